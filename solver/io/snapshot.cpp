#include "io/snapshot.hpp"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <regex>
#include <stdexcept>
#include <system_error>
#include <type_traits>

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
void put(std::string& out, std::int32_t x) { out += std::to_string(x); }
void put(std::string& out, std::uint8_t x) { out += std::to_string(x); }

void put(std::string& out, const Vec3& v) {
  put(out, v[0]);
  out += ' ';
  put(out, v[1]);
  out += ' ';
  put(out, v[2]);
}

// The arrays' bytes are the host's: the files declare its byte order, and VTK readers swap when theirs differs.
static_assert(std::endian::native == std::endian::little || std::endian::native == std::endian::big,
              "snapshots need a little- or big-endian host");
constexpr const char* kByteOrder = std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian";
static_assert(sizeof(double) == 8 && std::numeric_limits<double>::is_iec559, "Float64 must be an IEEE double");

template <class T>
constexpr const char* vtk_type() {
  if constexpr (std::is_same_v<T, double>) return "Float64";
  else if constexpr (std::is_same_v<T, std::int64_t>) return "Int64";
  else if constexpr (std::is_same_v<T, std::int32_t>) return "Int32";
  else {
    static_assert(std::is_same_v<T, std::uint8_t>);
    return "UInt8";
  }
}

void append_uint64(std::string& out, std::uint64_t x) { out.append(reinterpret_cast<const char*>(&x), sizeof x); }

// vtkZLibDataCompressor's layout: a header of UInt64s [blocks, block size, size of a partial last block (0: the
// last block is whole), compressed size of each block], then the blocks, each compressed on its own.
constexpr std::size_t kZlibBlock = 32768;  // bytes of uncompressed data per block (VTK's default)

void append_compressed(std::string& out, const char* data, std::size_t size) {
  const std::size_t blocks = (size + kZlibBlock - 1) / kZlibBlock;
  std::vector<std::uint64_t> header = {blocks, kZlibBlock, size % kZlibBlock};
  std::string compressed;
  std::vector<Bytef> buffer(compressBound(kZlibBlock));
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t length = std::min(kZlibBlock, size - b * kZlibBlock);
    uLongf written = static_cast<uLongf>(buffer.size());
    const int rc = compress2(buffer.data(), &written, reinterpret_cast<const Bytef*>(data + b * kZlibBlock),
                             static_cast<uLong>(length), Z_DEFAULT_COMPRESSION);
    if (rc != Z_OK) throw IoError("snapshot: zlib cannot compress an array (zlib error " + std::to_string(rc) + ")");
    header.push_back(written);
    compressed.append(reinterpret_cast<const char*>(buffer.data()), written);
  }
  for (const std::uint64_t h : header) append_uint64(out, h);
  out += compressed;
}

// One VTK XML file: the XML, and with an appended format every array's bytes after it in <AppendedData>,
// each at the offset its DataArray names (from the first byte after the '_').
class VtkFile {
 public:
  VtkFile(const char* type, SnapshotFormat format) : format_(format) {
    xml_ += "<?xml version=\"1.0\"?>\n";
    xml_ += "<VTKFile type=\"";
    xml_ += type;
    xml_ += "\" version=\"1.0\" byte_order=\"";
    xml_ += kByteOrder;
    xml_ += "\" header_type=\"UInt64\"";
    if (format_ == SnapshotFormat::Zlib) xml_ += " compressor=\"vtkZLibDataCompressor\"";
    xml_ += ">\n";
  }

  // Text of the XML structure around the arrays.
  VtkFile& operator<<(const std::string& text) {
    xml_ += text;
    return *this;
  }

  // One DataArray of `values.size() / components` tuples; as text one tuple per line, else appended. Field
  // data (tuples_attribute) says its number of tuples, as VTK's field data requires.
  template <class T>
  void array(const char* indent, const char* name, int components, const std::vector<T>& values,
             bool tuples_attribute = false) {
    xml_ += indent;
    xml_ += "<DataArray type=\"";
    xml_ += vtk_type<T>();
    xml_ += "\"";
    if (name) {
      xml_ += " Name=\"";
      xml_ += name;
      xml_ += "\"";
    }
    if (components > 1) xml_ += " NumberOfComponents=\"" + std::to_string(components) + "\"";
    if (tuples_attribute) xml_ += " NumberOfTuples=\"" + std::to_string(values.size() / components) + "\"";
    if (format_ != SnapshotFormat::Ascii) {
      xml_ += " format=\"appended\" offset=\"" + std::to_string(appended_.size()) + "\"/>\n";
      const char* bytes = reinterpret_cast<const char*>(values.data());
      const std::size_t size = values.size() * sizeof(T);
      if (format_ == SnapshotFormat::Zlib) {
        append_compressed(appended_, bytes, size);
      } else {
        append_uint64(appended_, size);
        appended_.append(bytes, size);
      }
      return;
    }
    xml_ += " format=\"ascii\">\n";
    for (std::size_t k = 0; k < values.size(); ++k) {
      if (k % components == 0) {
        xml_ += indent;
        xml_ += "  ";
      }
      put(xml_, values[k]);
      xml_ += (k + 1) % components == 0 ? '\n' : ' ';
    }
    xml_ += indent;
    xml_ += "</DataArray>\n";
  }

  // The whole file: the XML up to the end of the dataset's element, then the appended data, if any.
  std::string finish() && {
    if (format_ != SnapshotFormat::Ascii) {
      xml_.reserve(xml_.size() + appended_.size() + 64);
      xml_ += "  <AppendedData encoding=\"raw\">\n   _";
      xml_ += appended_;
      xml_ += "\n  </AppendedData>\n";
    }
    xml_ += "</VTKFile>\n";
    return std::move(xml_);
  }

 private:
  SnapshotFormat format_;
  std::string xml_;
  std::string appended_;
};

std::vector<double> flat(const std::vector<Vec3>& v) {
  std::vector<double> out;
  out.reserve(3 * v.size());
  for (const Vec3& x : v) out.insert(out.end(), {x[0], x[1], x[2]});
  return out;
}

// Time, step and cell of the snapshot: ParaView reads TimeValue as the dataset's time.
void field_data(VtkFile& out, const Cell& cell, std::int64_t step, double time) {
  out << "    <FieldData>\n";
  out.array("      ", "TimeValue", 1, std::vector<double>{time}, true);
  out.array("      ", "step", 1, std::vector<std::int64_t>{step}, true);
  std::vector<double> h;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) h.push_back(cell.h(r, c));
  out.array("      ", "cell_h", 9, h, true);
  out << "    </FieldData>\n";
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

std::string particles_vtu(const State& state, std::int64_t step, double time, SnapshotFormat format) {
  const Particles& p = state.particles;
  const std::size_t n = p.size();
  const std::vector<std::int32_t> contacts = contacts_per_particle(state);
  const std::vector<Mat3> stress = particle_stresses(state);
  std::vector<double> stress_rows;  // row-major, compression positive
  stress_rows.reserve(9 * n);
  for (const Mat3& m : stress)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) stress_rows.push_back(m(r, c));
  std::vector<Vec3> x(n);
  for (std::size_t i = 0; i < n; ++i) x[i] = wrapped_position(state.cell, p.scaled[i]);
  std::vector<std::int64_t> ids(n), offsets(n);
  for (std::size_t i = 0; i < n; ++i) ids[i] = static_cast<std::int64_t>(i), offsets[i] = static_cast<std::int64_t>(i + 1);

  VtkFile o("UnstructuredGrid", format);
  o << "  <UnstructuredGrid>\n";
  field_data(o, state.cell, step, time);
  o << "    <Piece NumberOfPoints=\"" + std::to_string(n) + "\" NumberOfCells=\"" + std::to_string(n) + "\">\n";
  o << "      <PointData Scalars=\"radius\" Vectors=\"velocity\">\n";
  const char* in = "        ";
  o.array(in, "radius", 1, p.radius);
  o.array(in, "velocity", 3, flat(p.velocity));
  o.array(in, "spin", 3, flat(p.spin));
  o.array(in, "contacts", 1, contacts);
  o.array(in, "net_force", 3, flat(net_contact_forces(state)));
  o.array(in, "stress", 9, stress_rows);
  o.array(in, "id", 1, ids);
  o << "      </PointData>\n";
  o << "      <Points>\n";
  o.array(in, nullptr, 3, flat(x));
  o << "      </Points>\n";
  o << "      <Cells>\n";
  // One VTK_VERTEX (type 1) per particle: cell i is point i.
  o.array(in, "connectivity", 1, ids);
  o.array(in, "offsets", 1, offsets);
  o.array(in, "types", 1, std::vector<std::uint8_t>(n, 1));
  o << "      </Cells>\n";
  o << "    </Piece>\n";
  o << "  </UnstructuredGrid>\n";
  return std::move(o).finish();
}

std::string contacts_vtp(const State& state, std::int64_t step, double time, SnapshotFormat format) {
  const std::vector<ContactSnapshot> contacts = touching_contacts(state);
  const std::size_t m = contacts.size();
  std::vector<Vec3> branch(m), tangential(m), points(2 * m);
  std::vector<double> normal(m);
  std::vector<std::uint8_t> sliding(m);
  std::vector<std::int64_t> pi(m), pj(m), connectivity(2 * m), offsets(m);
  for (std::size_t c = 0; c < m; ++c) {
    const ContactSnapshot& k = contacts[c];
    branch[c] = k.branch;
    normal[c] = k.normal_force;
    tangential[c] = k.tangential_force;
    sliding[c] = k.sliding ? 1 : 0;
    pi[c] = k.i;
    pj[c] = k.j;
    // Line c runs from point 2c (i's centre, wrapped) to point 2c + 1 (that centre plus the branch).
    points[2 * c] = wrapped_position(state.cell, state.particles.scaled[k.i]);
    points[2 * c + 1] = points[2 * c] + k.branch;
    connectivity[2 * c] = static_cast<std::int64_t>(2 * c);
    connectivity[2 * c + 1] = static_cast<std::int64_t>(2 * c + 1);
    offsets[c] = static_cast<std::int64_t>(2 * c + 2);
  }

  VtkFile o("PolyData", format);
  o << "  <PolyData>\n";
  field_data(o, state.cell, step, time);
  o << "    <Piece NumberOfPoints=\"" + std::to_string(2 * m) + "\" NumberOfVerts=\"0\" NumberOfLines=\"" +
           std::to_string(m) + "\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n";
  o << "      <CellData Scalars=\"normal_force\" Vectors=\"branch\">\n";
  const char* in = "        ";
  o.array(in, "branch", 3, flat(branch));
  o.array(in, "normal_force", 1, normal);
  o.array(in, "tangential_force", 3, flat(tangential));
  o.array(in, "sliding", 1, sliding);
  o.array(in, "i", 1, pi);
  o.array(in, "j", 1, pj);
  o << "      </CellData>\n";
  o << "      <Points>\n";
  o.array(in, nullptr, 3, flat(points));
  o << "      </Points>\n";
  o << "      <Lines>\n";
  o.array(in, "connectivity", 1, connectivity);
  o.array(in, "offsets", 1, offsets);
  o << "      </Lines>\n";
  o << "    </Piece>\n";
  o << "  </PolyData>\n";
  return std::move(o).finish();
}

std::string lammps_dump(const State& state, std::int64_t step) {
  const Particles& p = state.particles;
  const DumpFrame frame = dump_frame(state.cell.h);
  const Mat3& b = frame.box;
  const std::vector<std::int32_t> contacts = contacts_per_particle(state);
  const std::vector<Vec3> net_force = net_contact_forces(state);
  const std::vector<Mat3> stress = particle_stresses(state);
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
  o += "ITEM: ATOMS id radius x y z vx vy vz wx wy wz contacts fx fy fz c_stress[1] c_stress[2] c_stress[3] "
       "c_stress[4] c_stress[5] c_stress[6]\n";
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
    o += ' ';
    put(o, Vec3(frame.rotation * net_force[i]));
    // The tensor in the dump's frame, as LAMMPS's six: xx yy zz xy xz yz (it is symmetric: the mean of the two
    // off-diagonal entries is either of them).
    const Mat3 t = frame.rotation * stress[i] * frame.rotation.transpose();
    for (const double x : {t(0, 0), t(1, 1), t(2, 2), 0.5 * (t(0, 1) + t(1, 0)), 0.5 * (t(0, 2) + t(2, 0)),
                           0.5 * (t(1, 2) + t(2, 1))}) {
      o += ' ';
      put(o, x);
    }
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

SnapshotWriter::SnapshotWriter(fs::path dir, std::string stem, SnapshotFormat format)
    : dir_(std::move(dir)), stem_(std::move(stem)), format_(format) {
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
  write_file_atomic(particles_file(step), particles_vtu(state, step, time, format_));
  write_file_atomic(contacts_file(step), contacts_vtp(state, step, time, format_));
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
