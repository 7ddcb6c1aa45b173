#include "io/deck.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

namespace celldem {
namespace {

using Json = nlohmann::json;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Reads one JSON object, remembering which keys were asked for so unknown keys are errors.
// Every message carries the JSON path of the key.
class ObjectReader {
 public:
  ObjectReader(const Json& j, std::string path) : j_(j), path_(std::move(path)) {
    if (!j_.is_object()) fail(path_, "expected an object");
  }

  bool has(const std::string& key) {
    known_.insert(key);
    return j_.contains(key);
  }

  double number(const std::string& key, double lo, double hi, std::optional<double> fallback = {}) {
    const Json* v = find(key, fallback.has_value());
    if (!v) return *fallback;
    if (!v->is_number()) fail(at(key), "expected a number, got " + type_name(*v));
    const double x = v->get<double>();
    check_range(key, x, lo, hi);
    return x;
  }

  // Strictly positive number.
  double positive(const std::string& key, std::optional<double> fallback = {}) {
    const double x = number(key, 0.0, kInf, fallback);
    if (!(x > 0.0)) fail(at(key), "must be > 0, got " + fmt(x));
    return x;
  }

  std::int64_t integer(const std::string& key, std::int64_t lo, std::int64_t hi,
                       std::optional<std::int64_t> fallback = {}) {
    const Json* v = find(key, fallback.has_value());
    if (!v) return *fallback;
    if (!v->is_number_integer()) fail(at(key), "expected an integer, got " + type_name(*v));
    // Large unsigned values do not fit int64: reject them before get<int64_t> wraps them.
    if (v->is_number_unsigned() && v->get<std::uint64_t>() > static_cast<std::uint64_t>(hi))
      fail(at(key), "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    const std::int64_t x = v->get<std::int64_t>();
    if (x < lo || x > hi)
      fail(at(key), "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                        std::to_string(x));
    return x;
  }

  std::string string(const std::string& key, std::optional<std::string> fallback = {}) {
    const Json* v = find(key, fallback.has_value());
    if (!v) return *fallback;
    if (!v->is_string()) fail(at(key), "expected a string, got " + type_name(*v));
    return v->get<std::string>();
  }

  template <class Enum>
  Enum choice(const std::string& key, const std::map<std::string, Enum>& options, Enum fallback) {
    const Json* v = find(key, true);
    if (!v) return fallback;
    if (!v->is_string()) fail(at(key), "expected a string, got " + type_name(*v));
    const auto it = options.find(v->get<std::string>());
    if (it == options.end()) {
      std::string list;
      for (const auto& [name, _] : options) list += (list.empty() ? "" : ", ") + ("\"" + name + "\"");
      fail(at(key), "unknown value \"" + v->get<std::string>() + "\"; expected one of " + list);
    }
    return it->second;
  }

  ObjectReader object(const std::string& key) {
    const Json* v = find(key, false);
    return ObjectReader(*v, at(key));
  }

  const Json& raw(const std::string& key) { return *find(key, false); }

  std::string at(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  const std::string& path() const { return path_; }

  // Call after reading every key: anything not asked for is a typo or an unsupported option.
  void finish() const {
    for (const auto& [key, _] : j_.items())
      if (!known_.count(key)) fail(at(key), "unknown key");
  }

  [[noreturn]] static void fail(const std::string& path, const std::string& what) {
    throw DeckError(path + ": " + what);
  }

  static std::string fmt(double x) {
    std::ostringstream s;
    s << x;
    return s.str();
  }

  static std::string type_name(const Json& v) { return v.type_name(); }

 private:
  const Json* find(const std::string& key, bool optional) {
    known_.insert(key);
    const auto it = j_.find(key);
    if (it == j_.end()) {
      if (optional) return nullptr;
      fail(at(key), "missing required key");
    }
    if (it->is_null() && optional) return nullptr;
    return &*it;
  }

  void check_range(const std::string& key, double x, double lo, double hi) const {
    if (!std::isfinite(x)) fail(at(key), "must be finite");
    if (x < lo || x > hi) fail(at(key), "must be in [" + fmt(lo) + ", " + fmt(hi) + "], got " + fmt(x));
  }

  const Json& j_;
  std::string path_;
  std::set<std::string> known_;
};

SampleDef read_sample(ObjectReader r) {
  SampleDef s;
  s.count = static_cast<int>(r.integer("count", 1, 50'000'000));
  s.density = r.positive("density");
  s.seed = static_cast<std::uint64_t>(r.integer("seed", 0, std::numeric_limits<std::int64_t>::max(), 1));
  {
    ObjectReader d = r.object("diameters");
    if (d.has("list")) {
      const Json& list = d.raw("list");
      if (!list.is_array() || list.empty()) ObjectReader::fail(d.at("list"), "expected a non-empty array");
      for (std::size_t i = 0; i < list.size(); ++i) {
        const std::string p = d.at("list") + "[" + std::to_string(i) + "]";
        if (!list[i].is_number()) ObjectReader::fail(p, "expected a number");
        const double x = list[i].get<double>();
        if (!(x > 0.0) || !std::isfinite(x)) ObjectReader::fail(p, "must be a finite number > 0");
        s.diameters.push_back(x);
      }
      if (d.has("min") || d.has("max") || d.has("count"))
        ObjectReader::fail(d.path(), "give either \"list\" or \"min\"/\"max\"/\"count\", not both");
    } else {
      const double lo = d.positive("min");
      const double hi = d.positive("max");
      const int n = static_cast<int>(d.integer("count", 1, 100000));
      if (hi < lo) ObjectReader::fail(d.at("max"), "must be >= min");
      if (n == 1 && hi != lo) ObjectReader::fail(d.at("count"), "must be > 1 when max > min");
      for (int i = 0; i < n; ++i) s.diameters.push_back(n == 1 ? lo : lo + (hi - lo) * i / (n - 1));
    }
    d.finish();
  }
  double dmax = 0.0;
  for (double x : s.diameters) dmax = std::max(dmax, x);
  s.grid_spacing = r.number("grid_spacing", 0.0, kInf, 1.1 * dmax);
  if (s.grid_spacing <= dmax)
    ObjectReader::fail(r.at("grid_spacing"), "must exceed the largest diameter (" + ObjectReader::fmt(dmax) +
                                                 ") so that the initial spheres do not overlap");
  r.finish();
  return s;
}

ContactDef read_contact(ObjectReader r) {
  ContactDef c;
  c.kn = r.positive("kn");
  c.kt = r.number("kt", 0.0, kInf);
  c.rotation = r.choice<TangentialRotation>(
      "tangential_rotation", {{"rotate", TangentialRotation::Rotate}, {"project", TangentialRotation::Project}},
      TangentialRotation::Rotate);
  c.moment_arm = r.choice<MomentArm>("moment_arm",
                                     {{"contact_point", MomentArm::ContactPoint}, {"radius", MomentArm::Radius}},
                                     MomentArm::ContactPoint);
  r.finish();
  return c;
}

AxisControl read_axis(ObjectReader r) {
  AxisControl a;
  int given = 0;
  if (r.has("strain_increment")) {
    a = {AxisMode::StrainIncrement, r.number("strain_increment", -0.01, 0.01)};
    ++given;
  }
  if (r.has("strain_rate")) {
    a = {AxisMode::StrainRate, r.number("strain_rate", -1e6, 1e6)};
    ++given;
  }
  if (r.has("stress")) {
    a = {AxisMode::Stress, r.positive("stress")};
    ++given;
  }
  if (given != 1) ObjectReader::fail(r.path(), "give exactly one of \"strain_increment\", \"strain_rate\", \"stress\"");
  r.finish();
  return a;
}

TestDef read_test(ObjectReader r) {
  TestDef t;
  t.name = r.string("name");
  if (t.name.empty() || t.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") !=
                            std::string::npos)
    ObjectReader::fail(r.at("name"), "must be a non-empty name of letters, digits, '_' or '-'");
  t.friction = r.number("friction", 0.0, 1e3);
  {
    ObjectReader axes = r.object("axes");
    const char* names[3] = {"x1", "x2", "x3"};
    for (int i = 0; i < 3; ++i) t.axes[i] = read_axis(axes.object(names[i]));
    axes.finish();
  }
  {
    ObjectReader end = r.object("end");
    const std::string axis = end.string("axis", "x1");
    if (axis != "x1" && axis != "x2" && axis != "x3") ObjectReader::fail(end.at("axis"), "expected \"x1\", \"x2\" or \"x3\"");
    t.end_axis = axis[1] - '1';
    t.end_strain = end.number("strain", -0.9, 0.9);
    if (t.end_strain == 0.0) ObjectReader::fail(end.at("strain"), "must be non-zero");
    t.max_steps = end.integer("max_steps", 0, std::int64_t{1} << 50, 0);
    end.finish();
  }
  const AxisControl& driver = t.axes[t.end_axis];
  if (driver.mode == AxisMode::Stress)
    ObjectReader::fail(r.at("end.axis"), "the axis that ends the test must be strain-controlled");
  if (driver.value == 0.0 || (driver.value > 0) != (t.end_strain > 0))
    ObjectReader::fail(r.at("end.strain"), "the end axis is not strained towards this value");
  t.output_interval = r.integer("output_interval", 1, std::int64_t{1} << 40, 1000);
  r.finish();
  return t;
}

PrepareDef read_prepare(ObjectReader r) {
  PrepareDef p;
  p.friction = r.number("friction", 0.0, 1e3, 0.0);
  p.target_pressure = r.positive("target_pressure");
  p.fast_solid_fraction = r.number("fast_solid_fraction", 0.01, 0.6, 0.45);
  p.fast_strain_increment = r.number("fast_strain_increment", 1e-9, 1e-2, 2e-5);
  p.output_interval = r.integer("output_interval", 1, std::int64_t{1} << 40, 1000);
  if (r.has("equilibrium")) {
    ObjectReader e = r.object("equilibrium");
    EquilibriumDef& q = p.equilibrium;
    q.pressure_tolerance = e.number("pressure_tolerance", 1e-9, 1.0, q.pressure_tolerance);
    q.stress_tolerance = e.number("stress_tolerance", 1e-9, 1.0, q.stress_tolerance);
    q.unbalanced_force_ratio = e.number("unbalanced_force_ratio", 1e-12, 1.0, q.unbalanced_force_ratio);
    q.min_steps = e.integer("min_steps", 0, std::int64_t{1} << 50, q.min_steps);
    q.check_interval = e.integer("check_interval", 1, std::int64_t{1} << 40, q.check_interval);
    q.max_steps = e.integer("max_steps", 1, std::int64_t{1} << 50, q.max_steps);
    e.finish();
  }
  r.finish();
  return p;
}

}  // namespace

double skin_length(const Deck& deck) {
  return deck.neighbor_skin * *std::max_element(deck.sample.diameters.begin(), deck.sample.diameters.end());
}

double critical_time_step(const SampleDef& sample, double kn) {
  double dmin = sample.diameters.empty() ? 0.0 : sample.diameters[0];
  for (double d : sample.diameters) dmin = std::min(dmin, d);
  const double m_min = sample.density * M_PI / 6.0 * dmin * dmin * dmin;
  return std::sqrt(m_min / kn);
}

Deck parse_deck(const std::string& json_text, const std::string& source) {
  Json j;
  try {
    // Depth is bounded by the parser's own recursion; reject absurd nesting before it matters.
    int depth = 0, max_depth = 0;
    bool in_string = false, escaped = false;
    for (char c : json_text) {
      if (in_string) {
        if (escaped) escaped = false;
        else if (c == '\\') escaped = true;
        else if (c == '"') in_string = false;
        continue;
      }
      if (c == '"') in_string = true;
      else if (c == '{' || c == '[') max_depth = std::max(max_depth, ++depth);
      else if (c == '}' || c == ']') --depth;
    }
    if (max_depth > 64) throw DeckError("deck: nesting deeper than 64 levels");
    j = Json::parse(json_text, nullptr, true, /*ignore_comments=*/true);
  } catch (const Json::exception& e) {  // parse errors, and numbers too large for a double
    throw DeckError(std::string("deck is not valid JSON: ") + e.what());
  }

  Deck d;
  d.source = source;
  d.canonical = j.dump(-1, ' ', false, Json::error_handler_t::replace);  // invalid UTF-8 must not throw
  ObjectReader r(j, "");
  d.format = static_cast<int>(r.integer("format", 1, 1000));
  if (d.format != kDeckFormatVersion)
    ObjectReader::fail("format", "this celldem reads deck format " + std::to_string(kDeckFormatVersion) +
                                     ", the deck says " + std::to_string(d.format));
  if (r.has("description")) (void)r.string("description");
  d.sample = read_sample(r.object("sample"));
  d.contact = read_contact(r.object("contact"));
  {
    ObjectReader dmp = r.object("damping");
    d.damping.translational = dmp.number("translational", 0.0, 10.0);
    d.damping.rotational = dmp.number("rotational", 0.0, 10.0);
    dmp.finish();
  }
  d.kinematics = r.choice<Kinematics>("kinematics", {{"affine", Kinematics::Affine}, {"lammps", Kinematics::Lammps}},
                                      Kinematics::Affine);
  d.time_step = r.positive("time_step");
  const double dt_crit = critical_time_step(d.sample, d.contact.kn);
  if (d.time_step > dt_crit)
    ObjectReader::fail("time_step", "exceeds the stability limit sqrt(m_min/kn) = " + ObjectReader::fmt(dt_crit) +
                                        " s of the lightest particle");
  if (r.has("servo")) {
    ObjectReader s = r.object("servo");
    d.servo.gain = s.number("gain", 0.0, 1.0, d.servo.gain);
    d.servo.integral_gain = s.number("integral_gain", 0.0, 1.0, d.servo.integral_gain);
    d.servo.max_strain_increment = s.number("max_strain_increment", 1e-12, 1e-2, d.servo.max_strain_increment);
    if (d.servo.gain == 0.0 && d.servo.integral_gain == 0.0)
      ObjectReader::fail(s.path(), "gain and integral_gain cannot both be zero");
    s.finish();
  }
  d.neighbor_skin = r.number("neighbor_skin", 1e-4, 1.0, d.neighbor_skin);
  d.checkpoint_interval = r.integer("checkpoint_interval", 1, std::int64_t{1} << 50, d.checkpoint_interval);

  const bool has_prepare = r.has("prepare");
  const bool has_state = r.has("initial_state");
  if (has_prepare == has_state)
    ObjectReader::fail(has_prepare ? "initial_state" : "prepare",
                       "give exactly one of \"prepare\" (make a sample) and \"initial_state\" (reuse one)");
  if (has_prepare) d.prepare = read_prepare(r.object("prepare"));
  if (has_state) d.initial_state = r.string("initial_state");

  if (r.has("tests")) {
    const Json& tests = r.raw("tests");
    if (!tests.is_array()) ObjectReader::fail("tests", "expected an array");
    std::set<std::string> names;
    for (std::size_t i = 0; i < tests.size(); ++i) {
      const std::string path = "tests[" + std::to_string(i) + "]";
      d.tests.push_back(read_test(ObjectReader(tests[i], path)));
      if (!names.insert(d.tests.back().name).second)
        ObjectReader::fail(path + ".name", "duplicate test name \"" + d.tests.back().name + "\"");
    }
  }
  if (!has_prepare && d.tests.empty()) ObjectReader::fail("tests", "a deck without \"prepare\" needs at least one test");
  r.finish();
  return d;
}

Deck read_deck(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DeckError(path + ": cannot open the deck");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_deck(text.str(), path);
}

}  // namespace celldem
