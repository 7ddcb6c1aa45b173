// Snapshots (solver/io/snapshot.hpp): the .vtu, .vtp, .pvd and dump files of a sheared cell with contacts
// are read back (with a small XML reader here, which also decodes VTK's appended raw and zlib-compressed
// arrays and checks their layout) and every number, in each encoding, is checked against values computed in
// the test from the state: wrapped positions, radii, contact counts from the pair list, each contact's normal
// force against the spring law kn * overlap. Collections list every snapshot and survive a resume; a
// failed write throws naming the file and leaves nothing under a final name.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <bit>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <random>
#include <sstream>

#include "contact/contact_forces.hpp"
#include "helpers.hpp"
#include "io/files.hpp"
#include "io/snapshot.hpp"
#include "measure/micro.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {

// The encoding's deck name in test names and messages (found by argument-dependent lookup, so in celldem).
void PrintTo(SnapshotFormat format, std::ostream* os);
void PrintTo(SnapshotFormat format, std::ostream* os) { *os << name_of(format, kSnapshotFormatNames); }

namespace {

constexpr double kKn = 1e4, kFriction = 0.1;

// ---- a minimal XML reader: elements, attributes and text; throws on a malformed document ----

struct XmlElement {
  std::string name;
  std::map<std::string, std::string> attributes;
  std::string text;
  std::vector<XmlElement> children;
};

class XmlReader {
 public:
  explicit XmlReader(const std::string& text) : t_(text) {}

  XmlElement document() {
    skip_space();
    if (t_.compare(at_, 5, "<?xml") == 0) at_ = t_.find("?>", at_) + 2;
    skip_space();
    XmlElement root = element();
    skip_space();
    if (at_ != t_.size()) fail("text after the root element");
    return root;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("XML at offset " + std::to_string(at_) + ": " + what);
  }
  void skip_space() {
    while (at_ < t_.size() && std::isspace(static_cast<unsigned char>(t_[at_]))) ++at_;
  }
  std::string name() {
    const std::size_t begin = at_;
    while (at_ < t_.size() && (std::isalnum(static_cast<unsigned char>(t_[at_])) || t_[at_] == '_')) ++at_;
    if (at_ == begin) fail("expected a name");
    return t_.substr(begin, at_ - begin);
  }
  void expect(char c) {
    if (at_ >= t_.size() || t_[at_] != c) fail(std::string("expected '") + c + "'");
    ++at_;
  }
  XmlElement element() {
    expect('<');
    XmlElement e;
    e.name = name();
    for (;;) {
      skip_space();
      if (t_.compare(at_, 2, "/>") == 0) {
        at_ += 2;
        return e;
      }
      if (at_ < t_.size() && t_[at_] == '>') break;
      const std::string key = name();
      expect('=');
      expect('"');
      const std::size_t end = t_.find('"', at_);
      if (end == std::string::npos) fail("unterminated attribute");
      if (!e.attributes.emplace(key, t_.substr(at_, end - at_)).second) fail("duplicate attribute " + key);
      at_ = end + 1;
    }
    ++at_;
    for (;;) {
      const std::size_t lt = t_.find('<', at_);
      if (lt == std::string::npos) fail("unclosed element " + e.name);
      e.text += t_.substr(at_, lt - at_);
      at_ = lt;
      if (t_.compare(at_, 2, "</") == 0) {
        at_ += 2;
        if (name() != e.name) fail("mismatched closing tag of " + e.name);
        expect('>');
        return e;
      }
      e.children.push_back(element());
    }
  }

  const std::string& t_;
  std::size_t at_ = 0;
};

XmlElement read_xml(const std::filesystem::path& path) {
  const std::string text = testing::read_bytes(path);
  return XmlReader(text).document();
}

// The first element named `name` (with Name="array_name" when given), depth first; fails the test if none.
const XmlElement* find(const XmlElement& e, const std::string& name, const std::string& array_name = "") {
  if (e.name == name && (array_name.empty() || (e.attributes.count("Name") && e.attributes.at("Name") == array_name)))
    return &e;
  for (const XmlElement& c : e.children)
    if (const XmlElement* f = find(c, name, array_name)) return f;
  return nullptr;
}

std::vector<double> numbers(const std::string& text) {
  std::istringstream in(text);
  std::vector<double> v;
  for (std::string w; in >> w;) v.push_back(std::strtod(w.c_str(), nullptr));
  return v;
}

// ---- VTK files: the XML, and the appended bytes when the arrays are stored there ----

struct VtkDocument {
  XmlElement root;
  std::string appended;  // the bytes after <AppendedData>'s '_', up to </AppendedData> (none for ascii)
};

// The appended data comes last: the XML before it, closed as the file closes it, is a document of its own.
VtkDocument parse_vtk(const std::string& text) {
  VtkDocument doc;
  const std::size_t at = text.find("<AppendedData");
  if (at == std::string::npos) {
    doc.root = XmlReader(text).document();
    return doc;
  }
  const std::string xml = text.substr(0, at) + "</VTKFile>\n";
  doc.root = XmlReader(xml).document();
  const std::size_t open_end = text.find('>', at);
  EXPECT_EQ(text.substr(at, open_end + 1 - at), "<AppendedData encoding=\"raw\">");
  const std::size_t underscore = text.find('_', open_end);
  EXPECT_NE(underscore, std::string::npos);
  for (std::size_t k = open_end + 1; k < underscore; ++k) EXPECT_TRUE(std::isspace(static_cast<unsigned char>(text[k])));
  const std::size_t close = text.rfind("</AppendedData>");
  EXPECT_NE(close, std::string::npos);
  if (underscore == std::string::npos || close == std::string::npos || close < underscore) return doc;
  std::string tail = text.substr(close + std::strlen("</AppendedData>"));
  std::erase_if(tail, [](char c) { return std::isspace(static_cast<unsigned char>(c)); });
  EXPECT_EQ(tail, "</VTKFile>");
  doc.appended = text.substr(underscore + 1, close - underscore - 1);
  return doc;
}

VtkDocument read_vtk(const std::filesystem::path& path) { return parse_vtk(testing::read_bytes(path)); }

// The elements named `name`, depth first in document order.
void find_all(const XmlElement& e, const std::string& name, std::vector<const XmlElement*>& out) {
  if (e.name == name) out.push_back(&e);
  for (const XmlElement& c : e.children) find_all(c, name, out);
}

std::uint64_t uint64_at(const std::string& bytes, std::size_t at) {
  std::uint64_t x = 0;
  if (at + 8 > bytes.size()) throw std::runtime_error("appended data ends inside a header");
  std::memcpy(&x, bytes.data() + at, 8);
  return x;
}

struct Appended {
  std::string bytes;    // the array's bytes, decompressed
  std::size_t end = 0;  // where its data ends in the appended section
  std::vector<std::uint64_t> zlib_header;  // blocks, block size, partial last block, compressed sizes
};

// One array of the appended section at `offset`: a UInt64 byte count and the bytes, or with zlib the block
// header and the blocks, each inflated to its size.
Appended appended_at(const VtkDocument& doc, std::size_t offset) {
  const std::string& data = doc.appended;
  Appended a;
  if (!doc.root.attributes.count("compressor")) {
    const std::uint64_t size = uint64_at(data, offset);
    if (offset + 8 + size > data.size()) throw std::runtime_error("appended array runs past the data");
    a.bytes = data.substr(offset + 8, size);
    a.end = offset + 8 + size;
    return a;
  }
  EXPECT_EQ(doc.root.attributes.at("compressor"), "vtkZLibDataCompressor");
  const std::uint64_t blocks = uint64_at(data, offset), block_size = uint64_at(data, offset + 8),
                      last = uint64_at(data, offset + 16);
  a.zlib_header = {blocks, block_size, last};
  std::size_t at = offset + 24 + 8 * blocks;
  for (std::uint64_t b = 0; b < blocks; ++b) {
    const std::uint64_t compressed = uint64_at(data, offset + 24 + 8 * b);
    a.zlib_header.push_back(compressed);
    if (at + compressed > data.size()) throw std::runtime_error("compressed block runs past the data");
    uLongf size = static_cast<uLongf>(b + 1 == blocks && last != 0 ? last : block_size);
    std::string block(size, '\0');
    EXPECT_EQ(uncompress(reinterpret_cast<Bytef*>(block.data()), &size, reinterpret_cast<const Bytef*>(data.data() + at),
                         static_cast<uLong>(compressed)),
              Z_OK);
    EXPECT_EQ(size, block.size()) << "block " << b;  // inflates to exactly the size the header gives
    a.bytes += block;
    at += compressed;
  }
  a.end = at;
  return a;
}

template <class T>
std::vector<double> convert(const std::string& bytes) {
  EXPECT_EQ(bytes.size() % sizeof(T), 0u);
  std::vector<double> v(bytes.size() / sizeof(T));
  for (std::size_t k = 0; k < v.size(); ++k) {
    T x;
    std::memcpy(&x, bytes.data() + k * sizeof(T), sizeof(T));
    v[k] = static_cast<double>(x);  // exact: every integer written here is below 2^53
  }
  return v;
}

// The values of one DataArray, as doubles.
std::vector<double> values(const VtkDocument& doc, const XmlElement& e) {
  if (e.attributes.at("format") == "ascii") return numbers(e.text);
  EXPECT_EQ(e.attributes.at("format"), "appended");
  const std::string bytes = appended_at(doc, std::stoull(e.attributes.at("offset"))).bytes;
  const std::string& type = e.attributes.at("type");
  if (type == "Float64") return convert<double>(bytes);
  if (type == "Int64") return convert<std::int64_t>(bytes);
  if (type == "Int32") return convert<std::int32_t>(bytes);
  if (type == "UInt8") return convert<std::uint8_t>(bytes);
  ADD_FAILURE() << "unexpected type " << type;
  return {};
}

// The file is stored as `format` says: the header, every array's format attribute, and the appended arrays
// one after the other from offset 0 to the end of the data (nothing between, nothing left over).
void expect_encoding(const VtkDocument& doc, SnapshotFormat format) {
  const auto& attributes = doc.root.attributes;
  EXPECT_EQ(attributes.at("byte_order"), std::endian::native == std::endian::little ? "LittleEndian" : "BigEndian");
  EXPECT_EQ(attributes.at("header_type"), "UInt64");
  EXPECT_EQ(attributes.count("compressor"), format == SnapshotFormat::Zlib ? 1u : 0u);
  std::vector<const XmlElement*> arrays;
  find_all(doc.root, "DataArray", arrays);
  EXPECT_FALSE(arrays.empty());
  std::size_t end = 0;
  for (const XmlElement* e : arrays) {
    if (format == SnapshotFormat::Ascii) {
      EXPECT_EQ(e->attributes.at("format"), "ascii");
      continue;
    }
    EXPECT_EQ(e->attributes.at("format"), "appended");
    EXPECT_EQ(e->attributes.count("offset"), 1u);
    if (!e->attributes.count("offset")) continue;
    EXPECT_EQ(std::stoull(e->attributes.at("offset")), end);
    end = appended_at(doc, end).end;
  }
  if (format == SnapshotFormat::Ascii) {
    EXPECT_TRUE(doc.appended.empty());
  } else {
    std::string rest = doc.appended.substr(std::min(end, doc.appended.size()));
    std::erase_if(rest, [](char c) { return std::isspace(static_cast<unsigned char>(c)); });
    EXPECT_EQ(rest, "");  // only the line break before </AppendedData>
    EXPECT_GT(doc.appended.size(), end);
  }
}

std::vector<double> array(const VtkDocument& doc, const std::string& array_name, std::size_t expected_size) {
  const XmlElement* e = find(doc.root, "DataArray", array_name);
  EXPECT_NE(e, nullptr) << array_name;
  if (!e) return std::vector<double>(expected_size, 0.0);
  std::vector<double> v = values(doc, *e);
  EXPECT_EQ(v.size(), expected_size) << array_name;
  v.resize(expected_size, 0.0);
  return v;
}

// The array inside <Points>.
std::vector<double> points(const VtkDocument& doc, std::size_t expected_size) {
  const XmlElement* p = find(doc.root, "Points");
  EXPECT_NE(p, nullptr);
  if (!p || p->children.empty()) return std::vector<double>(expected_size, 0.0);
  EXPECT_EQ(p->children[0].attributes.at("NumberOfComponents"), "3");
  std::vector<double> v = values(doc, p->children[0]);
  EXPECT_EQ(v.size(), expected_size);
  v.resize(expected_size, 0.0);
  return v;
}

Vec3 vec_at(const std::vector<double>& v, std::size_t k) { return Vec3(v[3 * k], v[3 * k + 1], v[3 * k + 2]); }

// ---- the state ----

// A sheared cell (upper triangular h), particles displaced by whole cells (scaled positions outside
// [0, 1)), velocities and spins, and contacts with history, some across the boundary and some sliding.
State sheared_state() {
  std::mt19937_64 gen(23);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  State s = testing::lattice_state(3, 0.5, Vec3(0.97, 0.98, 0.99), 0.05);
  s.cell.h(0, 1) = 0.1;
  s.cell.h(1, 2) = -0.05;
  s.cell.h(0, 2) = 0.03;
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    s.particles.radius[i] = 0.5 + 0.01 * u(gen);
    s.particles.scaled[i] += testing::draw_vec3(u, gen) * 1e-3 + Vec3(i % 2, -(int)(i % 3), 2.0 * (i % 5 == 0));
    s.particles.velocity[i] = testing::draw_vec3(u, gen);
    s.particles.spin[i] = testing::draw_vec3(u, gen) * 3.0;
  }
  s.cell.velocity_gradient = (Mat3() << 1e-3, 2e-4, 0, 0, -1e-3, 0, 0, 5e-5, 0).finished();
  const Model model = make_model(testing::model_deck(kKn, kKn, 1e-4), s.particles.radius);
  rebuild_pairs(model, s);
  compute_contact_forces(model, kFriction, s);
  // Stretch the spring of every other contact far beyond the Coulomb limit, so that those slide.
  for (std::size_t q = 0; q < s.pairs.size(); ++q)
    if ((s.pairs.flags[q] & kTouching) && q % 2 == 0) s.pairs.tangential[q] = Vec3(0.05, -0.03, 0.02);
  compute_contact_forces(model, kFriction, s);
  return s;
}

// Wrapped position computed here, independently of the writer.
Vec3 primary_position(const State& s, std::size_t i) {
  Vec3 w = s.particles.scaled[i];
  for (int k = 0; k < 3; ++k) w[k] -= std::floor(w[k]);
  return s.cell.h * w;
}

// Touching pairs per particle, counted here from the pair list.
std::vector<int> contact_count(const State& s) {
  std::vector<int> count(s.particles.size(), 0);
  for_each_pair(s.pairs, [&](Index i, Index q) {
    if (s.pairs.flags[q] & kTouching) count[i]++, count[s.pairs.neighbor[q]]++;
  });
  return count;
}

// x lies in the primary cell and differs from h s by whole cells.
void expect_same_place(const State& s, std::size_t i, const Vec3& x) {
  const Vec3 sx = s.cell.h.inverse() * x;
  for (int k = 0; k < 3; ++k) {
    EXPECT_GE(sx[k], -1e-12) << i;
    EXPECT_LT(sx[k], 1.0 + 1e-12) << i;
    const double shift = s.particles.scaled[i][k] - sx[k];
    EXPECT_NEAR(shift, std::round(shift), 1e-12) << i;
  }
  EXPECT_NEAR((x - primary_position(s, i)).norm(), 0.0, 1e-12) << i;
}

// Every encoding: the same checks of every number (binary and zlib hold the doubles' bytes, ascii %.17g).
class SnapshotFormats : public ::testing::TestWithParam<SnapshotFormat> {};

INSTANTIATE_TEST_SUITE_P(Snapshot, SnapshotFormats,
                         ::testing::Values(SnapshotFormat::Binary, SnapshotFormat::Zlib, SnapshotFormat::Ascii),
                         [](const auto& info) { return std::string(name_of(info.param, kSnapshotFormatNames)); });

TEST_P(SnapshotFormats, ParticlesFileHoldsWrappedPositionsRadiiAndContactCounts) {
  const State s = sheared_state();
  ASSERT_GT(s.touching, 10);
  testing::TempDir dir;
  SnapshotWriter writer(dir.path(), "snap", GetParam());
  writer.write(s, 1234, 0.5);
  const VtkDocument vtu = read_vtk(writer.particles_file(1234));
  expect_encoding(vtu, GetParam());
  EXPECT_EQ(vtu.root.attributes.at("type"), "UnstructuredGrid");
  const std::size_t n = s.particles.size();
  const XmlElement* piece = find(vtu.root, "Piece");
  ASSERT_NE(piece, nullptr);
  EXPECT_EQ(piece->attributes.at("NumberOfPoints"), std::to_string(n));
  EXPECT_EQ(piece->attributes.at("NumberOfCells"), std::to_string(n));

  const std::vector<double> x = points(vtu, 3 * n);
  const std::vector<double> radius = array(vtu, "radius", n);
  const std::vector<double> velocity = array(vtu, "velocity", 3 * n);
  const std::vector<double> spin = array(vtu, "spin", 3 * n);
  const std::vector<double> contacts = array(vtu, "contacts", n);
  const std::vector<double> id = array(vtu, "id", n);
  const std::vector<double> net_force = array(vtu, "net_force", 3 * n);
  const std::vector<double> stress = array(vtu, "stress", 9 * n);
  const std::vector<Vec3> expected_force = net_contact_forces(s);
  const std::vector<Mat3> expected_stress = particle_stresses(s);
  const std::vector<int> expected_contacts = contact_count(s);
  bool any_wrapped = false;
  for (std::size_t i = 0; i < n; ++i) {
    expect_same_place(s, i, vec_at(x, i));
    any_wrapped |= (vec_at(x, i) - s.cell.h * s.particles.scaled[i]).norm() > 0.1;
    EXPECT_EQ(radius[i], s.particles.radius[i]);  // %.17g reads back exactly
    EXPECT_EQ(vec_at(velocity, i), s.particles.velocity[i]);
    EXPECT_EQ(vec_at(spin, i), s.particles.spin[i]);
    EXPECT_EQ(contacts[i], expected_contacts[i]) << i;
    EXPECT_EQ(id[i], static_cast<double>(i));
    EXPECT_EQ(vec_at(net_force, i), expected_force[i]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(stress[9 * i + 3 * r + c], expected_stress[i](r, c)) << i;
  }
  EXPECT_TRUE(any_wrapped);

  // One vertex per particle.
  EXPECT_EQ(array(vtu, "types", n), std::vector<double>(n, 1.0));
  const std::vector<double> offsets = array(vtu, "offsets", n);
  for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(offsets[i], static_cast<double>(i + 1));
  // Time, step and cell as field data.
  EXPECT_EQ(array(vtu, "TimeValue", 1)[0], 0.5);
  EXPECT_EQ(array(vtu, "step", 1)[0], 1234.0);
  const std::vector<double> h = array(vtu, "cell_h", 9);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) EXPECT_EQ(h[3 * r + c], s.cell.h(r, c));
}

TEST_P(SnapshotFormats, ContactFileHoldsEveryTouchingPairWithItsForces) {
  const State s = sheared_state();
  testing::TempDir dir;
  SnapshotWriter writer(dir.path(), "snap", GetParam());
  writer.write(s, 7, 0.25);
  const VtkDocument vtp = read_vtk(writer.contacts_file(7));
  expect_encoding(vtp, GetParam());
  EXPECT_EQ(vtp.root.attributes.at("type"), "PolyData");

  std::vector<std::size_t> touching;
  for (std::size_t q = 0; q < s.pairs.size(); ++q)
    if (s.pairs.flags[q] & kTouching) touching.push_back(q);
  const std::size_t m = touching.size();
  ASSERT_EQ(static_cast<std::int64_t>(m), s.touching);
  const XmlElement* piece = find(vtp.root, "Piece");
  ASSERT_NE(piece, nullptr);
  EXPECT_EQ(piece->attributes.at("NumberOfLines"), std::to_string(m));
  EXPECT_EQ(piece->attributes.at("NumberOfPoints"), std::to_string(2 * m));

  const std::vector<double> x = points(vtp, 6 * m);
  const std::vector<double> branch = array(vtp, "branch", 3 * m);
  const std::vector<double> normal_force = array(vtp, "normal_force", m);
  const std::vector<double> tangential = array(vtp, "tangential_force", 3 * m);
  const std::vector<double> sliding = array(vtp, "sliding", m);
  const std::vector<double> pi = array(vtp, "i", m), pj = array(vtp, "j", m);
  const std::vector<double> connectivity = array(vtp, "connectivity", 2 * m);
  const std::vector<double> offsets = array(vtp, "offsets", m);
  int across_boundary = 0, sliding_count = 0;
  for (std::size_t c = 0; c < m; ++c) {
    const std::size_t q = touching[c];
    const Index i = s.pairs.owner_of(q), j = s.pairs.neighbor[q];
    EXPECT_EQ(pi[c], i);
    EXPECT_EQ(pj[c], j);
    EXPECT_EQ(connectivity[2 * c], 2.0 * c);
    EXPECT_EQ(connectivity[2 * c + 1], 2.0 * c + 1);
    EXPECT_EQ(offsets[c], 2.0 * c + 2);
    const auto& n = s.pairs.image[q];
    across_boundary += n[0] != 0 || n[1] != 0 || n[2] != 0;

    // The line starts at i's wrapped centre and ends at the image of j's centre touching it.
    const Vec3 l = s.cell.h * (s.particles.scaled[j] - s.particles.scaled[i] + Vec3(n[0], n[1], n[2]));
    EXPECT_NEAR((vec_at(branch, c) - l).norm(), 0.0, 1e-14);
    expect_same_place(s, i, vec_at(x, 2 * c));
    EXPECT_NEAR((vec_at(x, 2 * c + 1) - vec_at(x, 2 * c) - l).norm(), 0.0, 1e-12);
    EXPECT_LT(l.norm(), s.particles.radius[i] + s.particles.radius[j]);

    // Normal force: the dot product with the unit branch, and the spring law's kn * overlap.
    const Vec3& f = s.pairs.force[q];
    const double fn = f.dot(l) / l.norm();
    EXPECT_NEAR(normal_force[c], fn, 1e-12 * std::abs(fn));
    const double overlap = s.particles.radius[i] + s.particles.radius[j] - l.norm();
    EXPECT_NEAR(normal_force[c], kKn * overlap, 1e-9 * kKn * overlap);
    EXPECT_GT(normal_force[c], 0.0);  // compression positive

    // Tangential force: f minus its normal part, perpendicular to the branch, within the Coulomb cap.
    const Vec3 ft = vec_at(tangential, c);
    EXPECT_NEAR((ft - (f - fn * l / l.norm())).norm(), 0.0, 1e-12 * f.norm());
    EXPECT_NEAR(ft.dot(l), 0.0, 1e-12 * f.norm() * l.norm());
    EXPECT_LE(ft.norm(), kFriction * fn * (1 + 1e-9));
    const bool slides = (s.pairs.flags[q] & kSliding) != 0;
    EXPECT_EQ(sliding[c], slides ? 1.0 : 0.0);
    if (slides) {
      EXPECT_NEAR(ft.norm(), kFriction * fn, 1e-9 * fn);
    }
    sliding_count += slides;
  }
  EXPECT_GT(across_boundary, 0);
  EXPECT_GT(sliding_count, 0);
}

// Arrays larger than one zlib block (32 KiB) are split: whole blocks, then a partial last one, each inflated on
// its own; the values are the state's. 1000 particles: 72 000 bytes of stress, 24 000 of each vector.
TEST(Snapshot, ZlibSplitsLargeArraysIntoBlocksOfVtkLayout) {
  std::mt19937_64 gen(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  State s = testing::lattice_state(10, 0.5, Vec3(0.99, 0.99, 0.99), 0.05);
  for (std::size_t i = 0; i < s.particles.size(); ++i) s.particles.velocity[i] = testing::draw_vec3(u, gen);
  const Model model = make_model(testing::model_deck(kKn, kKn, 1e-4), s.particles.radius);
  rebuild_pairs(model, s);
  compute_contact_forces(model, kFriction, s);
  const std::size_t n = s.particles.size();
  const VtkDocument vtu = parse_vtk(particles_vtu(s, 3, 0.0, SnapshotFormat::Zlib));
  expect_encoding(vtu, SnapshotFormat::Zlib);
  const XmlElement* stress = find(vtu.root, "DataArray", "stress");
  ASSERT_NE(stress, nullptr);
  const Appended a = appended_at(vtu, std::stoull(stress->attributes.at("offset")));
  const std::size_t bytes = 9 * n * sizeof(double), block = 32768;
  ASSERT_EQ(a.zlib_header.size(), 3 + (bytes + block - 1) / block);
  EXPECT_EQ(a.zlib_header[0], (bytes + block - 1) / block);
  EXPECT_EQ(a.zlib_header[1], block);
  EXPECT_EQ(a.zlib_header[2], bytes % block);
  EXPECT_EQ(a.bytes.size(), bytes);
  const std::vector<Mat3> expected = particle_stresses(s);
  const std::vector<double> got = array(vtu, "stress", 9 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) EXPECT_EQ(got[9 * i + 3 * r + c], expected[i](r, c)) << i;
  const std::vector<double> velocity = array(vtu, "velocity", 3 * n);
  for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(vec_at(velocity, i), s.particles.velocity[i]) << i;
  // The binary file holds the same bytes uncompressed, the text file the same numbers.
  for (const SnapshotFormat format : {SnapshotFormat::Binary, SnapshotFormat::Ascii})
    EXPECT_EQ(array(parse_vtk(particles_vtu(s, 3, 0.0, format)), "stress", 9 * n), got);
}

// The dump's lines, split into words.
std::vector<std::vector<std::string>> dump_lines(const std::filesystem::path& path) {
  std::istringstream in(testing::read_bytes(path));
  std::vector<std::vector<std::string>> out;
  for (std::string line; std::getline(in, line);) {
    std::istringstream words(line);
    out.emplace_back();
    for (std::string w; words >> w;) out.back().push_back(w);
  }
  return out;
}

double number(const std::string& word) { return std::strtod(word.c_str(), nullptr); }

TEST(Snapshot, DumpHoldsTheTiltedBoxAndEveryAtom) {
  const State s = sheared_state();
  testing::TempDir dir;
  SnapshotWriter writer(dir.path(), "snap");
  writer.write(s, 42, 0.1);
  const auto lines = dump_lines(writer.dump_file(42));
  const std::size_t n = s.particles.size();
  ASSERT_EQ(lines.size(), 9 + n);
  EXPECT_EQ(lines[0], (std::vector<std::string>{"ITEM:", "TIMESTEP"}));
  EXPECT_EQ(lines[1], (std::vector<std::string>{"42"}));
  EXPECT_EQ(lines[3], (std::vector<std::string>{std::to_string(n)}));
  EXPECT_EQ(lines[4], (std::vector<std::string>{"ITEM:", "BOX", "BOUNDS", "xy", "xz", "yz", "pp", "pp", "pp"}));

  // LAMMPS's bounding box and tilts: xlo_bound = xlo + min(0, xy, xz, xy + xz), ...
  const Mat3& h = s.cell.h;
  const double xy = h(0, 1), xz = h(0, 2), yz = h(1, 2);
  EXPECT_EQ(number(lines[5][2]), xy);
  EXPECT_EQ(number(lines[6][2]), xz);
  EXPECT_EQ(number(lines[7][2]), yz);
  EXPECT_DOUBLE_EQ(number(lines[5][0]), std::min({0.0, xy, xz, xy + xz}));
  EXPECT_DOUBLE_EQ(number(lines[5][1]), h(0, 0) + std::max({0.0, xy, xz, xy + xz}));
  EXPECT_DOUBLE_EQ(number(lines[6][0]), std::min(0.0, yz));
  EXPECT_DOUBLE_EQ(number(lines[6][1]), h(1, 1) + std::max(0.0, yz));
  EXPECT_EQ(number(lines[7][0]), 0.0);
  EXPECT_EQ(number(lines[7][1]), h(2, 2));

  EXPECT_EQ(lines[8], (std::vector<std::string>{"ITEM:", "ATOMS", "id", "radius", "x", "y", "z", "vx", "vy", "vz",
                                                "wx", "wy", "wz", "contacts", "fx", "fy", "fz", "c_stress[1]",
                                                "c_stress[2]", "c_stress[3]", "c_stress[4]", "c_stress[5]",
                                                "c_stress[6]"}));
  const std::vector<int> contacts = contact_count(s);
  // The net force and particle stress read back are the .vtu's (an upper triangular cell: the dump's frame is
  // celldem's), the stress as LAMMPS's six: xx yy zz and the symmetric part's xy xz yz.
  const std::vector<Vec3> force = net_contact_forces(s);
  const std::vector<Mat3> stress = particle_stresses(s);
  double largest_force = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& w = lines[9 + i];
    ASSERT_EQ(w.size(), 21u);
    EXPECT_EQ(Vec3(number(w[12]), number(w[13]), number(w[14])), force[i]) << i;
    largest_force = std::max(largest_force, force[i].norm());
    const Mat3& t = stress[i];
    const double six[6] = {t(0, 0), t(1, 1), t(2, 2), 0.5 * (t(0, 1) + t(1, 0)), 0.5 * (t(0, 2) + t(2, 0)),
                           0.5 * (t(1, 2) + t(2, 1))};
    for (int k = 0; k < 6; ++k) EXPECT_EQ(number(w[15 + k]), six[k]) << i << " c_stress[" << k + 1 << "]";
  }
  EXPECT_GT(largest_force, 0.0);  // the sheared state's contacts push
  for (std::size_t i = 0; i < n; ++i) {
    const auto& w = lines[9 + i];
    EXPECT_EQ(w[0], std::to_string(i + 1));
    EXPECT_EQ(number(w[1]), s.particles.radius[i]);
    expect_same_place(s, i, Vec3(number(w[2]), number(w[3]), number(w[4])));
    EXPECT_EQ(Vec3(number(w[5]), number(w[6]), number(w[7])), s.particles.velocity[i]);
    EXPECT_EQ(Vec3(number(w[8]), number(w[9]), number(w[10])), s.particles.spin[i]);
    EXPECT_EQ(w[11], std::to_string(contacts[i]));
  }
}

TEST(Snapshot, DumpOfAnOrthogonalCellUsesThePlainBoxBounds) {
  State s = testing::lattice_state(2, 0.5, Vec3(1.0, 1.2, 1.4), 0.05);
  s.particles.scaled[3] += Vec3(-1, 3, 0);
  testing::TempDir dir;
  SnapshotWriter writer(dir.path(), "cube");
  writer.write(s, 0, 0.0);
  const auto lines = dump_lines(writer.dump_file(0));
  ASSERT_EQ(lines.size(), 9 + s.particles.size());
  EXPECT_EQ(lines[4], (std::vector<std::string>{"ITEM:", "BOX", "BOUNDS", "pp", "pp", "pp"}));
  EXPECT_EQ(lines[5], (std::vector<std::string>{"0", "2"}));
  EXPECT_EQ(lines[6], (std::vector<std::string>{"0", "2.3999999999999999"}));  // 2 x 1.2, %.17g
  EXPECT_EQ(number(lines[7][1]), 2.8);
  expect_same_place(s, 3, Vec3(number(lines[12][2]), number(lines[12][3]), number(lines[12][4])));
  // No contacts: an empty but valid contact file, in every encoding.
  for (const SnapshotFormat format : {SnapshotFormat::Binary, SnapshotFormat::Zlib, SnapshotFormat::Ascii}) {
    SCOPED_TRACE(std::string(name_of(format, kSnapshotFormatNames)));
    const VtkDocument vtp = parse_vtk(contacts_vtp(s, 0, 0.0, format));
    expect_encoding(vtp, format);
    EXPECT_EQ(find(vtp.root, "Piece")->attributes.at("NumberOfLines"), "0");
    EXPECT_TRUE(array(vtp, "normal_force", 0).empty());
    EXPECT_TRUE(points(vtp, 0).empty());
    EXPECT_EQ(array(vtp, "cell_h", 9)[4], s.cell.h(1, 1));
  }
}

// A cell that is not upper triangular is rotated into LAMMPS's frame: lengths and angles are kept.
TEST(Snapshot, DumpRotatesAGeneralCellIntoTheLammpsFrame) {
  State s = sheared_state();
  s.cell.h(1, 0) = 0.2;
  s.cell.h(2, 0) = -0.1;
  s.cell.h(2, 1) = 0.07;
  const std::string dump = lammps_dump(s, 3);
  const std::vector<Vec3> force = net_contact_forces(s);
  const std::vector<Mat3> stress = particle_stresses(s);
  testing::TempDir dir;
  testing::write_bytes(dir.path() / "d.dump", dump);
  const auto lines = dump_lines(dir.path() / "d.dump");
  const double xy = number(lines[5][2]), xz = number(lines[6][2]), yz = number(lines[7][2]);
  const double lx = number(lines[5][1]) - number(lines[5][0]) - (std::max({0.0, xy, xz, xy + xz}) - std::min({0.0, xy, xz, xy + xz}));
  const double ly = number(lines[6][1]) - number(lines[6][0]) - std::abs(yz);
  const double lz = number(lines[7][1]) - number(lines[7][0]);
  const Mat3 box = (Mat3() << lx, xy, xz, 0, ly, yz, 0, 0, lz).finished();
  const Mat3 metric = s.cell.h.transpose() * s.cell.h;
  EXPECT_NEAR((box.transpose() * box - metric).norm(), 0.0, 1e-12);
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    const auto& w = lines[9 + i];
    const Vec3 x(number(w[2]), number(w[3]), number(w[4])), v(number(w[5]), number(w[6]), number(w[7]));
    const Vec3 spin(number(w[8]), number(w[9]), number(w[10]));
    // The same point of the cell, and the same vectors relative to the cell vectors.
    const Vec3 sx = box.inverse() * x;
    const Vec3 expected = s.cell.h.inverse() * primary_position(s, i);
    EXPECT_NEAR((sx - expected).norm(), 0.0, 1e-12);
    EXPECT_NEAR((box.transpose() * v - s.cell.h.transpose() * s.particles.velocity[i]).norm(), 0.0, 1e-12);
    EXPECT_NEAR((box.transpose() * spin - s.cell.h.transpose() * s.particles.spin[i]).norm(), 0.0, 1e-12);
    // Force and stress rotate with the frame: box^T f and box^T T box are the same as with h.
    const Vec3 f(number(w[12]), number(w[13]), number(w[14]));
    const Vec3 f_cell = s.cell.h.transpose() * force[i];
    EXPECT_NEAR((box.transpose() * f - f_cell).norm(), 0.0, 1e-12 * std::max(1.0, f_cell.norm())) << i;
    Mat3 t;
    t << number(w[15]), number(w[18]), number(w[19]), number(w[18]), number(w[16]), number(w[20]), number(w[19]),
        number(w[20]), number(w[17]);
    const Mat3 sym = 0.5 * (stress[i] + stress[i].transpose());
    const Mat3 t_cell = s.cell.h.transpose() * sym * s.cell.h;
    EXPECT_NEAR((box.transpose() * t * box - t_cell).norm(), 0.0, 1e-12 * std::max(1.0, t_cell.norm())) << i;
  }
}

std::vector<std::pair<double, std::string>> collection(const std::filesystem::path& pvd) {
  const XmlElement root = read_xml(pvd);
  EXPECT_EQ(root.attributes.at("type"), "Collection");
  std::vector<std::pair<double, std::string>> out;
  const XmlElement* c = find(root, "Collection");
  if (!c) return out;
  for (const XmlElement& e : c->children) {
    EXPECT_EQ(e.name, "DataSet");
    out.emplace_back(number(e.attributes.at("timestep")), e.attributes.at("file"));
  }
  return out;
}

using Entries = std::vector<std::pair<double, std::string>>;

TEST(Snapshot, CollectionsListEverySnapshotAndContinueAfterAResume) {
  const State s = sheared_state();
  testing::TempDir dir;
  const auto folder = dir.path() / "snapshots";  // created by the first write
  {
    SnapshotWriter writer(folder, "run.a");
    writer.write(s, 0, 0.0);
    EXPECT_EQ(collection(writer.particles_collection()), (Entries{{0.0, "run.a_0.vtu"}}));
    writer.write(s, 100, 0.1);
    writer.write(s, 200, 0.2);
    EXPECT_EQ(collection(writer.particles_collection()),
              (Entries{{0.0, "run.a_0.vtu"}, {0.1, "run.a_100.vtu"}, {0.2, "run.a_200.vtu"}}));
    EXPECT_EQ(collection(writer.contacts_collection()),
              (Entries{{0.0, "run.a_contacts_0.vtp"}, {0.1, "run.a_contacts_100.vtp"}, {0.2, "run.a_contacts_200.vtp"}}));
    for (const auto& [time, file] : collection(writer.particles_collection()))
      EXPECT_TRUE(std::filesystem::exists(folder / file)) << file;
  }
  // A run resumed from a checkpoint at step 150 writes step 200 again: the collection keeps what came before.
  {
    SnapshotWriter writer(folder, "run.a");
    writer.write(s, 200, 0.2);
    writer.write(s, 300, 0.3);
    EXPECT_EQ(collection(writer.particles_collection()),
              (Entries{{0.0, "run.a_0.vtu"}, {0.1, "run.a_100.vtu"}, {0.2, "run.a_200.vtu"}, {0.3, "run.a_300.vtu"}}));
  }
  // A new run from step 0 starts a new collection.
  {
    SnapshotWriter writer(folder, "run.a");
    writer.write(s, 0, 0.0);
    EXPECT_EQ(collection(writer.particles_collection()), (Entries{{0.0, "run.a_0.vtu"}}));
    EXPECT_EQ(collection(writer.contacts_collection()), (Entries{{0.0, "run.a_contacts_0.vtp"}}));
  }
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
}

TEST(Snapshot, AFailedWriteThrowsNamingTheFileAndLeavesNoPartialFile) {
  const State s = sheared_state();
  testing::TempDir dir;

  // A folder that cannot be made: its parent is a regular file.
  testing::write_bytes(dir.path() / "plain_file", "x");
  const auto impossible = dir.path() / "plain_file" / "snapshots";
  try {
    SnapshotWriter(impossible, "snap").write(s, 1, 0.0);
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(impossible.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("Not a directory"), std::string::npos) << e.what();
  }

  // A folder without write permission (root may write anyway: then only the case below applies).
  if (::geteuid() != 0) {
    const auto locked = dir.path() / "locked";
    std::filesystem::create_directory(locked);
    std::filesystem::permissions(locked, std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec);
    try {
      SnapshotWriter(locked, "snap").write(s, 1, 0.0);
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find((locked / "snap_1.vtu").string()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("Permission denied"), std::string::npos) << e.what();
    }
    std::filesystem::permissions(locked, std::filesystem::perms::owner_all);
  }

  // A final name that cannot be replaced (a non-empty folder stands there): the error names the file, the
  // temporary is gone, and no collection lists the missing snapshot.
  const auto folder = dir.path() / "out";
  SnapshotWriter writer(folder, "snap");
  std::filesystem::create_directories(writer.contacts_file(5) / "blocker");
  try {
    writer.write(s, 5, 0.0);
    ADD_FAILURE() << "no exception";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(writer.contacts_file(5).string()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(writer.contacts_file(5).string() + ".tmp"));
  EXPECT_FALSE(std::filesystem::exists(writer.particles_collection()));
}

TEST(Snapshot, StemMustBeSafeInFileNamesAndXml) {
  EXPECT_THROW(SnapshotWriter("/tmp", "a\"b"), std::invalid_argument);
  EXPECT_THROW(SnapshotWriter("/tmp", "a/b"), std::invalid_argument);
  EXPECT_THROW(SnapshotWriter("/tmp", ""), std::invalid_argument);
  EXPECT_NO_THROW(SnapshotWriter("/tmp/celldem-no-such-folder", "ttc_01-x.y"));
}

}  // namespace
}  // namespace celldem
