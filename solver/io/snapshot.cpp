#include "io/snapshot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <regex>
#include <stdexcept>
#include <system_error>

#include "io/files.hpp"
#include "measure/micro.hpp"

namespace celldem {
namespace fs = std::filesystem;

namespace {

// %.17g: reads back to the same double.
void put(std::string& out, double x) {
  char buf[32];
  const int n = std::snprintf(buf, sizeof buf, "%.17g", x);
  out.append(buf, static_cast<std::size_t>(n));
}

void put(std::string& out, std::int64_t x) { out += std::to_string(x); }

void put(std::string& out, const Vec3& v) {
  put(out, v[0]);
  out += ' ';
  put(out, v[1]);
  out += ' ';
  put(out, v[2]);
}

// One DataArray with one tuple per line; `value(k, out)` appends tuple k.
template <class AppendTuple>
void data_array(std::string& out, const char* type, const char* name, int components, std::size_t count,
                AppendTuple value) {
  out += "        <DataArray type=\"";
  out += type;
  out += "\"";
  if (name) {
    out += " Name=\"";
    out += name;
    out += "\"";
  }
  if (components > 1) out += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  out += " format=\"ascii\">\n";
  for (std::size_t k = 0; k < count; ++k) {
    out += "          ";
    value(k, out);
    out += '\n';
  }
  out += "        </DataArray>\n";
}

// Time, step and cell of the snapshot: ParaView reads TimeValue as the dataset's time.
void field_data(std::string& out, const Cell& cell, std::int64_t step, double time) {
  out += "    <FieldData>\n";
  out += "      <DataArray type=\"Float64\" Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">";
  put(out, time);
  out += "</DataArray>\n";
  out += "      <DataArray type=\"Int64\" Name=\"step\" NumberOfTuples=\"1\" format=\"ascii\">";
  put(out, step);
  out += "</DataArray>\n";
  out += "      <DataArray type=\"Float64\" Name=\"cell_h\" NumberOfComponents=\"9\" NumberOfTuples=\"1\" "
         "format=\"ascii\">";
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      if (r + c > 0) out += ' ';
      put(out, cell.h(r, c));
    }
  out += "</DataArray>\n";
  out += "    </FieldData>\n";
}

// LAMMPS boxes are "restricted triclinic": a along x, b in the xy plane, i.e. an upper triangular matrix
// with a positive diagonal (h = [[lx, xy, xz], [0, ly, yz], [0, 0, lz]]). A cell of another orientation is
// rotated into that frame (h = Q R, the dump shows R s and Q^T applied to every vector).
struct DumpFrame {
  Mat3 rotation = Mat3::Identity();  // Q^T: celldem frame -> dump frame
  Mat3 box = Mat3::Identity();       // R, upper triangular, positive diagonal
};

DumpFrame dump_frame(const Mat3& h) {
  DumpFrame f;
  const bool upper = h(1, 0) == 0.0 && h(2, 0) == 0.0 && h(2, 1) == 0.0;
  if (upper && h(0, 0) > 0.0 && h(1, 1) > 0.0 && h(2, 2) > 0.0) {
    f.box = h;
    return f;
  }
  const Eigen::HouseholderQR<Mat3> qr(h);
  Mat3 q = qr.householderQ();
  Mat3 r = qr.matrixQR().triangularView<Eigen::Upper>();
  for (int k = 0; k < 3; ++k)
    if (r(k, k) < 0.0) {  // Q R = (Q D)(D R) with D = diag(+-1): make the diagonal of R positive
      r.row(k) *= -1.0;
      q.col(k) *= -1.0;
    }
  f.rotation = q.transpose();
  f.box = r;
  return f;
}

void check_stem(const std::string& stem) {
  const bool ok = !stem.empty() && std::all_of(stem.begin(), stem.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
           c == '.';
  });
  if (!ok)
    throw std::invalid_argument("snapshot stem \"" + stem +
                                "\": use letters, digits, '_', '-' or '.' only (it names files and XML entries)");
}

}  // namespace

Vec3 wrapped_scaled(const Vec3& s) {
  Vec3 w;
  for (int k = 0; k < 3; ++k) {
    w[k] = s[k] - std::floor(s[k]);
    if (w[k] == 1.0) w[k] = 0.0;  // s just below a whole number rounds up to 1 (NaN stays NaN: visible)
  }
  return w;
}

Vec3 wrapped_position(const Cell& cell, const Vec3& s) { return cell.h * wrapped_scaled(s); }

std::vector<std::int32_t> contacts_per_particle(const State& state) {
  std::vector<std::int32_t> count(state.particles.size(), 0);
  const PairList& pl = state.pairs;
  for_each_pair(pl, [&](Index i, Index q) {
    if (!(pl.flags[q] & kTouching)) return;
    ++count[i];
    ++count[pl.neighbor[q]];
  });
  return count;
}

std::vector<ContactSnapshot> touching_contacts(const State& state) {
  const PairList& pl = state.pairs;
  const Mat3& h = state.cell.h;
  std::vector<ContactSnapshot> out;
  for_each_pair(pl, [&](Index i, Index q) {
    if (!(pl.flags[q] & kTouching)) return;
    ContactSnapshot c;
    c.i = i;
    c.j = pl.neighbor[q];
    const Vec3 image(pl.image[q][0], pl.image[q][1], pl.image[q][2]);
    c.branch = h * (state.particles.scaled[c.j] - state.particles.scaled[c.i] + image);
    const Vec3 n = c.branch.normalized();
    const Vec3& f = pl.force[q];
    c.normal_force = f.dot(n);
    c.tangential_force = f - c.normal_force * n;
    c.sliding = (pl.flags[q] & kSliding) != 0;
    out.push_back(c);
  });
  return out;
}

std::string particles_vtu(const State& state, std::int64_t step, double time) {
  const Particles& p = state.particles;
  const std::size_t n = p.size();
  const std::vector<std::int32_t> contacts = contacts_per_particle(state);
  const std::vector<Mat3> stress = particle_stresses(state);
  const std::vector<Vec3> net_force = net_contact_forces(state);
  std::string o;
  o += "<?xml version=\"1.0\"?>\n";
  o += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  o += "  <UnstructuredGrid>\n";
  field_data(o, state.cell, step, time);
  o += "    <Piece NumberOfPoints=\"" + std::to_string(n) + "\" NumberOfCells=\"" + std::to_string(n) + "\">\n";
  o += "      <PointData Scalars=\"radius\" Vectors=\"velocity\">\n";
  data_array(o, "Float64", "radius", 1, n, [&](std::size_t i, std::string& s) { put(s, p.radius[i]); });
  data_array(o, "Float64", "velocity", 3, n, [&](std::size_t i, std::string& s) { put(s, p.velocity[i]); });
  data_array(o, "Float64", "spin", 3, n, [&](std::size_t i, std::string& s) { put(s, p.spin[i]); });
  data_array(o, "Int32", "contacts", 1, n, [&](std::size_t i, std::string& s) { put(s, std::int64_t{contacts[i]}); });
  data_array(o, "Float64", "net_force", 3, n, [&](std::size_t i, std::string& s) { put(s, net_force[i]); });
  data_array(o, "Float64", "stress", 9, n, [&](std::size_t i, std::string& s) {  // row-major, compression +
    for (int r = 0; r < 3; ++r) {
      if (r) s += ' ';
      put(s, Vec3(stress[i].row(r).transpose()));
    }
  });
  data_array(o, "Int64", "id", 1, n, [&](std::size_t i, std::string& s) { put(s, static_cast<std::int64_t>(i)); });
  o += "      </PointData>\n";
  o += "      <Points>\n";
  data_array(o, "Float64", nullptr, 3, n,
             [&](std::size_t i, std::string& s) { put(s, wrapped_position(state.cell, p.scaled[i])); });
  o += "      </Points>\n";
  o += "      <Cells>\n";
  // One VTK_VERTEX (type 1) per particle: cell i is point i.
  data_array(o, "Int64", "connectivity", 1, n, [&](std::size_t i, std::string& s) { put(s, static_cast<std::int64_t>(i)); });
  data_array(o, "Int64", "offsets", 1, n, [&](std::size_t i, std::string& s) { put(s, static_cast<std::int64_t>(i + 1)); });
  data_array(o, "UInt8", "types", 1, n, [&](std::size_t, std::string& s) { s += '1'; });
  o += "      </Cells>\n";
  o += "    </Piece>\n";
  o += "  </UnstructuredGrid>\n";
  o += "</VTKFile>\n";
  return o;
}

std::string contacts_vtp(const State& state, std::int64_t step, double time) {
  const std::vector<ContactSnapshot> contacts = touching_contacts(state);
  const std::size_t m = contacts.size();
  std::string o;
  o += "<?xml version=\"1.0\"?>\n";
  o += "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  o += "  <PolyData>\n";
  field_data(o, state.cell, step, time);
  o += "    <Piece NumberOfPoints=\"" + std::to_string(2 * m) + "\" NumberOfVerts=\"0\" NumberOfLines=\"" +
       std::to_string(m) + "\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n";
  o += "      <CellData Scalars=\"normal_force\" Vectors=\"branch\">\n";
  data_array(o, "Float64", "branch", 3, m, [&](std::size_t c, std::string& s) { put(s, contacts[c].branch); });
  data_array(o, "Float64", "normal_force", 1, m,
             [&](std::size_t c, std::string& s) { put(s, contacts[c].normal_force); });
  data_array(o, "Float64", "tangential_force", 3, m,
             [&](std::size_t c, std::string& s) { put(s, contacts[c].tangential_force); });
  data_array(o, "UInt8", "sliding", 1, m, [&](std::size_t c, std::string& s) { s += contacts[c].sliding ? '1' : '0'; });
  data_array(o, "Int64", "i", 1, m, [&](std::size_t c, std::string& s) { put(s, std::int64_t{contacts[c].i}); });
  data_array(o, "Int64", "j", 1, m, [&](std::size_t c, std::string& s) { put(s, std::int64_t{contacts[c].j}); });
  o += "      </CellData>\n";
  o += "      <Points>\n";
  // Line c runs from point 2c (i's centre, wrapped) to point 2c + 1 (that centre plus the branch).
  data_array(o, "Float64", nullptr, 3, 2 * m, [&](std::size_t k, std::string& s) {
    const ContactSnapshot& c = contacts[k / 2];
    const Vec3 xi = wrapped_position(state.cell, state.particles.scaled[c.i]);
    put(s, k % 2 == 0 ? xi : Vec3(xi + c.branch));
  });
  o += "      </Points>\n";
  o += "      <Lines>\n";
  data_array(o, "Int64", "connectivity", 1, 2 * m,
             [&](std::size_t k, std::string& s) { put(s, static_cast<std::int64_t>(k)); });
  data_array(o, "Int64", "offsets", 1, m,
             [&](std::size_t c, std::string& s) { put(s, static_cast<std::int64_t>(2 * c + 2)); });
  o += "      </Lines>\n";
  o += "    </Piece>\n";
  o += "  </PolyData>\n";
  o += "</VTKFile>\n";
  return o;
}

std::string lammps_dump(const State& state, std::int64_t step) {
  const Particles& p = state.particles;
  const DumpFrame frame = dump_frame(state.cell.h);
  const Mat3& b = frame.box;
  const std::vector<std::int32_t> contacts = contacts_per_particle(state);
  std::string o;
  o += "ITEM: TIMESTEP\n";
  put(o, step);
  o += "\nITEM: NUMBER OF ATOMS\n";
  put(o, static_cast<std::int64_t>(p.size()));
  o += '\n';
  const double xy = b(0, 1), xz = b(0, 2), yz = b(1, 2);
  if (xy == 0.0 && xz == 0.0 && yz == 0.0) {
    o += "ITEM: BOX BOUNDS pp pp pp\n";
    for (int k = 0; k < 3; ++k) {
      o += "0 ";
      put(o, b(k, k));
      o += '\n';
    }
  } else {
    // LAMMPS writes the bounding box of the tilted cell and the tilt factors (origin at 0).
    const double x_low = std::min({0.0, xy, xz, xy + xz}), x_high = b(0, 0) + std::max({0.0, xy, xz, xy + xz});
    const double y_low = std::min(0.0, yz), y_high = b(1, 1) + std::max(0.0, yz);
    const double rows[3][3] = {{x_low, x_high, xy}, {y_low, y_high, xz}, {0.0, b(2, 2), yz}};
    o += "ITEM: BOX BOUNDS xy xz yz pp pp pp\n";
    for (const auto& row : rows) {
      put(o, row[0]);
      o += ' ';
      put(o, row[1]);
      o += ' ';
      put(o, row[2]);
      o += '\n';
    }
  }
  o += "ITEM: ATOMS id radius x y z vx vy vz wx wy wz contacts\n";
  for (std::size_t i = 0; i < p.size(); ++i) {
    put(o, static_cast<std::int64_t>(i + 1));
    o += ' ';
    put(o, p.radius[i]);
    o += ' ';
    put(o, Vec3(b * wrapped_scaled(p.scaled[i])));
    o += ' ';
    put(o, Vec3(frame.rotation * p.velocity[i]));
    o += ' ';
    put(o, Vec3(frame.rotation * p.spin[i]));
    o += ' ';
    put(o, std::int64_t{contacts[i]});
    o += '\n';
  }
  return o;
}

std::string pvd_collection(const std::vector<CollectionEntry>& entries) {
  std::string o;
  o += "<?xml version=\"1.0\"?>\n";
  o += "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
  o += "  <Collection>\n";
  for (const CollectionEntry& e : entries) {
    o += "    <DataSet timestep=\"";
    put(o, e.time);
    o += "\" group=\"\" part=\"0\" file=\"" + e.file + "\"/>\n";
  }
  o += "  </Collection>\n";
  o += "</VTKFile>\n";
  return o;
}

SnapshotWriter::SnapshotWriter(fs::path dir, std::string stem) : dir_(std::move(dir)), stem_(std::move(stem)) {
  check_stem(stem_);
  // Continue a collection left by an interrupted run: its entries, as this writer wrote them.
  std::error_code ec;
  if (!fs::is_regular_file(particles_collection(), ec)) return;
  const std::string text = read_file(particles_collection());
  std::string stem_pattern;  // the stem as a regular expression: '.' is its only special character
  for (char c : stem_) stem_pattern += c == '.' ? std::string("\\.") : std::string(1, c);
  const std::regex entry("<DataSet timestep=\"([^\"]*)\"[^>]* file=\"" + stem_pattern + "_(-?[0-9]+)\\.vtu\"");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), entry); it != std::sregex_iterator(); ++it) {
    try {
      entries_.push_back({std::stoll((*it)[2].str()), std::stod((*it)[1].str())});
    } catch (const std::exception&) {
      throw IoError(particles_collection().string() + ": cannot continue the collection: unreadable entry \"" +
                    it->str() + "\"");
    }
  }
}

fs::path SnapshotWriter::particles_file(std::int64_t step) const {
  return dir_ / (stem_ + "_" + std::to_string(step) + ".vtu");
}
fs::path SnapshotWriter::contacts_file(std::int64_t step) const {
  return dir_ / (stem_ + "_contacts_" + std::to_string(step) + ".vtp");
}
fs::path SnapshotWriter::dump_file(std::int64_t step) const {
  return dir_ / (stem_ + "_" + std::to_string(step) + ".dump");
}
fs::path SnapshotWriter::particles_collection() const { return dir_ / (stem_ + ".pvd"); }
fs::path SnapshotWriter::contacts_collection() const { return dir_ / (stem_ + "_contacts.pvd"); }

void SnapshotWriter::write(const State& state, std::int64_t step, double time) {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw_io_error(dir_, "cannot create the snapshot folder", ec.value());

  // The data files first, then the collections that list them.
  write_file_atomic(particles_file(step), particles_vtu(state, step, time));
  write_file_atomic(contacts_file(step), contacts_vtp(state, step, time));
  write_file_atomic(dump_file(step), lammps_dump(state, step));

  // A step at or before one already listed: a resumed run replaces what followed its checkpoint.
  std::erase_if(entries_, [&](const Entry& e) { return e.step >= step; });
  entries_.push_back({step, time});
  std::vector<CollectionEntry> particles, contacts;
  for (const Entry& e : entries_) {
    particles.push_back({e.time, particles_file(e.step).filename().string()});
    contacts.push_back({e.time, contacts_file(e.step).filename().string()});
  }
  write_file_atomic(contacts_collection(), pvd_collection(contacts));
  write_file_atomic(particles_collection(), pvd_collection(particles));
}

}  // namespace celldem
