#include "io/state_file.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "io/files.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {

constexpr char kMagic[8] = {'C', 'E', 'L', 'L', 'D', 'E', 'M', 'S'};

std::uint64_t fnv1a(const char* data, std::size_t size) {
  std::uint64_t h = 1469598103934665603ULL;
  for (std::size_t k = 0; k < size; ++k) h = (h ^ static_cast<unsigned char>(data[k])) * 1099511628211ULL;
  return h;
}

class Writer {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void put(const Vec3& v) { for (int k = 0; k < 3; ++k) put(v[k]); }
  void put(const Vec6& v) { for (int k = 0; k < 6; ++k) put(v[k]); }
  void put(const Mat3& m) { for (int k = 0; k < 9; ++k) put(m.data()[k]); }
  void put_string(const std::string& s) {
    put(static_cast<std::uint32_t>(s.size()));
    out_ += s;
  }
  std::string& bytes() { return out_; }

 private:
  std::string out_;
};

class Reader {
 public:
  Reader(const char* data, std::size_t size) : data_(data), size_(size) {}
  template <class T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    need(sizeof(T));
    T v;
    std::memcpy(&v, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  double finite() {
    const double x = get<double>();
    if (!std::isfinite(x)) throw StateFileError("state file holds a non-finite number");
    return x;
  }
  Vec3 vec() {
    Vec3 v;  // one by one: the order of evaluation of constructor arguments is unspecified
    for (int k = 0; k < 3; ++k) v[k] = finite();
    return v;
  }
  Vec6 vec6() {
    Vec6 v;
    for (int k = 0; k < 6; ++k) v[k] = finite();
    return v;
  }
  Mat3 mat() {
    Mat3 m;
    for (int k = 0; k < 9; ++k) m.data()[k] = finite();
    return m;
  }
  std::string string(std::size_t max) {
    const auto n = get<std::uint32_t>();
    if (n > max) throw StateFileError("state file holds an over-long string");
    need(n);
    std::string s(data_ + pos_, n);
    pos_ += n;
    return s;
  }
  std::size_t remaining() const { return size_ - pos_; }
  void need(std::size_t n) const {
    if (n > size_ - pos_) throw StateFileError("state file is truncated");
  }

 private:
  const char* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace

std::string serialize_state(const State& s, const std::string& label, const std::string& physics,
                            const std::string& checkpoint_record) {
  Writer w;
  const std::vector<StoredContact> contacts = stored_contacts(s);
  const bool rotational = !s.pairs.rolling.empty();
  const bool radius = !s.pairs.contact_radius.empty();
  // Format 7 (every state with a physics record or contact radii) holds the control as one record of the six
  // components; without either, format 2 or 3 as before (their cells were never sheared by the control and their
  // legs ran at the deck's rate).
  const std::uint32_t version = !checkpoint_record.empty()        ? 8
                                : radius || !physics.empty() ? 7
                                : rotational                 ? 3
                                                             : 2;
  w.put_string(label);
  if (version >= 4) w.put_string(physics);
  if (version >= 8) w.put_string(checkpoint_record);
  w.put(static_cast<std::uint64_t>(s.particles.size()));
  w.put(static_cast<std::uint64_t>(contacts.size()));
  w.put(s.time);
  w.put(s.steps_since_creation);
  w.put(s.cell.h);
  w.put(s.cell.velocity_gradient);
  w.put(s.control.leg_steps);
  w.put(s.control.leg);
  w.put(s.control.stage_steps);
  if (version >= 7) {  // the control record: ControlState and the last evaluation's stresses, per component
    w.put(s.control.reference);
    w.put(s.control.reference_volume);
    w.put(s.control.leg_start_volume);
    w.put(s.control.servo_integral);
    w.put(s.control.leg_start_strains);
    w.put(s.control.rate_factor);
    w.put(s.control.leg_progress);
    w.put(s.stress);
    w.put(s.stiffness);
  } else {  // formats 2 and 3: the normal axes' record (a full tensor's slot for the stress, as format 1 held)
    w.put(Vec3(s.control.reference.head<3>()));
    w.put(s.control.reference_volume);
    w.put(Vec3(s.control.servo_integral.head<3>()));
    w.put(Vec3(s.control.leg_start_strains.head<3>()));
    w.put(s.control.leg_start_volume);
    w.put(Mat3(s.normal_stress().asDiagonal()));
    w.put(Vec3(s.stiffness.head<3>()));
  }
  w.put(s.touching);
  w.put(s.pairs.skin);
  if (version >= 4)
    w.put(static_cast<std::uint8_t>((rotational ? kStateRotationalFields : 0) | (radius ? kStateRadiusField : 0)));
  const Particles& p = s.particles;
  for (std::size_t i = 0; i < p.size(); ++i) {
    w.put(p.radius[i]);
    w.put(p.scaled[i]);
    w.put(p.velocity[i]);
    w.put(p.spin[i]);
  }
  for (const StoredContact& c : contacts) {
    w.put(c.i);
    w.put(c.j);
    w.put(c.tangential);
    w.put(c.flags);
    if (rotational) {
      w.put(c.rolling);
      w.put(c.twist);
    }
    if (radius) w.put(c.contact_radius);
  }
  std::string payload = std::move(w.bytes());
  Writer file;
  file.bytes().append(kMagic, sizeof kMagic);
  file.put(version);
  file.put(static_cast<std::uint64_t>(payload.size()));
  file.bytes() += payload;
  file.put(fnv1a(payload.data(), payload.size()));
  return std::move(file.bytes());
}

namespace {
// Formats 1 to 6: the normal axes' record, then from format 5 the shear axes' (the shear stresses in the stress
// tensor's slot, the shear stiffnesses, the stage's reference tilts, the leg's start shear strains and the
// shear servo's integral), then from format 6 the adaptive rate's; older files' tilts as they stand are the
// stage's reference, and their legs ran at the deck's rate.
void read_control_up_to_6(Reader& r, std::uint32_t version, State& s) {
  ControlState& c = s.control;
  c.reference.head<3>() = r.vec();
  c.reference_volume = r.finite();
  c.servo_integral.head<3>() = r.vec();
  if (version >= 2) {  // format 1 had no legs: its stage was one leg from the stage start
    c.leg_start_strains.head<3>() = r.vec();
    c.leg_start_volume = r.finite();
  } else {
    c.leg_start_volume = c.reference_volume;
  }
  const Mat3 stress = r.mat();
  s.stress.head<3>() = stress.diagonal();
  s.stiffness.head<3>() = r.vec();
  if (version >= 5) {
    for (int a = 0; a < 3; ++a) s.stress[3 + a] = stress(kShearAxisEntries[a][0], kShearAxisEntries[a][1]);
    s.stiffness.tail<3>() = r.vec();
    c.reference.tail<3>() = r.vec();
    c.leg_start_strains.tail<3>() = r.vec();
    c.servo_integral.tail<3>() = r.vec();
  } else {
    for (int a = 0; a < 3; ++a) c.reference[3 + a] = s.cell.h(kShearAxisEntries[a][0], kShearAxisEntries[a][1]);
  }
  if (version >= 6) {
    c.rate_factor = r.finite();
    c.leg_progress = r.finite();
  } else {
    c.leg_progress = static_cast<double>(c.leg_steps);
  }
}
}  // namespace

State parse_state(const std::string& bytes, std::string* label, std::string* physics, std::string* checkpoint_record) {
  Reader head(bytes.data(), bytes.size());
  head.need(sizeof kMagic);
  if (std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) throw StateFileError("not a celldem state file");
  for (std::size_t k = 0; k < sizeof kMagic; ++k) (void)head.get<char>();
  const auto version = head.get<std::uint32_t>();
  if (version < 1 || version > kStateFormatVersion)
    throw StateFileError("state file format " + std::to_string(version) + " is not one of the supported 1 to " +
                         std::to_string(kStateFormatVersion));
  const auto payload_size = head.get<std::uint64_t>();
  head.need(sizeof(std::uint64_t));  // then remaining() >= 8 and the subtraction below cannot wrap
  if (payload_size != head.remaining() - sizeof(std::uint64_t))
    throw StateFileError("state file is truncated or has trailing bytes");
  const char* payload = bytes.data() + (bytes.size() - head.remaining());
  std::uint64_t stored_sum;
  std::memcpy(&stored_sum, payload + payload_size, sizeof stored_sum);
  if (fnv1a(payload, payload_size) != stored_sum) throw StateFileError("state file checksum mismatch (corrupted)");

  Reader r(payload, payload_size);
  State s;
  const std::string text = r.string(4096);
  if (label) *label = text;
  const std::string record = version >= 4 ? r.string(65536) : std::string();
  if (physics) *physics = record;
  std::string checkpoint = version >= 8 ? r.string(std::size_t{1} << 28) : std::string();
  if (version >= 8 && checkpoint.empty()) throw StateFileError("state file format 8 holds an empty checkpoint record");
  if (checkpoint_record) *checkpoint_record = std::move(checkpoint);
  const auto n = r.get<std::uint64_t>();
  const auto nc = r.get<std::uint64_t>();
  constexpr std::size_t kParticleBytes = 10 * sizeof(double), kContactBytes = 8 + 3 * sizeof(double) + 1;
  if (n == 0 || n > r.remaining() / kParticleBytes || nc > r.remaining() / kContactBytes)
    throw StateFileError("state file particle or contact count does not match its size");
  s.time = r.finite();
  s.steps_since_creation = r.get<std::int64_t>();
  s.cell.h = r.mat();
  s.cell.velocity_gradient = r.mat();
  s.control.leg_steps = r.get<std::int64_t>();
  s.control.leg = r.get<std::int32_t>();
  s.control.stage_steps = r.get<std::int64_t>();
  if (version >= 7) {
    s.control.reference = r.vec6();
    s.control.reference_volume = r.finite();
    s.control.leg_start_volume = r.finite();
    s.control.servo_integral = r.vec6();
    s.control.leg_start_strains = r.vec6();
    s.control.rate_factor = r.finite();
    s.control.leg_progress = r.finite();
    s.stress = r.vec6();
    s.stiffness = r.vec6();
  } else {
    read_control_up_to_6(r, version, s);
  }
  if (!(s.control.rate_factor > 0.0) || s.control.leg_progress < 0.0)
    throw StateFileError("state file holds a non-positive rate factor or a negative leg progress");
  s.touching = r.get<std::int64_t>();
  s.pairs.skin = r.finite();
  // The optional fields of each contact: the rotational springs from format 3 on, as format 4 says.
  const std::uint8_t fields = version >= 4 ? r.get<std::uint8_t>() : version == 3 ? kStateRotationalFields : 0;
  if (fields & ~(kStateRotationalFields | kStateRadiusField))
    throw StateFileError("state file names contact fields this version does not know");
  if (!(s.cell.volume() > 0.0)) throw StateFileError("state file cell has no positive volume");
  if (s.pairs.skin < 0.0 || s.steps_since_creation < 0 || s.control.leg_steps < 0 || s.control.stage_steps < 0)
    throw StateFileError("state file holds a negative step count or skin");
  s.particles.resize(n);
  Particles& p = s.particles;
  for (std::size_t i = 0; i < n; ++i) {
    p.radius[i] = r.finite();
    if (!(p.radius[i] > 0.0)) throw StateFileError("state file holds a non-positive radius");
    p.scaled[i] = r.vec();
    p.velocity[i] = r.vec();
    p.spin[i] = r.vec();
  }
  std::vector<StoredContact> contacts(nc);
  for (std::size_t c = 0; c < nc; ++c) {
    StoredContact& k = contacts[c];
    k.i = r.get<Index>();
    k.j = r.get<Index>();
    k.tangential = r.vec();
    k.flags = r.get<std::uint8_t>();
    if (fields & kStateRotationalFields) {
      k.rolling = r.vec();
      k.twist = r.finite();
    }
    if (fields & kStateRadiusField) {
      k.contact_radius = r.finite();
      if (k.contact_radius < 0.0) throw StateFileError("state file holds a negative contact radius");
    }
    const bool ordered = c == 0 || contacts[c - 1].i < k.i || (contacts[c - 1].i == k.i && contacts[c - 1].j < k.j);
    if (k.i < 0 || k.j <= k.i || static_cast<std::uint64_t>(k.j) >= n || !ordered)
      throw StateFileError("state file contact list is invalid (indices out of range or unsorted)");
  }
  if (r.remaining() != 0) throw StateFileError("state file has trailing bytes in its payload");
  set_stored_contacts(s, contacts);
  return s;
}

void write_state(const std::string& path, const State& state, const std::string& label, const std::string& physics,
                 const std::string& checkpoint_record) {
  write_file_atomic(path, serialize_state(state, label, physics, checkpoint_record));
}

State read_state(const std::string& path, std::string* label, std::string* physics, std::string* checkpoint_record) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StateFileError(path + ": cannot open the state file");
  std::ostringstream text;
  text << in.rdbuf();
  try {
    return parse_state(text.str(), label, physics, checkpoint_record);
  } catch (const StateFileError& e) {
    throw StateFileError(path + ": " + e.what());
  }
}

}  // namespace celldem
