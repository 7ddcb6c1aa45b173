#include "run/control_verdict.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "cell/control.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "run/health.hpp"

namespace celldem {
using Json = nlohmann::json;

namespace {
double number_of(const Json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : std::numeric_limits<double>::quiet_NaN();
}
double worst_of(double a, double b) { return std::isfinite(a) ? (std::isfinite(b) ? std::max(a, b) : a) : b; }
bool controlled(AxisMode mode) {
  return mode == AxisMode::Stress || mode == AxisMode::StressRamp || mode == AxisMode::MeanStress ||
         mode == AxisMode::B || mode == AxisMode::ConstantVolume;
}
}  // namespace

double control_tolerance(AxisMode mode, int /*component*/) {
  switch (mode) {
    case AxisMode::Stress:
    case AxisMode::StressRamp: return kServoTolerance;  // relative to the moving target (a shear's: to max(|t|, p))
    case AxisMode::MeanStress: return kMeanStressTolerance;
    case AxisMode::B: return kBTolerance;
    case AxisMode::ConstantVolume: return kVolumeTolerance;
    default: return std::numeric_limits<double>::infinity();
  }
}

std::string control_kind(AxisMode mode, int component) {
  switch (mode) {
    case AxisMode::Stress:
    case AxisMode::StressRamp: return is_shear_component(component) ? "shear_stress" : "stress";
    case AxisMode::MeanStress: return "mean_stress";
    case AxisMode::B: return "b";
    case AxisMode::ConstantVolume: return "volume";
    case AxisMode::Held: return "held";
    default: return "strain";
  }
}

double ControlErrors::worst(const std::string& kind, bool judged) const {
  double w = kNone;
  for (int k = 0; k < kComponents; ++k)
    if (control_kind(mode[k], k) == kind) w = worst_of(w, judged ? sustained[k] : error[k]);
  return w;
}

LegChecks::LegChecks(const Leg& leg, const Model& model) : driving(leg_driving_increment(leg, model.dt)) {
  const bool any = std::any_of(leg.axes.begin(), leg.axes.end(), [](const AxisControl& a) { return controlled(a.mode); });
  if (!any || leg.end.kind == LegEndKind::Equilibrium) return;  // (equilibrium: its criterion is the verdict)
  checked = true;
  if (driving > 0.0) {  // whole steps: a quotient rounded just above an integer does not add one
    const auto steps_for = [&](double strain) { return static_cast<std::int64_t>(std::ceil(strain / driving * (1.0 - 1e-12))); };
    settle = steps_for(kSettleStrain);
    span = std::max(kMinPersistSteps, steps_for(kPersistStrain));
  } else {
    settle = kRampSettleSteps;
    span = kMinPersistSteps;
  }
}

namespace {
// The measured value of component k in its error's quantity (Pa, b, V/V0) and the target in the same.
struct Reading {
  double reached = std::numeric_limits<double>::quiet_NaN();
  double target = std::numeric_limits<double>::quiet_NaN();
};
Reading reading(const Leg& leg, int k, const State& state, const Vec6& targets) {
  const AxisControl& a = leg.axes[static_cast<std::size_t>(k)];
  const Vec6& s = state.stress;
  switch (a.mode) {
    case AxisMode::Stress:
    case AxisMode::StressRamp: return {s[k], targets[k]};
    case AxisMode::MeanStress: return {state.mean_stress(), a.value};
    case AxisMode::B: {
      int driver = -1, minor = -1;
      for (int m = 2; m >= 0; --m)
        if (leg.axes[m].strain_driven()) driver = m;
      for (int m = 0; m < 3; ++m)
        if (leg.axes[m].mode == AxisMode::Stress || leg.axes[m].mode == AxisMode::MeanStress) minor = m;
      return {(s[k] - s[minor]) / (s[driver] - s[minor]), a.value};
    }
    case AxisMode::ConstantVolume: return {state.cell.volume() / state.control.leg_start_volume, 1.0};
    default: return {};
  }
}
}  // namespace

namespace {
// A component's error at this step in its kind's measure, from its reading against its target (control_targets
// at the step's end): stress and shear_stress relative (a shear target to max(|target|, p): a shear target, 0 most
// of all, has no scale of its own, and the mean stress is the one the packing carries), b absolute, mean stress
// relative, volume relative to the leg's start; NaN where the component is not controlled.
double error_of(AxisMode mode, int k, const Reading& r, double p) {
  switch (mode) {
    case AxisMode::Stress:
    case AxisMode::StressRamp:
      if (is_shear_component(k)) return std::abs(r.reached - r.target) / std::max(std::abs(r.target), p);
      return std::abs(r.reached / r.target - 1.0);
    case AxisMode::MeanStress:
    case AxisMode::ConstantVolume: return std::abs(r.reached / r.target - 1.0);
    case AxisMode::B: return std::isfinite(r.reached) ? std::abs(r.reached - r.target) : std::numeric_limits<double>::quiet_NaN();
    default: return std::numeric_limits<double>::quiet_NaN();
  }
}

// Judges component k on its sustained error (the bias-corrected average); true when its control fails now, its
// target and reading at the failure those of its last checked step.
bool judge(int k, ControlErrors& errors) {
  const double sustained = errors.average[k] / (1.0 - errors.decay);
  errors.sustained[k] = worst_of(errors.sustained[k], sustained);
  if (!(sustained > control_tolerance(errors.mode[k], k)) || errors.failed[k]) return false;
  errors.failed[k] = true;
  errors.target_at_failure[k] = errors.last_target[k], errors.reached_at_failure[k] = errors.last_reached[k];
  return true;
}
}  // namespace

int track_controls(const Leg& leg, const LegChecks& checks, double dt, const State& state, ControlErrors& errors) {
  const ControlState& c = state.control;
  for (int k = 0; k < kComponents; ++k) {
    errors.mode[k] = leg.axes[static_cast<std::size_t>(k)].mode;
    errors.saturated_steps[k] += state.servo_saturated[k];
  }
  // The settle window in the leg's progress (its driving strain over the deck's increment: steps at factor 1).
  if (!checks.checked || c.leg_progress < static_cast<double>(checks.settle)) return -1;
  const double leg_time = static_cast<double>(c.leg_steps) * dt;  // the stresses are the step's end's
  const Vec6 targets = control_targets(leg.axes, leg.rotation, state.stress, leg_time, dt);
  // This step's weight in the span: its progress (an adaptive leg's factor), one step where nothing drives.
  const double weight = checks.driving > 0.0 ? c.rate_factor : 1.0;
  const double alpha = std::min(1.0, weight / static_cast<double>(checks.span));
  errors.decay *= 1.0 - alpha;
  errors.weight += weight;
  const bool judged = errors.weight >= static_cast<double>(checks.span);
  const double p = state.mean_stress();
  int failed = -1;
  for (int k = 0; k < kComponents; ++k) {
    if (!controlled(errors.mode[k])) continue;
    const Reading r = reading(leg, k, state, targets);
    const double e = error_of(errors.mode[k], k, r, p);
    if (!std::isfinite(e)) continue;  // a b that is not defined at this step (s_major = s_minor)
    errors.error[k] = worst_of(errors.error[k], e);
    errors.average[k] += alpha * (e - errors.average[k]);
    errors.last_target[k] = r.target, errors.last_reached[k] = r.reached;
    if (e > control_tolerance(errors.mode[k], k)) {
      ++errors.over_steps[k];
      errors.over_saturated[k] += state.servo_saturated[k];
    }
    if (judged && judge(k, errors) && failed < 0) failed = k;
  }
  ++errors.steps;
  return failed;
}

int judge_leg_end(const State& /*state*/, ControlErrors& errors) {
  if (!(errors.weight > 0.0)) return -1;
  int failed = -1;
  for (int k = 0; k < kComponents; ++k)
    if (controlled(errors.mode[k]) && judge(k, errors) && failed < 0) failed = k;
  return failed;
}

double present_over_tolerance(const ControlErrors& errors) {
  if (!(errors.weight > 0.0)) return 0.0;
  double worst = 0.0;
  for (int k = 0; k < kComponents; ++k)
    if (controlled(errors.mode[k]))
      worst = std::max(worst, errors.average[k] / (1.0 - errors.decay) / control_tolerance(errors.mode[k], k));
  return worst;
}

Json to_json(const ControlErrors& e) {
  Json axes = Json::array();
  for (int k = 0; k < kComponents; ++k)
    axes.push_back({{"name", component_name(k)}, {"kind", control_kind(e.mode[k], k)},
                    {"error", number_or_null(e.error[k])}, {"sustained", number_or_null(e.sustained[k])},
                    {"average", e.average[k]}, {"saturated_steps", e.saturated_steps[k]},
                    {"over_steps", e.over_steps[k]}, {"over_saturated", e.over_saturated[k]}, {"failed", e.failed[k]},
                    {"target_at_failure", number_or_null(e.target_at_failure[k])},
                    {"reached_at_failure", number_or_null(e.reached_at_failure[k])},
                    {"last_target", number_or_null(e.last_target[k])}, {"last_reached", number_or_null(e.last_reached[k])}});
  return {{"stress", number_or_null(e.worst("stress"))},
          {"shear_stress", number_or_null(e.worst("shear_stress"))},
          {"b", number_or_null(e.worst("b"))},
          {"mean_stress", number_or_null(e.worst("mean_stress"))},
          {"volume", number_or_null(e.worst("volume"))},
          {"steps", e.steps},
          {"span_weight", e.weight},
          {"span_decay", e.decay},
          {"axes", axes}};
}

ControlErrors control_errors_from_json(const Json& j) {
  ControlErrors e;
  e.steps = j.value("steps", std::int64_t{0});
  e.weight = j.value("span_weight", 0.0);
  e.decay = j.value("span_decay", 1.0);
  if (!j.contains("axes")) return e;
  const Json& axes = j["axes"];
  for (int k = 0; k < kComponents && k < static_cast<int>(axes.size()); ++k) {
    const Json& a = axes[static_cast<std::size_t>(k)];
    const std::string kind = a.value("kind", std::string("held"));
    for (int m = 0; m <= static_cast<int>(AxisMode::Held); ++m)
      if (control_kind(static_cast<AxisMode>(m), k) == kind) {
        e.mode[k] = static_cast<AxisMode>(m);
        break;
      }
    e.error[k] = number_of(a, "error");
    e.sustained[k] = number_of(a, "sustained");
    e.average[k] = a.value("average", 0.0);
    e.saturated_steps[k] = a.value("saturated_steps", std::int64_t{0});
    e.over_steps[k] = a.value("over_steps", std::int64_t{0});
    e.over_saturated[k] = a.value("over_saturated", std::int64_t{0});
    e.failed[k] = a.value("failed", false);
    e.target_at_failure[k] = number_of(a, "target_at_failure");
    e.reached_at_failure[k] = number_of(a, "reached_at_failure");
    e.last_target[k] = number_of(a, "last_target");
    e.last_reached[k] = number_of(a, "last_reached");
  }
  return e;
}

ControlErrorMaxima control_error_maxima(const std::vector<ControlErrors>& errors) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  ControlErrorMaxima m{nan, nan, nan, nan};
  for (const ControlErrors& e : errors) {
    for (const char* kind : {"stress", "shear_stress", "mean_stress"}) m.servo = worst_of(m.servo, e.worst(kind));
    m.b = worst_of(m.b, e.worst("b"));
    m.volume = worst_of(m.volume, e.worst("volume"));
    for (int k = 0; k < kComponents; ++k)
      if (controlled(e.mode[k])) m.over_tolerance = worst_of(m.over_tolerance, e.sustained[k] / control_tolerance(e.mode[k], k));
  }
  return m;
}

std::vector<ControlFailureRecord> control_failures(const std::vector<ControlErrors>& errors) {
  std::vector<ControlFailureRecord> out;
  for (std::size_t leg = 0; leg < errors.size(); ++leg)
    for (int k = 0; k < kComponents; ++k) {
      const ControlErrors& e = errors[leg];
      if (e.failed[k])
        out.push_back({leg, k, control_kind(e.mode[k], k), e.sustained[k], control_tolerance(e.mode[k], k),
                       e.target_at_failure[k], e.reached_at_failure[k]});
    }
  return out;
}

namespace {
// "target 1e+05 Pa, reached 5.2e+04 Pa" in the kind's quantity.
std::string target_text(const std::string& kind, double target, double reached) {
  if (kind == "b") return "target b = " + fmt3(target) + ", reached b = " + fmt3(reached);
  if (kind == "volume") return "V/V(leg start) = " + fmt3(reached) + " against 1";
  const std::string what = kind == "mean_stress" ? "p = " : "";
  return "target " + what + fmt3(target) + " Pa, reached " + what + fmt3(reached) + " Pa";
}
}  // namespace

std::string control_failure_message(const std::string& where, const ControlErrors& e, int k, double cap,
                                    const ServoDef& servo, const State& state, const LegChecks& checks) {
  const std::string span = checks.driving > 0.0 ? "a span of " + fmt3(100 * kPersistStrain) + " % of driving strain"
                                                : "a span of " + std::to_string(checks.span) + " steps";
  const AxisMode mode = e.mode[k];
  const std::string kind = control_kind(mode, k);
  const bool relative = mode != AxisMode::B;
  const double scale = relative ? 100.0 : 1.0;
  const std::string unit = relative ? " %" : "";
  std::string m = where + ": the " + kind + " control of axis " + component_name(k) + " failed: " +
                  target_text(kind, e.target_at_failure[k], e.reached_at_failure[k]) + "; its error averaged " +
                  fmt3(scale * e.sustained[k]) + unit + " over " + span + " (tolerance " +
                  fmt3(scale * control_tolerance(mode, k)) + unit + ", worst step " + fmt3(scale * e.error[k]) + unit + ")";
  if (mode == AxisMode::ConstantVolume) return m + " (the volume hold is exact: report this as a bug)";
  const bool saturated = 2 * e.over_saturated[k] > e.over_steps[k];
  if (saturated && is_shear_component(k)) {
    // The packing's shear strength: the tilt moved at the cap while the shear stress stopped short of its target.
    const int j = kComponentEntries[static_cast<std::size_t>(k)][1];
    const double normal = state.stress[j];
    const double target = e.target_at_failure[k], reached = e.reached_at_failure[k];
    if (normal > 0.0 && std::abs(reached) < std::abs(target))
      return m + "; the cell sheared at the servo's cap in " + std::to_string(e.over_saturated[k]) + " of the " +
             std::to_string(e.over_steps[k]) + " steps out of tolerance while s" + component_name(k).substr(1) +
             " stayed at " + fmt3(std::abs(reached) / normal) + " of the normal stress s" + std::to_string(j + 1) +
             std::to_string(j + 1) + ": the packing flows there (its Coulomb limit), so the target (" +
             fmt3(std::abs(target) / normal) + " of it) is beyond the shear stress it can carry; hold a shear stress "
             "below its strength, or drive the axis by its strain";
  }
  if (saturated)
    return m + "; the servo's increment sat at its cap in " + std::to_string(e.over_saturated[k]) + " of the " +
           std::to_string(e.over_steps[k]) + " steps out of tolerance: the target is beyond what the servo reaches at "
           "its cap; raise servo.max_strain_increment (now " + fmt3(cap) +
           (servo.max_strain_increment_given ? "" : ", the default for this leg") + ") or lower the loading rate";
  return m + "; the servo was not at its cap (" + fmt3(cap) +
         "): its target moved, or the packing was loaded, faster than it follows; lower the rate (a rotation's "
         "or a ramp's rate, or the strain rate), or raise servo.gain/integral_gain (now " + fmt3(servo.gain) + "/" +
         fmt3(servo.integral_gain) + ")";
}

std::vector<std::string> control_warnings(const std::string& test_name, const std::vector<ControlErrors>& errors) {
  std::vector<std::string> out;
  for (const ControlFailureRecord& f : control_failures(errors)) {
    const double scale = f.kind == "b" ? 1.0 : 100.0;
    const char* unit = f.kind == "b" ? "" : " %";
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "test '%s' leg %zu: the %s control of axis %s failed (%s; sustained error %.3g%s, tolerance %.3g%s); "
                  "the test is marked uncontrolled (control_failure \"warn\")",
                  test_name.c_str(), f.leg, f.kind.c_str(), component_name(f.component).c_str(),
                  target_text(f.kind, f.target, f.reached).c_str(), scale * f.error, unit, scale * f.tolerance, unit);
    out.push_back(buf);
  }
  return out;
}

}  // namespace celldem
