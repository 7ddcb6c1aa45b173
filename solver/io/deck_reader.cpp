#include "io/deck_reader.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <type_traits>

#include "core/plan.hpp"
#include "io/deck_parts.hpp"
#include "io/tolerance.hpp"

namespace celldem {
namespace {

using deck_json::fail;
using deck_json::key_path;
using deck_json::Json;
using deck_json::parse_json;

// Reads one JSON object, remembering which keys were asked for so unknown keys are errors. Each read names
// its key's entry in the key table, which gives the range and the default. Messages carry the JSON path.
class ObjectReader {
 public:
  ObjectReader(const Json& j, std::string path) : j_(j), path_(std::move(path)) {
    if (!j_.is_object()) fail(path_, "expected an object");
  }

  bool has(std::string_view key) {
    known_.insert(std::string(key));
    return j_.contains(std::string(key));
  }
  bool has(const KeySpec& spec) { return has(spec.name()); }

  double number(const KeySpec& spec) {
    const Json* v = find(spec);
    if (!v) return spec.fallback;
    if (!v->is_number()) fail(at(spec), "expected a number, got " + std::string(v->type_name()));
    const double x = v->get<double>();
    if (!std::isfinite(x)) fail(at(spec), "must be finite");
    check_range(spec, x);
    return x;
  }

  std::int64_t integer(const KeySpec& spec) {
    const Json* v = find(spec);
    if (!v) return static_cast<std::int64_t>(spec.fallback);
    if (!v->is_number_integer()) fail(at(spec), "expected an integer, got " + std::string(v->type_name()));
    // Large unsigned values do not fit int64: reject them before get<int64_t> wraps them.
    if (v->is_number_unsigned() && v->get<std::uint64_t>() > static_cast<std::uint64_t>(spec.max))
      fail(at(spec), "must be in [" + fmt(spec.min) + ", " + fmt(spec.max) + "]");
    const std::int64_t x = v->get<std::int64_t>();
    check_range(spec, static_cast<double>(x));
    return x;
  }

  bool boolean(const KeySpec& spec) {
    const Json* v = find(spec);
    if (!v) return false;
    if (!v->is_boolean()) fail(at(spec), "expected true or false, got " + std::string(v->type_name()));
    return v->get<bool>();
  }

  std::string string(const KeySpec& spec) {
    const Json* v = find(spec);
    if (!v) return "";
    if (!v->is_string()) fail(at(spec), "expected a string, got " + std::string(v->type_name()));
    return v->get<std::string>();
  }

  // The index of the value among spec.choices (the first choice when the key is optional and absent).
  std::size_t choice(const KeySpec& spec) {
    const Json* v = find(spec);
    if (!v) return 0;
    if (!v->is_string()) fail(at(spec), "expected a string, got " + std::string(v->type_name()));
    const std::string value = v->get<std::string>();
    for (std::size_t k = 0; k < spec.choices.size(); ++k)
      if (spec.choices[k] == value) return k;
    std::string list;
    for (const std::string_view c : spec.choices) {
      list += list.empty() ? "\"" : ", \"";
      list += c;
      list += '"';
    }
    fail(at(spec), "unknown value \"" + value + "\"; expected one of " + list);
  }
  template <class Enum>
  Enum choice_of(const KeySpec& spec) {
    return static_cast<Enum>(choice(spec));
  }

  ObjectReader object(const KeySpec& spec) { return object(spec.name()); }
  ObjectReader object(std::string_view key) {
    known_.insert(std::string(key));
    const auto it = j_.find(std::string(key));
    if (it == j_.end()) fail(at(key), "missing required key");
    return ObjectReader(*it, at(key));
  }

  const Json& raw(const KeySpec& spec) {
    known_.insert(std::string(spec.name()));
    const auto it = j_.find(std::string(spec.name()));
    if (it == j_.end()) fail(at(spec), "missing required key");
    return *it;
  }

  // The path of a key the code names (it may go deeper: "end.strain"); the deck's own keys go through key_path.
  std::string at(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  }
  std::string at(const KeySpec& spec) const { return at(spec.name()); }
  const std::string& path() const { return path_; }

  // Call after reading every key: anything not asked for is a typo or an unsupported option.
  void finish() const {
    for (const auto& [key, _] : j_.items())
      if (!known_.count(key)) fail(key_path(path_, key), "unknown key");  // the deck's own key, quoted if odd
  }

 private:
  const Json* find(const KeySpec& spec) {
    known_.insert(std::string(spec.name()));
    const auto it = j_.find(std::string(spec.name()));
    if (it == j_.end() || (it->is_null() && !spec.required)) {
      if (!spec.required) return nullptr;
      fail(at(spec), "missing required key");
    }
    return &*it;
  }

  void check_range(const KeySpec& spec, double x) const {
    if (spec.positive && !(x > 0.0)) fail(at(spec), "must be > 0, got " + fmt(x));
    if (x < spec.min || x > spec.max)
      fail(at(spec), "must be in [" + fmt(spec.min) + ", " + fmt(spec.max) + "], got " + fmt(x));
  }

  const Json& j_;
  std::string path_;
  std::set<std::string> known_;
};

// Reads the listed keys into the struct's fields (the key table gives range and default).
template <class S, class T>
void read_fields(ObjectReader& r, S& s, const std::initializer_list<std::pair<const KeySpec*, T S::*>>& fields) {
  for (const auto& [key, field] : fields) {
    if constexpr (std::is_same_v<T, double>) s.*field = r.number(*key);
    else s.*field = r.integer(*key);
  }
}

// An array of finite numbers; each element's errors name it (`path[i]`).
std::vector<double> read_numbers(ObjectReader& r, const KeySpec& spec) {
  const Json& list = r.raw(spec);
  const std::string path = r.at(spec);
  if (!list.is_array()) fail(path, "expected an array, got " + std::string(list.type_name()));
  std::vector<double> out;
  for (std::size_t i = 0; i < list.size(); ++i) {
    if (!list[i].is_number()) fail(path + "[" + std::to_string(i) + "]", "expected a number");
    out.push_back(list[i].get<double>());
    if (!std::isfinite(out.back())) fail(path + "[" + std::to_string(i) + "]", "must be finite");
  }
  return out;
}

GradingDef read_grading(ObjectReader r) {
  GradingDef g;
  g.by = r.choice_of<GradingBasis>(keys::sample_diameters_grading_by);
  g.sizes = read_numbers(r, keys::sample_diameters_grading_sizes);
  g.passing = read_numbers(r, keys::sample_diameters_grading_passing);
  const std::string sizes = r.at(keys::sample_diameters_grading_sizes);
  const std::string passing = r.at(keys::sample_diameters_grading_passing);
  const auto at = [](const std::string& path, std::size_t i) { return path + "[" + std::to_string(i) + "]"; };
  if (g.sizes.size() < 2) fail(sizes, "needs at least 2 sizes, got " + std::to_string(g.sizes.size()));
  for (std::size_t i = 0; i < g.sizes.size(); ++i) {
    if (!(g.sizes[i] > 0.0)) fail(at(sizes, i), "must be > 0, got " + fmt(g.sizes[i]));
    if (i > 0 && !(g.sizes[i] > g.sizes[i - 1]))
      fail(at(sizes, i), "must exceed the size before it (" + fmt(g.sizes[i - 1]) + "): sizes strictly increase");
  }
  if (g.passing.size() != g.sizes.size())
    fail(passing, "has " + std::to_string(g.passing.size()) + " entries, one per size expected (" +
                      std::to_string(g.sizes.size()) + ")");
  for (std::size_t i = 0; i < g.passing.size(); ++i) {
    if (g.passing[i] < 0.0 || g.passing[i] > 100.0) fail(at(passing, i), "must be in [0, 100], got " + fmt(g.passing[i]));
    if (i > 0 && g.passing[i] < g.passing[i - 1])
      fail(at(passing, i), "must be >= the percentage before it (" + fmt(g.passing[i - 1]) + "): passing never decreases");
  }
  if (g.passing.front() != 0.0)
    fail(at(passing, 0), "must be 0: the first size bounds every sphere from below, got " + fmt(g.passing.front()));
  if (g.passing.back() != 100.0)
    fail(at(passing, g.passing.size() - 1),
         "must be 100: the last size bounds every sphere from above, got " + fmt(g.passing.back()));
  r.finish();
  return g;
}

void read_diameters(ObjectReader d, SampleDef& s) {
  std::vector<double>& out = s.diameters;
  if (d.has(keys::sample_diameters_grading)) {
    for (const KeySpec* k : {&keys::sample_diameters_list, &keys::sample_diameters_min, &keys::sample_diameters_max,
                             &keys::sample_diameters_count})
      if (d.has(*k))
        fail(d.at(*k), "give one of \"list\", \"min\"/\"max\"/\"count\" or \"grading\", not more");
    s.grading = read_grading(d.object(keys::sample_diameters_grading));
  } else if (d.has(keys::sample_diameters_list)) {
    const Json& list = d.raw(keys::sample_diameters_list);
    const std::string path = d.at(keys::sample_diameters_list);
    if (!list.is_array() || list.empty()) fail(path, "expected a non-empty array");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string p = path + "[" + std::to_string(i) + "]";
      if (!list[i].is_number()) fail(p, "expected a number");
      const double x = list[i].get<double>();
      if (!(x > 0.0) || !std::isfinite(x)) fail(p, "must be a finite number > 0");
      out.push_back(x);
    }
    if (d.has(keys::sample_diameters_min) || d.has(keys::sample_diameters_max) || d.has(keys::sample_diameters_count))
      fail(d.path(), "give either \"list\" or \"min\"/\"max\"/\"count\", not both");
  } else {
    for (const KeySpec* k : {&keys::sample_diameters_min, &keys::sample_diameters_max, &keys::sample_diameters_count})
      if (!d.has(*k)) fail(d.at(*k), "missing required key (or give \"list\" or \"grading\")");
    const double lo = d.number(keys::sample_diameters_min);
    const double hi = d.number(keys::sample_diameters_max);
    const int n = static_cast<int>(d.integer(keys::sample_diameters_count));
    if (hi < lo) fail(d.at(keys::sample_diameters_max), "must be >= min");
    if (n == 1 && hi != lo) fail(d.at(keys::sample_diameters_count), "must be > 1 when max > min");
    for (int i = 0; i < n; ++i) out.push_back(n == 1 ? lo : lo + (hi - lo) * i / (n - 1));
  }
  d.finish();
}

// A sphere's mass and moment of inertia (m d^2 / 10) must be normal doubles, the largest finite: below the
// smallest normal double (2.2e-308) they lose their digits or vanish (a density of 1e-300 kg/m^3 made every
// sphere weigh nothing and was refused as a time step far above a stability limit of 1e-157 s), above the largest
// the motion is inf. The key named is the density, unless the diameters alone (at 1 kg/m^3) break the bound.
void check_sphere_masses(const ObjectReader& r, const SampleDef& s) {
  const auto mass = [](double density, double d) { return density * M_PI / 6.0 * d * d * d; };
  const double dmin = s.smallest_diameter(), dmax = s.largest_diameter();
  const double lightest = mass(s.density, dmin), heaviest = mass(s.density, dmax);
  const double inertia = 0.1 * lightest * dmin * dmin, largest_inertia = 0.1 * heaviest * dmax * dmax;
  constexpr double kNormal = std::numeric_limits<double>::min();
  if (inertia >= kNormal && std::isfinite(largest_inertia)) return;
  const double unit_inertia = 0.1 * mass(1.0, dmin) * dmin * dmin, unit_largest = 0.1 * mass(1.0, dmax) * dmax * dmax;
  const bool sizes = !(unit_inertia >= kNormal) || !std::isfinite(unit_largest);
  const std::string what = fmt(s.density) + " kg/m^3 with diameters " + fmt(dmin) + " to " + fmt(dmax) +
                           " m gives spheres of " + fmt(lightest) + " to " + fmt(heaviest) +
                           " kg (moments of inertia " + fmt(inertia) + " to " + fmt(largest_inertia) + " kg m^2)";
  fail(r.at(sizes ? keys::sample_diameters : keys::sample_density),
       what + (inertia >= kNormal ? ": beyond the largest double (1.8e308)" : ": below the smallest normal double "
                                                                               "(2.2e-308), where masses lose their "
                                                                               "digits or vanish") +
           (sizes ? "" : "; a density is in kg/m^3 (quartz: 2650)"));
}

SampleDef read_sample(ObjectReader r) {
  SampleDef s;
  s.count = static_cast<int>(r.integer(keys::sample_count));
  s.density = r.number(keys::sample_density);
  s.seed = static_cast<std::uint64_t>(r.integer(keys::sample_seed));
  read_diameters(r.object(keys::sample_diameters), s);
  check_sphere_masses(r, s);
  const double dmax = s.largest_diameter();
  s.grid_spacing = r.has(keys::sample_grid_spacing) ? r.number(keys::sample_grid_spacing) : 1.1 * dmax;
  if (s.grid_spacing <= dmax)
    fail(r.at(keys::sample_grid_spacing),
         "must exceed the largest diameter (" + fmt(dmax) + ") so that the initial spheres do not overlap");
  // The grid's cell (a cube of ceil(cbrt(count)) spacings a side) must have a volume a double holds.
  const double side = std::ceil(std::cbrt(static_cast<double>(s.count))) * s.grid_spacing;
  if (!std::isfinite(side * side * side))
    fail(r.at(keys::sample_grid_spacing), fmt(s.grid_spacing) + " m makes the initial cell " + fmt(side) +
                                              " m a side, whose volume overflows a double: give a spacing a little "
                                              "above the largest diameter (default 1.1 times it)");
  r.finish();
  return s;
}

// `contact.normal = "hertz"`: a sub-model choice as the messages name it.
std::string choice_text(std::string_view sub_model, std::string_view choice) {
  return "contact." + std::string(sub_model) + " = \"" + std::string(choice) + "\"";
}

// Why a key is refused when the deck makes none of its sub-model choices: the deck's choices of those sub-models,
// and the choices the key belongs to (from the key table's sub_models).
std::string unused_message(const KeySpec& spec, const SubModelSelection& selection) {
  std::string made, wanted;
  std::vector<std::string_view> seen;
  for (const SubModelChoice& use : spec.sub_models) {
    if (use.sub_model.empty()) break;
    const bool first = std::find(seen.begin(), seen.end(), use.sub_model) == seen.end();
    if (first) {
      seen.push_back(use.sub_model);
      made += (made.empty() ? "" : ", ") + choice_text(use.sub_model, selection[sub_model_index(use.sub_model)]);
      wanted += (wanted.empty() ? "" : ", ") + choice_text(use.sub_model, use.choice);
    } else {
      wanted += " or \"" + std::string(use.choice) + "\"";
    }
  }
  return "not used with " + made + " (only with " + wanted + ")";
}

// The keys of the object `r` (whose keys are `table_prefix` + name in the key table, e.g. "contact." or
// "tests[].") that belong to contact sub-models: each one the deck's choices do not use is refused, naming
// those choices; each one they use and need (required_when_used) must be there.
void check_sub_model_keys(ObjectReader& r, std::string_view table_prefix, const SubModelSelection& selection) {
  for (const KeySpec* k : keys::kAll) {
    if (k->sub_models[0].sub_model.empty() || !k->path.starts_with(table_prefix) ||
        k->path.find('.', table_prefix.size()) != std::string_view::npos)
      continue;
    const SubModelChoice* use = chosen_use(*k, selection);
    if (use == nullptr && r.has(*k)) fail(r.at(*k), unused_message(*k, selection));
    if (use != nullptr && k->required_when_used && !r.has(*k))
      fail(r.at(*k), "missing; required with " + choice_text(use->sub_model, use->choice));
  }
}

ContactDef read_contact(ObjectReader r) {
  ContactDef c;
  c.normal = r.choice_of<NormalModel>(keys::contact_normal);
  c.tangential = r.choice_of<TangentialModel>(keys::contact_tangential);
  c.rolling = r.choice_of<RollingModel>(keys::contact_rolling);
  c.twisting = r.choice_of<TwistingModel>(keys::contact_twisting);
  const SubModelSelection chosen = c.selection();
  check_sub_model_keys(r, "contact.", chosen);
  // Each parameter of the chosen sub-models (the others stay 0); reference_overlap 0: from the deck's stresses.
  for (const ContactParameter& p : kContactParameters)
    if (key_used(*p.key, chosen)) c.*p.field = r.number(*p.key);
  c.rotation = r.choice_of<TangentialRotation>(keys::contact_tangential_rotation);
  c.moment_arm = r.choice_of<MomentArm>(keys::contact_moment_arm);
  r.finish();
  return c;
}

DampingDef read_damping(ObjectReader r) {
  DampingDef d;
  d.translational = r.number(keys::damping_translational);
  d.rotational = r.number(keys::damping_rotational);
  r.finish();
  return d;
}

ServoDef read_servo(ObjectReader r) {
  ServoDef s;
  read_fields<ServoDef, double>(r, s, {{&keys::servo_gain, &ServoDef::gain},
                                       {&keys::servo_integral_gain, &ServoDef::integral_gain},
                                       {&keys::servo_max_strain_increment, &ServoDef::max_strain_increment}});
  s.max_strain_increment_given = r.has(keys::servo_max_strain_increment);
  if (s.gain == 0.0 && s.integral_gain == 0.0) fail(r.path(), "gain and integral_gain cannot both be zero");
  r.finish();
  return s;
}

AxisControl read_axis(ObjectReader r) {
  AxisControl a;
  int given = 0;
  const std::pair<const KeySpec*, AxisMode> controls[] = {
      {&keys::axis_strain_increment, AxisMode::StrainIncrement}, {&keys::axis_strain_rate, AxisMode::StrainRate},
      {&keys::axis_stress, AxisMode::Stress}, {&keys::axis_b, AxisMode::B},
      {&keys::axis_mean_stress, AxisMode::MeanStress}, {&keys::axis_constant_volume, AxisMode::ConstantVolume}};
  for (const auto& [spec, mode] : controls)
    if (r.has(*spec)) {
      if (mode == AxisMode::ConstantVolume) {
        if (!r.boolean(*spec)) fail(r.at(*spec), "only true is meaningful (leave the key out otherwise)");
        a = {mode, 0.0};
      } else {
        a = {mode, r.number(*spec)};
      }
      ++given;
    }
  if (r.has(keys::axis_stress_ramp)) {
    ObjectReader ramp = r.object(keys::axis_stress_ramp);
    a = {AxisMode::StressRamp, ramp.number(keys::axis_stress_ramp_from), ramp.number(keys::axis_stress_ramp_rate)};
    if (a.rate == 0.0) fail(ramp.at(keys::axis_stress_ramp_rate), "must be non-zero (a constant target is \"stress\")");
    ramp.finish();
    ++given;
  }
  if (given != 1)
    fail(r.path(), "give exactly one of \"strain_increment\", \"strain_rate\", \"stress\", \"stress_ramp\", \"b\", "
                   "\"mean_stress\", \"constant_volume\"");
  r.finish();
  return a;
}

// A shear axis (x12, x13, x23): its strain per step or rate, or a shear stress target of either sign.
AxisControl read_shear_axis(ObjectReader r) {
  AxisControl a;
  int given = 0;
  const std::pair<const KeySpec*, AxisMode> controls[] = {{&keys::shear_axis_strain_increment, AxisMode::StrainIncrement},
                                                          {&keys::shear_axis_strain_rate, AxisMode::StrainRate},
                                                          {&keys::shear_axis_stress, AxisMode::Stress}};
  for (const auto& [spec, mode] : controls)
    if (r.has(*spec)) a = {mode, r.number(*spec)}, ++given;
  r.finish();  // first: a normal axis's control (b, mean_stress, ...) is an unknown key here, named as such
  if (given != 1) fail(r.path(), "give exactly one of \"strain_increment\", \"strain_rate\", \"stress\" (a shear axis)");
  return a;
}

LegEnd read_end(ObjectReader end, bool preparation) {
  LegEnd e;
  int given = 0;
  if (end.has(keys::test_end_strain)) e.kind = LegEndKind::Strain, e.value = end.number(keys::test_end_strain), ++given;
  if (end.has(keys::test_end_ratio)) e.kind = LegEndKind::Ratio, e.value = end.number(keys::test_end_ratio), ++given;
  if (end.has(keys::test_end_stress)) e.kind = LegEndKind::Stress, e.value = end.number(keys::test_end_stress), ++given;
  if (end.has(keys::test_end_steps)) e.kind = LegEndKind::Steps, e.steps = end.integer(keys::test_end_steps), ++given;
  if (preparation && end.has(keys::end_solid_fraction))
    e.kind = LegEndKind::SolidFraction, e.value = end.number(keys::end_solid_fraction), ++given;
  const KeySpec& equilibrium = preparation ? keys::end_equilibrium : keys::test_end_equilibrium;
  if (end.has(equilibrium)) {
    if (!end.boolean(equilibrium)) fail(end.at(equilibrium), "only true is meaningful");
    e.kind = LegEndKind::Equilibrium, ++given;
  }
  if (given != 1)
    fail(end.path(), preparation ? "give exactly one of \"strain\", \"ratio\", \"stress\", \"steps\", "
                                   "\"solid_fraction\", \"equilibrium\""
                                 : "give exactly one of \"strain\", \"ratio\", \"stress\", \"steps\", \"equilibrium\"");
  e.axis = static_cast<int>(end.choice(keys::test_end_axis));
  if (is_shear_component(e.axis) && e.kind != LegEndKind::Strain)  // (kEndAxisNames): its engineering shear strain
    fail(end.at(keys::test_end_axis), "a shear axis ends a leg only on its strain (\"strain\": g_ij)");
  e.max_steps = end.integer(keys::test_end_max_steps);
  end.finish();
  return e;
}

// Ends that a leg's own servo keeps it from: a stress end on an axis that the leg holds at a constant stress
// while the axis starts the leg at a known stress, with the end stress not between the two (beyond
// kServoReachMargin of the target: a held stress wanders around its target as the packing yields, a few per cent;
// the control warnings start at 0.5 %); a ratio end s11/s33 with x1 and x3 held all leg at the stresses they
// start it at, of another ratio. The run would stop at max_steps advising to raise it. A leg starts an axis at a
// known stress after a leg that ended on that axis's stress or in equilibrium, or held it at the stress it started
// it at; `start` holds them (NaN: unknown) and returns them after the program. A rotation's targets move: its legs
// are not judged and leave the stresses unknown. `name(j)` is leg j's path.
inline constexpr double kServoReachMargin = 0.1;

std::array<double, 3> check_servo_reach(const std::vector<Leg>& legs, std::array<double, 3> start,
                                        const std::function<std::string(std::size_t)>& name) {
  const double unknown = std::numeric_limits<double>::quiet_NaN();
  const auto near = [](double a, double b) { return std::abs(a - b) <= kServoReachMargin * std::abs(b); };
  for (std::size_t j = 0; j < legs.size(); ++j) {
    const Leg& leg = legs[j];
    const LegEnd& e = leg.end;
    std::array<double, 3> held{unknown, unknown, unknown};
    for (std::size_t k = 0; k < 3; ++k)
      if (leg.axes[k].mode == AxisMode::Stress && !leg.rotation) held[k] = leg.axes[k].value;
    const auto a = static_cast<std::size_t>(e.axis);
    if (e.kind == LegEndKind::Stress && !std::isnan(held[a]) && !std::isnan(start[a])) {
      const double m = kServoReachMargin * held[a];
      if (e.value < std::min(start[a], held[a]) - m || e.value > std::max(start[a], held[a]) + m)
        fail(name(j) + "end.stress", "the leg holds axis " + std::string(kAxisNames[a]) + " at " + fmt(held[a]) +
                                         " Pa by its servo from " + fmt(start[a]) + " Pa at the leg start: it never "
                                         "reaches this end stress " + fmt(e.value) + " Pa (drive the axis, or give it "
                                         "a stress_ramp towards it)");
    }
    if (e.kind == LegEndKind::Ratio && !std::isnan(held[0]) && !std::isnan(held[2]) && !std::isnan(start[0]) &&
        !std::isnan(start[2]) && near(start[0], held[0]) && near(start[2], held[2])) {
      const double ratio = held[0] / held[2], lo = (1.0 - kServoReachMargin) / (1.0 + kServoReachMargin);
      if (e.value < ratio * lo || e.value > ratio / lo)
        fail(name(j) + "end.ratio", "the leg holds x1 at " + fmt(held[0]) + " Pa and x3 at " + fmt(held[2]) +
                                        " Pa by its servo, as they start it (s11/s33 = " + fmt(ratio) + "): it "
                                        "never reaches this end ratio " + fmt(e.value) + " (drive x1 or x3)");
    }
    for (std::size_t k = 0; k < 3; ++k) {  // where the next leg starts
      const bool stays = !std::isnan(held[k]) && !std::isnan(start[k]) && near(start[k], held[k]);
      start[k] = e.kind == LegEndKind::Stress && a == k           ? e.value
                 : e.kind == LegEndKind::Equilibrium && !leg.rotation ? leg.axes[k].value
                 : stays                                             ? held[k]
                                                                     : unknown;
    }
  }
  return start;
}

// The rules that make a leg's controls well defined; `at` is the leg's path.
void check_leg(const Leg& leg, const std::string& at) {
  int driven = 0, stress = 0, b = 0;
  double mean = -1.0;
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = leg.axes[k];
    driven += a.strain_driven();
    stress += a.mode == AxisMode::Stress || a.mode == AxisMode::MeanStress;
    b += a.mode == AxisMode::B;
    if (a.mode == AxisMode::MeanStress) {
      if (mean >= 0.0 && a.value != mean)
        fail(at + ".axes." + std::string(kAxisNames[k]) + ".mean_stress", "every mean_stress axis must give the same value");
      mean = a.value;
    }
  }
  for (int k = 0; k < 3; ++k) {
    const std::string axis = at + ".axes." + std::string(kAxisNames[k]);
    if (leg.axes[k].mode == AxisMode::B && (driven != 1 || stress != 1))
      fail(axis + ".b", "a b axis needs exactly one strain-driven axis (the major stress) and one other stress or "
                        "mean_stress axis (the minor stress)");
    if (leg.axes[k].mode == AxisMode::ConstantVolume && driven == 0)
      fail(axis + ".constant_volume", "a constant-volume axis needs a strain-driven axis to balance");
  }
  if (b > 1) fail(at + ".axes", "at most one b axis");
  for (int k = 0; k < 3; ++k)
    if (leg.axes[k].mode == AxisMode::StressRamp && (b > 0 || mean >= 0.0))
      fail(at + ".axes." + std::string(kAxisNames[k]) + ".stress_ramp",
           "a stress_ramp axis cannot share a leg with b or mean_stress axes (their targets follow the other axes' "
           "stresses)");
  if (mean >= 0.0 && driven == 0 && b == 0 && stress < 3)
    fail(at + ".axes", "mean_stress axes need a strain-driven or b axis beside them, or all three on mean_stress");
  const LegEnd& e = leg.end;
  const std::string end = at + ".end";
  if (const AxisMode mode = leg.axes[static_cast<std::size_t>(e.axis)].mode;
      e.kind == LegEndKind::Strain && is_shear_component(e.axis) && !leg.axes[static_cast<std::size_t>(e.axis)].strain_driven()) {
    const std::string name(kComponentNames[static_cast<std::size_t>(e.axis)]);
    fail(end + ".axis", "a strain end on shear axis " + name + " needs the leg to drive " + name + " (axes." + name +
                            ".strain_increment or strain_rate, or simple_shear for x12): the leg " +
                            (mode == AxisMode::Held ? "holds its tilt" : "holds a stress on it"));
  }
  if (e.kind == LegEndKind::Strain) {
    const bool driven_end = leg.axes[e.axis].strain_driven();
    if (driven_end && leg.strain_per_step(e.axis, 1.0) == 0.0)
      fail(end + ".axis", "the end axis is held at zero strain increment: it never moves");
    if (!driven_end && e.max_steps == 0)
      fail(end + ".max_steps", "a strain end on an axis that is not strain-driven needs max_steps (it may never be "
                               "reached)");
  }
  if (leg.rotation) {  // the axis beside the rotation's plane: a plain stress or strain
    if (e.kind == LegEndKind::Equilibrium)
      fail(end + ".equilibrium", "a principal-axis rotation's targets move: end it on steps");
    for (int k = 0; k < 3; ++k)
      if (leg.axes[k].mode != AxisMode::Stress && !leg.axes[k].strain_driven())
        fail(at + ".axes." + std::string(kAxisNames[k]),
             "beside rotate_principal_axes an axis holds a stress or a strain (b, mean_stress, stress_ramp and "
             "constant_volume follow other axes' stresses or strains)");
  }
  if (e.kind == LegEndKind::Equilibrium) {
    for (int k = 0; k < 3; ++k)
      if (leg.axes[k].mode != AxisMode::Stress && leg.axes[k].mode != AxisMode::MeanStress)
        fail(end + ".equilibrium", "a leg that ends in equilibrium needs every axis on stress or mean_stress");
    for (int a = 0; a < 3; ++a)
      if (leg.strain_per_step(3 + a, 1.0) != 0.0)
        fail(at + ".axes." + std::string(kShearAxisNames[a]),
             "a leg that ends in equilibrium cannot strain a shear axis (hold it: stress or a zero strain)");
  }
  if ((e.kind == LegEndKind::Ratio || e.kind == LegEndKind::Stress) && e.max_steps == 0)
    fail(end + ".max_steps", "a ratio or stress end needs max_steps (it may never be reached)");
  if (const AxisControl& a = leg.axes[e.axis]; e.kind == LegEndKind::Stress && a.mode == AxisMode::StressRamp &&
                                                 (e.value - a.value) * a.rate <= 0.0)
    fail(end + ".stress", "the stress_ramp of axis " + std::string(kAxisNames[e.axis]) + " moves away from this end "
                          "stress (from " + fmt(a.value) + " Pa at " + fmt(a.rate) + " Pa/s)");
}

// simple_shear: g12 driven, s22 held by the servo, e1 = e3 = 0, the tilts xz and yz held.
void read_simple_shear(ObjectReader r, Leg& leg) {
  const bool by_increment = r.has(keys::simple_shear_gamma_increment), by_rate = r.has(keys::simple_shear_gamma_rate);
  if (by_increment == by_rate) fail(r.path(), "give exactly one of \"gamma_increment\", \"gamma_rate\"");
  const AxisControl shear = by_increment ? AxisControl{AxisMode::StrainIncrement, r.number(keys::simple_shear_gamma_increment)}
                                         : AxisControl{AxisMode::StrainRate, r.number(keys::simple_shear_gamma_rate)};
  if (shear.value == 0.0) fail(r.at(by_increment ? keys::simple_shear_gamma_increment : keys::simple_shear_gamma_rate),
                               "must be non-zero (a simple shear that does not shear)");
  const AxisControl held{AxisMode::StrainIncrement, 0.0};
  leg.axes = {held, AxisControl{AxisMode::Stress, r.number(keys::simple_shear_normal_stress)}, held};
  leg.axes[3] = shear;
  r.finish();
}

// rotate_principal_axes: the plane, the principal values and the angle's course.
PrincipalRotation read_rotation(ObjectReader r) {
  constexpr double kRadian = 3.14159265358979323846 / 180.0;
  PrincipalRotation rot;
  rot.plane = static_cast<int>(r.choice(keys::rotation_plane));
  rot.sigma1 = r.number(keys::rotation_sigma1);
  rot.sigma3 = r.number(keys::rotation_sigma3);
  if (rot.sigma3 > rot.sigma1) fail(r.at(keys::rotation_sigma3), "must be <= sigma1 (" + fmt(rot.sigma1) + ")");
  rot.from = r.number(keys::rotation_from) * kRadian;
  const bool by_rate = r.has(keys::rotation_rate), by_increment = r.has(keys::rotation_angle_increment);
  if (by_rate == by_increment) fail(r.path(), "give exactly one of \"rate\", \"angle_increment\"");
  const KeySpec& key = by_rate ? keys::rotation_rate : keys::rotation_angle_increment;
  rot.rate = r.number(key) * kRadian;
  rot.per_step = by_increment;
  if (rot.rate == 0.0) fail(r.at(key), "must be non-zero (a rotation that does not turn is `stress` axes)");
  r.finish();
  return rot;
}

AdaptiveRate read_adaptive_rate(ObjectReader r) {
  AdaptiveRate a;
  a.min_factor = r.number(keys::adaptive_min_factor);
  a.max_factor = r.number(keys::adaptive_max_factor);
  a.unbalanced_force_ratio = r.number(keys::adaptive_unbalanced_force_ratio);
  a.kinetic_to_elastic = r.number(keys::adaptive_kinetic_to_elastic);
  a.inertial_number = r.number(keys::adaptive_inertial_number);
  a.check_interval = r.integer(keys::adaptive_check_interval);
  r.finish();
  return a;
}

Leg read_leg(ObjectReader& r, bool preparation) {
  Leg leg;
  if (r.has(keys::test_rotate_principal_axes)) leg.rotation = read_rotation(r.object(keys::test_rotate_principal_axes));
  const bool simple_shear = r.has(keys::test_simple_shear);
  if (simple_shear) {
    if (r.has(keys::test_axes)) fail(r.at(keys::test_simple_shear), "give either \"simple_shear\" or \"axes\", not both");
    if (leg.rotation) fail(r.at(keys::test_simple_shear), "give either \"simple_shear\" or \"rotate_principal_axes\", not both");
    read_simple_shear(r.object(keys::test_simple_shear), leg);
  } else {
    ObjectReader axes = r.object(keys::test_axes);
    const int plane = leg.rotation ? leg.rotation->plane : -1;
    const auto rotated = [&](int i) { return plane >= 0 && (kShearAxisEntries[plane][0] == i || kShearAxisEntries[plane][1] == i); };
    for (int i = 0; i < 3; ++i) {
      if (rotated(i)) {
        if (axes.has(kAxisNames[i]))
          fail(axes.at(kAxisNames[i]), "set by rotate_principal_axes (plane " + std::string(kPlaneNames[plane]) +
                                           "): leave it out");
        continue;
      }
      leg.axes[i] = read_axis(axes.object(kAxisNames[i]));
    }
    for (int a = 0; a < 3; ++a) {
      if (a == plane && axes.has(kShearAxisNames[a]))
        fail(axes.at(kShearAxisNames[a]), "set by rotate_principal_axes (plane " + std::string(kPlaneNames[plane]) +
                                              "): leave it out");
      if (axes.has(kShearAxisNames[a])) leg.axes[3 + a] = read_shear_axis(axes.object(kShearAxisNames[a]));
    }
    axes.finish();
    if (leg.rotation) {  // the plane's controls: stress axes at the leg start's targets (moved by the control)
      const std::array<double, 3> t = leg.rotation->targets(0.0, 1.0);
      leg.axes[kShearAxisEntries[plane][0]] = {AxisMode::Stress, t[0]};
      leg.axes[kShearAxisEntries[plane][1]] = {AxisMode::Stress, t[1]};
      leg.axes[3 + plane] = AxisControl{AxisMode::Stress, t[2]};
      // The principal axes stay in the plane: the other shear stresses are held at 0 unless the leg names them.
      for (int a = 0; a < 3; ++a)
        if (leg.axes[3 + a].mode == AxisMode::Held) leg.axes[3 + a] = AxisControl{AxisMode::Stress, 0.0};
    }
  }
  if (r.has(keys::test_zero_shear_stress)) {
    if (!r.boolean(keys::test_zero_shear_stress))
      fail(r.at(keys::test_zero_shear_stress), "only true is meaningful (leave the key out otherwise)");
    for (int a = 0; a < 3; ++a)
      if (leg.axes[3 + a].mode != AxisMode::Held)
        fail(r.at(keys::test_zero_shear_stress),
             simple_shear ? std::string("contradicts simple_shear (which drives x12)")
             : leg.rotation ? std::string("contradicts rotate_principal_axes (which sets its plane's shear stress)")
                          : "contradicts the shear axis axes." + std::string(kShearAxisNames[a]) +
                                " (zero_shear_stress sets all three): give one or the other");
    for (int a = 0; a < 3; ++a) leg.axes[3 + a] = AxisControl{AxisMode::Stress, 0.0};
  }
  leg.end = read_end(r.object(keys::test_end), preparation);
  if (r.has(keys::test_adaptive_rate)) {
    const std::string at = r.at(keys::test_adaptive_rate);
    if (preparation) fail(at, "tests only (the preparation's legs keep their rates)");
    leg.adaptive = read_adaptive_rate(r.object(keys::test_adaptive_rate));
    // What the factor scales: strain increments and rates. A stress ramp's or a rotation's target moves with the
    // leg's time, and a `steps` end would change its strain with the factor: neither has one meaning when the
    // rate varies.
    if (leg.rotation) fail(at, "not with rotate_principal_axes (its angle moves with time, not with the rate)");
    for (int k = 0; k < 3; ++k)
      if (leg.axes[k].mode == AxisMode::StressRamp)
        fail(at, "not with the stress_ramp of axis " + std::string(kAxisNames[k]) + " (its target moves with time)");
    if (leg.end.kind == LegEndKind::Steps)
      fail(at, "not with a `steps` end (the factor would change the leg's strain): end the leg on a strain, ratio or stress");
    if (leg_driving_increment(leg, 1.0) == 0.0)
      fail(at, "the leg drives no axis by a non-zero strain increment or rate: nothing to adapt");
  }
  return leg;
}

// A program: legs in order, blocks {"repeat": n, "legs": [...]} expanded in place.
void read_program(const Json& list, const std::string& path, bool preparation, std::vector<Leg>& out) {
  if (!list.is_array() || list.empty()) fail(path, "expected a non-empty array of legs");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string at = path + "[" + std::to_string(i) + "]";
    ObjectReader r(list[i], at);
    if (r.has(keys::leg_repeat)) {
      const std::int64_t times = r.integer(keys::leg_repeat);
      std::vector<Leg> block;
      read_program(r.raw(keys::test_legs), r.at(keys::test_legs), preparation, block);
      r.finish();
      if (static_cast<double>(out.size()) + static_cast<double>(times) * block.size() > 1e6)
        fail(at + ".repeat", "more than a million legs");
      for (std::int64_t k = 0; k < times; ++k) out.insert(out.end(), block.begin(), block.end());
    } else {
      const Leg leg = read_leg(r, preparation);
      check_leg(leg, at);
      r.finish();
      out.push_back(leg);
    }
  }
}

// A list of a test's named points (probes.at): each one of the key's choices ("peak", "end"),
// none twice.
std::vector<std::string> read_point_names(ObjectReader& r, const KeySpec& key, bool may_be_empty) {
  const Json& list = r.raw(key);
  const std::string path = r.at(key);
  if (!list.is_array() || (list.empty() && !may_be_empty)) fail(path, "expected a non-empty array of \"peak\" and \"end\"");
  std::vector<std::string> names;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string item = path + "[" + std::to_string(i) + "]";
    if (!list[i].is_string() || std::find(key.choices.begin(), key.choices.end(), list[i].get<std::string>()) == key.choices.end())
      fail(item, "expected \"peak\" or \"end\"");
    if (std::find(names.begin(), names.end(), list[i].get<std::string>()) != names.end()) fail(item, "given twice");
    names.push_back(list[i].get<std::string>());
  }
  return names;
}

VerifyRateDef read_verify_rate(ObjectReader r) {
  VerifyRateDef v;
  if (r.has(keys::verify_rate_rungs) && r.has(keys::verify_rate_rate_factor))
    fail(r.at(keys::verify_rate_rate_factor), "not with `rungs` (rate_factor f stands for the rungs [f, f^2])");
  if (r.has(keys::verify_rate_twins) && r.has(keys::verify_rate_twin))
    fail(r.at(keys::verify_rate_twin), "not with `twins`");
  if (r.has(keys::verify_rate_rate_factor)) {
    const double f = r.number(keys::verify_rate_rate_factor);
    if (f * f < keys::verify_rate_rate_factor.min)
      fail(r.at(keys::verify_rate_rate_factor), "its second rung f^2 is below 0.001");
    v.rungs = {f, f * f};
  }
  if (r.has(keys::verify_rate_rungs)) {
    v.rungs = read_numbers(r, keys::verify_rate_rungs);
    if (v.rungs.size() < 2)
      fail(r.at(keys::verify_rate_rungs), "at least two rungs (with the test, three rates fit the order)");
    for (std::size_t i = 0; i < v.rungs.size(); ++i)
      if (!(v.rungs[i] >= 1e-3 && v.rungs[i] <= 0.999))
        fail(r.at(keys::verify_rate_rungs) + "[" + std::to_string(i) + "]",
             "expected a rate over the test's in [0.001, 0.999]");
    std::sort(v.rungs.begin(), v.rungs.end(), std::greater<>());
    if (std::adjacent_find(v.rungs.begin(), v.rungs.end()) != v.rungs.end())
      fail(r.at(keys::verify_rate_rungs), "a rung given twice");
  }
  if (r.has(keys::verify_rate_twins)) v.twins = static_cast<int>(r.integer(keys::verify_rate_twins));
  if (r.has(keys::verify_rate_twin) && !r.boolean(keys::verify_rate_twin)) v.twins = 0;
  r.finish();
  return v;
}

ProbeDef read_probes(ObjectReader r) {
  ProbeDef p;
  if (r.has(keys::probes_at)) p.at = read_point_names(r, keys::probes_at, /*may_be_empty=*/true);
  if (r.has(keys::probes_at_e1)) {
    p.at_e1 = read_numbers(r, keys::probes_at_e1);
    for (std::size_t i = 0; i < p.at_e1.size(); ++i)
      if (std::abs(p.at_e1[i]) > 0.9) fail(r.at(keys::probes_at_e1) + "[" + std::to_string(i) + "]", "expected a strain in [-0.9, 0.9]");
    std::sort(p.at_e1.begin(), p.at_e1.end());
    if (std::adjacent_find(p.at_e1.begin(), p.at_e1.end()) != p.at_e1.end()) fail(r.at(keys::probes_at_e1), "a strain given twice");
  }
  if (p.at.empty() && p.at_e1.empty()) fail(r.path(), "give the points: \"at\" ([\"peak\", \"end\"]) or \"at_e1\" (strains)");
  p.kind = r.choice_of<ProbeKind>(keys::probes_kind);
  const bool stress = p.kind == ProbeKind::Stress;
  for (const KeySpec* key : {&keys::probes_plane, &keys::probes_directions, &keys::probes_list})
    if (!stress && r.has(*key)) fail(r.at(*key), "only stress probes have directions in a plane (strain probes take the six strains)");
  p.plane = r.choice_of<ProbePlane>(keys::probes_plane);
  if (r.has(keys::probes_directions) && p.plane == ProbePlane::List)
    fail(r.at(keys::probes_directions), "the `list` plane takes its directions from \"list\"");
  p.directions = static_cast<int>(r.integer(keys::probes_directions));
  if (p.plane == ProbePlane::List) {
    const Json& list = r.raw(keys::probes_list);
    const std::string path = r.at(keys::probes_list);
    if (!list.is_array() || list.empty()) fail(path, "expected a non-empty array of [ds11, ds22, ds33]");
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string item = path + "[" + std::to_string(i) + "]";
      if (!list[i].is_array() || list[i].size() != 3) fail(item, "expected [ds11, ds22, ds33]");
      std::array<double, 3> d{};
      for (int k = 0; k < 3; ++k) {
        if (!list[i][k].is_number() || !std::isfinite(list[i][k].get<double>())) fail(item, "expected three finite numbers");
        d[k] = list[i][k].get<double>();
      }
      // The length as the sum of squares gives it (the normalisation decks have always had): a sum that overflows
      // (components above about 1e154) or falls below the smallest normal double is refused, not normalised to 0.
      const double squares = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
      const bool zero = d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0;
      if (zero) fail(item, "the direction has length 0");
      if (!std::isfinite(squares))
        fail(item, "the direction's length overflows: its squared length is above the largest double (1.8e308); a "
                   "direction is normalised to length 1, give components of ordinary size");
      if (squares < std::numeric_limits<double>::min())
        fail(item, "the direction's squared length " + fmt(squares) + " is below the smallest normal double "
                   "(2.2e-308), where its components lose their digits: give components of ordinary size");
      const double length = std::sqrt(squares);
      for (double& x : d) x /= length;
      p.list.push_back(d);
    }
  } else if (r.has(keys::probes_list)) {
    fail(r.at(keys::probes_list), "a list of directions needs \"plane\": \"list\"");
  }
  p.target_strain = r.number(keys::probes_target_strain);
  p.scaled = !r.has(keys::probes_magnitudes);
  if (p.scaled) {  // factors of the point's scale (run/probes.cpp): two sizes show the linear range
    p.magnitudes = stress ? std::vector<double>{1.0, 2.0} : std::vector<double>{p.target_strain};
  } else {
    p.magnitudes = read_numbers(r, keys::probes_magnitudes);
    if (p.magnitudes.empty()) fail(r.at(keys::probes_magnitudes), "expected at least one magnitude");
  }
  for (std::size_t i = 0; i < p.magnitudes.size(); ++i) {
    const std::string item = r.at(keys::probes_magnitudes) + "[" + std::to_string(i) + "]";
    if (!(p.magnitudes[i] > 0.0)) fail(item, "must be > 0");
    if (!stress && p.magnitudes[i] > 0.01) fail(item, "a strain probe's strain must be at most 0.01 (it probes the tangent)");
    if (!stress && p.magnitudes[i] < keys::probes_target_strain.min)
      fail(item, "a strain probe's strain must be at least " + fmt(keys::probes_target_strain.min) +
                     " (the smallest target_strain): a smaller one measures round-off, not the tangent");
  }
  p.steps = r.integer(keys::probes_steps);
  p.hold_steps = r.integer(keys::probes_hold_steps);
  p.rest_fraction = r.number(keys::probes_rest_fraction);
  p.rest_max_steps = r.integer(keys::probes_rest_max_steps);
  p.drift_limit = r.number(keys::probes_drift_limit);
  p.elastic_factor = r.number(keys::probes_elastic_factor);
  if (!stress && r.has(keys::probes_elastic_factor))
    fail(r.at(keys::probes_elastic_factor), "only stress probes have an elastic part to compare with C_elastic^-1 ds");
  p.asymmetry_limit = r.number(keys::probes_asymmetry_limit);
  r.finish();
  return p;
}

SnapshotDef read_snapshots(ObjectReader r) {
  SnapshotDef s;
  s.interval = r.integer(keys::snapshots_interval);
  if (r.has(keys::snapshots_e1)) {
    const Json& list = r.raw(keys::snapshots_e1);
    const std::string path = r.at(keys::snapshots_e1);
    if (!list.is_array() || list.empty()) fail(path, "expected a non-empty array of strains");
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (!list[i].is_number() || !std::isfinite(list[i].get<double>()) || std::abs(list[i].get<double>()) > 0.9)
        fail(path + "[" + std::to_string(i) + "]", "expected a strain in [-0.9, 0.9]");
      s.e1.push_back(list[i].get<double>());
    }
    std::sort(s.e1.begin(), s.e1.end());
  }
  s.format = r.choice_of<SnapshotFormat>(keys::snapshots_format);
  if (!s.any()) fail(r.path(), "give \"interval\" or \"e1\"");
  r.finish();
  return s;
}

// A stress probe's increment M [Pa] below kSmallestProbeFraction of the stress the test holds measures nothing: the
// stress it is read on is a sum over every contact, each term rounded at 2.2e-16, whose round-off reaches N eps
// of the stress (2e-11 over 1e5 contacts); 1e-9 keeps the increment 50 times above that. (A probe of 1e-12 Pa at
// 1e5 Pa held nothing but round-off: its point was called `drifting` with a drift of 0.) The stress is the
// largest the test's legs hold or end on, else the deck's (the preparation's); no stress anywhere: no bound.
inline constexpr double kSmallestProbeFraction = 1e-9;

void check_probe_magnitudes(const Deck& d) {
  const double deck_stress = largest_deck_stress(d);
  for (std::size_t i = 0; i < d.tests.size(); ++i) {
    const TestDef& t = d.tests[i];
    if (!t.probes || t.probes->kind != ProbeKind::Stress || t.probes->scaled) continue;
    double stress = 0.0;
    for (const Leg& leg : t.legs) {
      for (int k = 0; k < 3; ++k)
        if (leg.axes[static_cast<std::size_t>(k)].stress_driven() && leg.axes[static_cast<std::size_t>(k)].mode != AxisMode::B)
          stress = std::max(stress, std::abs(leg.axes[static_cast<std::size_t>(k)].value));
      if (leg.end.kind == LegEndKind::Stress) stress = std::max(stress, leg.end.value);
    }
    const bool own = stress > 0.0;
    if (!own) stress = deck_stress;
    for (std::size_t m = 0; m < t.probes->magnitudes.size(); ++m) {
      const double magnitude = t.probes->magnitudes[m];
      if (!(magnitude < kSmallestProbeFraction * stress)) continue;
      fail("tests[" + std::to_string(i) + "].probes.magnitudes[" + std::to_string(m) + "]",
           fmt(magnitude) + " Pa is " + fmt(magnitude / stress) + " of the " + (own ? "test's" : "deck's") +
               " stress (" + fmt(stress) + " Pa), below " + fmt(kSmallestProbeFraction) + " of it: the increment is "
               "lost in the round-off of the stress it is measured on (a sum over every contact); a probe is a few "
               "per cent of the stress (e.g. " + fmt(0.02 * stress) + " Pa)");
    }
  }
}

// The path of leg j's keys as messages name them, up to the key ("tests[0].end." in the one-leg form).
std::function<std::string(std::size_t)> leg_paths(const std::string& path, bool one_leg) {
  return [path, one_leg](std::size_t j) {
    return one_leg ? path + "." : path + " (leg " + std::to_string(j) + " of the program, repeats unrolled): ";
  };
}

// The strain ends of every leg whose start strain is known ahead (the one-leg form's, and each leg of a program
// after legs of known length): a leg that drives its end axis away from its end strain (the run stops there when
// the leg starts: LegEndWatch), and a leg shorter than one step (an end strain below one step's increment, or a
// strain rate so large that one step passes the end).
void check_leg_lengths(const TestDef& t, double time_step, const std::string& legs_path, bool one_leg) {
  std::vector<double> from;
  const std::vector<std::int64_t> steps = program_leg_steps(t.legs, time_step, &from);
  const auto name = leg_paths(legs_path, one_leg);
  for (std::size_t j = 0; j < t.legs.size(); ++j) {
    const Leg& leg = t.legs[j];
    if (steps[j] < 0 || !leg.ends_on_driven_strain() || std::isnan(from[j])) continue;
    const int k = leg.end.axis;
    const double per_step = leg.end_strain_per_step(time_step), distance = leg.end.value - from[j];
    const std::string at = name(j) + "end.strain";
    if (distance * per_step < 0.0)
      fail(at, std::string("the end axis is not ") + (is_shear_component(k) ? "sheared" : "strained") +
                   " towards this value: axis " + component_name(k) + " moves " + fmt(per_step) + " per step from " +
                   fmt(from[j]) + " at the leg start, away from its end strain " + fmt(leg.end.value));
    // Steps are counted in integers: a leg longer than the schema's count bound (2^50) overflowed leg_steps.
    if (const double n = distance / per_step; !(n <= keys::kMaxCount))
      fail(at, "the leg takes " + fmt(n) + " steps (axis " + component_name(k) + " moves " + fmt(per_step) +
                   " per step over " + fmt(std::abs(distance)) + "), more than " + fmt(keys::kMaxCount) +
                   ": raise its strain increment or rate");
    // One whole step, less round-off (an end strain of exactly one increment is one step).
    if (std::abs(distance) >= std::abs(per_step) * (1.0 - 1e-9)) continue;
    const AxisControl& a = leg.axes[static_cast<std::size_t>(k)];
    fail(at, "the leg is shorter than one step: axis " + std::string(kComponentNames[static_cast<std::size_t>(k)]) +
                 " moves " + fmt(per_step) +
                 " per step (" + (a.mode == AxisMode::StrainRate ? "strain_rate " + fmt(a.value) + " 1/s x time_step " +
                                                                       fmt(time_step) + " s"
                                                                 : "strain_increment " + fmt(a.value)) +
                 "), more than the distance " + fmt(std::abs(distance)) + " to its end strain " + fmt(leg.end.value) +
                 ": lower the rate or move the end strain further");
  }
}

// Which key fills which field.
template <class S, class T>
using Bindings = std::initializer_list<std::pair<const KeySpec*, T S::*>>;
using E = EquilibriumDef;
using P = PrepareDef;
const Bindings<E, double> kEquilibriumTolerances = {
    {&keys::equilibrium_pressure_tolerance, &E::pressure_tolerance},
    {&keys::equilibrium_stress_tolerance, &E::stress_tolerance},
    {&keys::equilibrium_unbalanced_force_ratio, &E::unbalanced_force_ratio}};
const Bindings<E, std::int64_t> kEquilibriumSteps = {{&keys::equilibrium_min_steps, &E::min_steps},
                                                     {&keys::equilibrium_check_interval, &E::check_interval},
                                                     {&keys::equilibrium_max_steps, &E::max_steps}};

// The listed keys the object gives into the struct's fields; the others keep their values.
template <class S, class T>
void read_given_fields(ObjectReader& r, S& s, const Bindings<S, T>& fields) {
  for (const auto& [key, field] : fields)
    if (r.has(*key)) {
      if constexpr (std::is_same_v<T, double>) s.*field = r.number(*key);
      else s.*field = r.integer(*key);
    }
}

// `start_stress`: the normal stresses the test starts at where the preparation's servo set them (NaN: unknown).
TestDef read_test(ObjectReader r, const ContactDef& contact, double time_step, const EquilibriumDef& equilibrium,
                  const std::array<double, 3>& start_stress) {
  TestDef t;
  t.equilibrium = equilibrium;
  t.name = r.string(keys::test_name);
  if (t.name.empty() || t.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") !=
                            std::string::npos)
    fail(r.at(keys::test_name), "must be a non-empty name of letters, digits, '_' or '-'");
  // The name becomes a folder and its files' prefix: one limit for check and run, far below NAME_MAX.
  if (t.name.size() > keys::kMaxTestNameLength)
    fail(r.at(keys::test_name), "must be at most " + std::to_string(keys::kMaxTestNameLength) + " characters (it has " +
                                    std::to_string(t.name.size()) + ")");
  if (is_reserved_stage_name(t.name))
    fail(r.at(keys::test_name), "\"" + t.name + "\" is reserved (the preparation stage); choose another name");
  t.friction = r.number(keys::test_friction);
  if (r.has(keys::test_time_step)) t.time_step = r.number(keys::test_time_step);
  time_step = t.time_step.value_or(time_step);  // the leg lengths below are the stage's
  check_sub_model_keys(r, "tests[].", contact.selection());
  t.rolling_friction = r.has(keys::test_rolling_friction) ? r.number(keys::test_rolling_friction)
                                                          : contact.rolling_friction;
  if (r.has(keys::test_legs)) {
    if (r.has(keys::test_axes) || r.has(keys::test_end) || r.has(keys::test_simple_shear))
      fail(r.at(keys::test_legs), "give either \"legs\" or \"axes\" (or \"simple_shear\") and \"end\", not both");
    read_program(r.raw(keys::test_legs), r.at(keys::test_legs), false, t.legs);
    check_leg_lengths(t, time_step, r.at(keys::test_legs), false);
    check_servo_reach(t.legs, start_stress, leg_paths(r.at(keys::test_legs), false));
  } else {
    const Leg leg = read_leg(r, false);
    // The one-leg form: the axis that ends the test must be strain-controlled (a program's leg may end on the
    // strain of a normal axis it holds by stress, with max_steps). Its direction: check_leg_lengths, every leg's.
    if (leg.end.kind == LegEndKind::Strain) {
      const AxisControl& driver = leg.axes[static_cast<std::size_t>(leg.end.axis)];
      const std::string name = component_name(leg.end.axis);
      if (!driver.strain_driven())
        fail(r.at("end.axis"), "the axis that ends the test (" + name + ") must be strain-controlled" +
                                   (driver.mode == AxisMode::Held ? std::string(": the test holds its tilt") : std::string(": the test holds a stress on it")));
      if (leg.end.value == 0.0) fail(r.at("end.strain"), "must be non-zero");
      if (driver.value == 0.0)
        fail(r.at("end.strain"), std::string("the end axis is not ") +
                                     (is_shear_component(leg.end.axis) ? "sheared" : "strained") + " towards this value");
    }
    check_leg(leg, r.path());
    t.legs.push_back(leg);
    check_leg_lengths(t, time_step, r.path(), true);
    check_servo_reach(t.legs, start_stress, leg_paths(r.path(), true));
  }
  if (r.has(keys::test_equilibrium)) {
    ObjectReader e = r.object(keys::test_equilibrium);
    read_given_fields(e, t.equilibrium, kEquilibriumTolerances);
    read_given_fields(e, t.equilibrium, kEquilibriumSteps);
    e.finish();
  }
  t.output_interval = r.integer(keys::test_output_interval);
  if (r.has(keys::snapshots)) t.snapshots = read_snapshots(r.object(keys::snapshots));
  t.dynamic = r.boolean(keys::test_dynamic);
  if (r.has(keys::test_verify_rate)) t.verify_rate = read_verify_rate(r.object(keys::test_verify_rate));
  if (r.has(keys::test_probes)) t.probes = read_probes(r.object(keys::test_probes));
  r.finish();
  return t;
}

const Bindings<P, double> kPrepareNumbers = {{&keys::prepare_friction, &P::friction},
                                             {&keys::prepare_rolling_friction, &P::rolling_friction},
                                             {&keys::prepare_target_pressure, &P::target_pressure},
                                             {&keys::prepare_fast_solid_fraction, &P::fast_solid_fraction},
                                             {&keys::prepare_fast_strain_increment, &P::fast_strain_increment},
                                             {&keys::prepare_relax_overlaps, &P::relax_overlaps}};

PrepareDef read_prepare(ObjectReader r) {
  PrepareDef p;
  if (r.has(keys::prepare_legs))
    read_program(r.raw(keys::prepare_legs), r.at(keys::prepare_legs), true, p.legs);
  else if (!r.has(keys::prepare_target_pressure))
    fail(r.at(keys::prepare_target_pressure), "missing required key (or give \"legs\")");
  read_fields(r, p, kPrepareNumbers);
  if (r.has(keys::prepare_time_step)) p.time_step = r.number(keys::prepare_time_step);
  if (r.has(keys::prepare_servo_max_strain_increment))
    p.servo_max_strain_increment = r.number(keys::prepare_servo_max_strain_increment);
  p.output_interval = r.integer(keys::prepare_output_interval);
  if (r.has(keys::snapshots)) p.snapshots = read_snapshots(r.object(keys::snapshots));
  if (r.has(keys::prepare_equilibrium)) {
    ObjectReader e = r.object(keys::prepare_equilibrium);
    read_fields(e, p.equilibrium, kEquilibriumTolerances);
    read_fields(e, p.equilibrium, kEquilibriumSteps);
    e.finish();
  }
  p.default_legs = p.legs.empty();
  if (p.default_legs) p.legs = preparation_legs(p);
  r.finish();
  return p;
}

// Each spring's stability limit must be a normal double: a stiffness so large against the spheres' mass that the
// mode's frequency overflows gives a limit of 0 s (kn = 1e308 was refused as a time step "inf of the stability
// limit 0 s"), and one so small that the frequency underflows to 0 gives an infinite one. The key named is the
// spring's stiffness (the density and sizes are bounded by check_sphere_masses).
void check_mode_limits(const CriticalTimeStep& limit, const ContactDef& c) {
  for (const ModeLimit& mode : limit.modes) {
    if (!(mode.stiffness > 0.0)) continue;  // no such spring
    if (mode.time_step >= std::numeric_limits<double>::min() && std::isfinite(mode.time_step)) continue;
    const bool linear = mode.mode == ContactMode::Normal ? c.normal == NormalModel::Linear
                                                         : c.tangential == TangentialModel::LinearHistory;
    const std::string key = mode.mode == ContactMode::Rolling ? "contact.rolling_stiffness"
                            : linear ? (mode.mode == ContactMode::Normal ? "contact.kn" : "contact.kt")
                                     : "contact.youngs_modulus";
    fail(key, "the " + std::string(mode.name) + " mode's stability limit is " + fmt(mode.time_step) + " s (" +
                  mode.describe() + " against the smallest sphere's mass): beyond what a double resolves, give a "
                  "stiffness of ordinary size");
  }
}

// The reference overlap of hertz/mindlin (from the deck's stresses unless given), then the time step against
// the bounds that refuse it (core/plan: above the stability limit of the stiffest mode, or far below it).
void check_time_step(Deck& d) {
  ContactDef& c = d.contact;
  if (key_used(keys::contact_reference_overlap, c.selection()) && c.reference_overlap == 0.0) {
    c.reference_overlap = default_reference_overlap(d);
    if (c.reference_overlap == 0.0)
      fail("contact.reference_overlap", "missing; the deck names no stress to estimate the largest overlap from");
  }
  const CriticalTimeStep limit = critical_time_steps(d.sample, c);
  check_mode_limits(limit, c);
  const auto check = [&](double time_step, const std::string& path) {
    for (const TimeStepFinding& f : time_step_findings(time_step, limit))
      if (f.bound->refuse) fail(path, f.message);
  };
  check(d.time_step, "time_step");
  if (d.prepare && d.prepare->time_step) check(*d.prepare->time_step, "prepare.time_step");
  for (std::size_t i = 0; i < d.tests.size(); ++i)
    if (d.tests[i].time_step) check(*d.tests[i].time_step, "tests[" + std::to_string(i) + "].time_step");
}

// A stress the spheres cannot carry or resolve: the mean contact's overlap under it (mean_contact_force, the deck's
// normal law) above half the mean diameter (spheres that pass through one another; contact laws hold for overlaps
// of a few per cent) or below 1e-12 of it (lost in the round-off of positions: eps times a cell a few hundred
// diameters wide is about 1e-13 of a diameter). Each stress target of the preparation and of the tests' legs.
void check_stress_scale(const Deck& d) {
  const double dmean = mean_diameter(d.sample);
  const auto check = [&](double stress, const std::string& path) {
    if (!(stress > 0.0)) return;
    const double overlap = normal_overlap(d.contact, mean_contact_force(d.sample, stress), 0.25 * dmean) / dmean;
    if (overlap >= 1e-12 && overlap <= 0.5) return;
    fail(path, fmt(stress) + " Pa gives the mean contact an overlap of " + fmt(overlap) + " of the mean diameter " +
                   (overlap > 0.5 ? "(above 0.5: the spheres would pass through one another)"
                                  : "(below 1e-12: lost in the round-off of the positions)") +
                   " with the deck's contact stiffness");
  };
  if (d.prepare) check(d.prepare->target_pressure, "prepare.target_pressure");
  for (std::size_t i = 0; i < d.tests.size(); ++i)
    for (std::size_t j = 0; j < d.tests[i].legs.size(); ++j) {
      const Leg& leg = d.tests[i].legs[j];
      const std::string at = "tests[" + std::to_string(i) + "] (test '" + d.tests[i].name + "', leg " + std::to_string(j) + "): ";
      for (std::size_t k = 0; k < 3; ++k)
        if (leg.axes[k].mode == AxisMode::Stress || leg.axes[k].mode == AxisMode::MeanStress ||
            leg.axes[k].mode == AxisMode::StressRamp)
          check(leg.axes[k].value, at + "axes." + std::string(kAxisNames[k]));
      if (leg.end.kind == LegEndKind::Stress) check(leg.end.value, at + "end.stress");
    }
}

}  // namespace

Deck parse_deck(const std::string& json_text, const std::string& source) {
  const Json j = parse_json(json_text);
  Deck d;
  d.source = source;
  d.canonical = j.dump(-1, ' ', false, Json::error_handler_t::replace);  // invalid UTF-8 must not throw
  ObjectReader r(j, "");
  d.format = static_cast<int>(r.integer(keys::format));
  if (d.format != kDeckFormatVersion)
    fail("format", "this celldem reads deck format " + std::to_string(kDeckFormatVersion) + ", the deck says " +
                       std::to_string(d.format));
  (void)r.string(keys::description);
  d.sample = read_sample(r.object(keys::sample));
  d.contact = read_contact(r.object(keys::contact));
  d.damping = read_damping(r.object(keys::damping));
  d.kinematics = r.choice_of<Kinematics>(keys::kinematics);
  d.time_step = r.number(keys::time_step);
  if (r.has(keys::tolerance)) d.tolerance = r.number(keys::tolerance);
  if (r.has(keys::servo)) d.servo = read_servo(r.object(keys::servo));
  d.control_failure = r.choice_of<ControlFailure>(keys::control_failure);
  d.neighbor_skin = r.number(keys::neighbor_skin);
  d.checkpoint_interval = r.integer(keys::checkpoint_interval);
  d.energy_budget = r.boolean(keys::energy_budget);

  const bool has_prepare = r.has(keys::prepare);
  const bool has_state = r.has(keys::initial_state);
  if (!has_prepare && !has_state)
    fail("prepare", "give \"prepare\" (make a sample), \"initial_state\" (reuse one) or both (prepare a sample "
                    "from that state)");
  if (has_prepare) d.prepare = read_prepare(r.object(keys::prepare));
  if (has_state) d.initial_state = r.string(keys::initial_state);
  if (d.prepare && d.prepare->relax_overlaps > 0.0 && !has_state)
    fail("prepare.relax_overlaps", "only meaningful with \"initial_state\" (it relaxes an imported sample's overlaps "
                                   "before the preparation; a generated sample has none)");
  if (r.has(keys::override_state_physics)) {
    if (!has_state) fail("override_state_physics", "only meaningful with \"initial_state\"");
    d.override_state_physics = r.boolean(keys::override_state_physics);
  }

  if (r.has(keys::tests)) {
    const Json& tests = r.raw(keys::tests);
    if (!tests.is_array()) fail("tests", "expected an array");
    std::set<std::string> names;
    // Where the preparation's servo leaves the stresses (a generated sample starts at none; a loaded one unknown).
    const double unknown = std::numeric_limits<double>::quiet_NaN();
    std::array<double, 3> start{unknown, unknown, unknown};
    if (d.prepare) {
      if (!has_state) start = {0.0, 0.0, 0.0};
      start = check_servo_reach(d.prepare->legs, start, leg_paths("prepare.legs", false));
    }
    for (std::size_t i = 0; i < tests.size(); ++i) {
      const std::string path = "tests[" + std::to_string(i) + "]";
      d.tests.push_back(read_test(ObjectReader(tests[i], path), d.contact, d.time_step,
                                  d.prepare ? d.prepare->equilibrium : EquilibriumDef{}, start));
      if (!names.insert(d.tests.back().name).second)
        fail(path + ".name", "duplicate test name \"" + d.tests.back().name + "\"");
    }
  }
  if (!has_prepare && d.tests.empty()) fail("tests", "a deck without \"prepare\" needs at least one test");
  // prepare.rolling_friction is refused as a key of sub-model choices the deck does not make, except at its
  // default 0 (frictionless preparation either way).
  if (d.prepare && d.prepare->rolling_friction > 0.0 && !key_used(keys::prepare_rolling_friction, d.contact.selection()))
    fail("prepare.rolling_friction", unused_message(keys::prepare_rolling_friction, d.contact.selection()));
  check_time_step(d);
  check_stress_scale(d);
  check_probe_magnitudes(d);
  r.finish();
  return d;
}

std::string read_deck_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DeckError(path + ": cannot open the deck");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

Deck read_deck_as_written(const std::string& path) { return parse_deck(read_deck_text(path), path); }

Deck read_deck(const std::string& path, std::optional<double> tolerance) {
  const std::string text = read_deck_text(path);
  Deck written = parse_deck(text, path);
  const std::string key = tolerance ? "--tolerance" : "tolerance";
  if (!tolerance) tolerance = written.tolerance;
  if (!tolerance) return written;
  return resolve_tolerance(written, text, *tolerance, key);
}

}  // namespace celldem
