#include "run/program.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "cell/control.hpp"
#include "core/plan.hpp"
#include "measure/micro.hpp"
#include "measure/quasi_static.hpp"
#include "run/health.hpp"
#include "run/runner.hpp"
#include "run/stage_output.hpp"
#include "run/thread_governor.hpp"
#include "step.hpp"

namespace celldem {
using Json = nlohmann::json;

namespace {
Json number_or_null(double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); }
double number_of(const Json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : std::numeric_limits<double>::quiet_NaN();
}
}  // namespace

std::string control_axis_name(int k) {
  return std::string(k < 3 ? kAxisNames[static_cast<std::size_t>(k)] : kShearAxisNames[static_cast<std::size_t>(k - 3)]);
}

AxisMode control_mode(const Leg& leg, int k) {
  if (k < 3) return leg.axes[static_cast<std::size_t>(k)].mode;
  const auto& shear = leg.shear[static_cast<std::size_t>(k - 3)];
  return shear ? shear->mode : AxisMode::StrainIncrement;
}

Json to_json(const ControlErrors& e) {
  const auto axis = [&](int k) {
    return Json{{"error", number_or_null(e.axis_error[k])}, {"saturated_steps", e.saturated_steps[k]},
                {"over_steps", e.over_steps[k]}, {"over_saturated", e.over_saturated[k]}, {"failed", e.failed[k]}};
  };
  Json axes = Json::array();
  for (int k = 0; k < 3; ++k) axes.push_back(axis(k));
  Json out = {{"stress", number_or_null(e.stress)}, {"b", number_or_null(e.b)},
              {"mean_stress", number_or_null(e.mean_stress)}, {"volume", number_or_null(e.volume)},
              {"steps", e.steps}, {"axes", axes}};
  bool shear = std::isfinite(e.shear_stress);
  for (int k = 3; k < kControlAxes; ++k) shear |= e.saturated_steps[k] > 0 || e.over_steps[k] > 0 || e.failed[k];
  if (shear) {  // only a leg with a shear stress axis: the other legs' records stay as they were
    Json shear_axes = Json::array();
    for (int k = 3; k < kControlAxes; ++k) shear_axes.push_back(axis(k));
    out["shear_stress"] = number_or_null(e.shear_stress);
    out["shear_axes"] = shear_axes;
  }
  return out;
}

ControlErrors control_errors_from_json(const Json& j) {
  ControlErrors e;
  e.stress = number_of(j, "stress");
  e.b = number_of(j, "b");
  e.mean_stress = number_of(j, "mean_stress");
  e.volume = number_of(j, "volume");
  e.shear_stress = number_of(j, "shear_stress");
  e.steps = j.value("steps", std::int64_t{0});
  for (const auto& [key, first] : {std::pair{"axes", 0}, std::pair{"shear_axes", 3}})
    if (j.contains(key))
      for (int k = 0; k < 3 && k < static_cast<int>(j[key].size()); ++k) {
        const Json& a = j[key][k];
        e.axis_error[first + k] = number_of(a, "error");
        e.saturated_steps[first + k] = a.value("saturated_steps", std::int64_t{0});
        e.over_steps[first + k] = a.value("over_steps", std::int64_t{0});
        e.over_saturated[first + k] = a.value("over_saturated", std::int64_t{0});
        e.failed[first + k] = a.value("failed", false);
      }
  return e;
}

double control_tolerance(AxisMode mode) {
  switch (mode) {
    case AxisMode::Stress:
    case AxisMode::StressRamp: return kServoTolerance;  // relative to the moving target
    case AxisMode::MeanStress: return kMeanStressTolerance;
    case AxisMode::B: return kBTolerance;
    case AxisMode::ConstantVolume: return kVolumeTolerance;
    default: return std::numeric_limits<double>::infinity();
  }
}

double adapted_rate_factor(const AdaptiveRate& rule, double factor, const RateIndicators& now) {
  const double u = std::max(now.unbalanced_force / rule.unbalanced_force_ratio, now.kinetic_to_elastic / rule.kinetic_to_elastic);
  if (!(u <= 1.0)) factor *= std::max(kRateLowerMost, 1.0 / u);
  else if (u < kRateCalm) factor *= kRateRaise;
  double ceiling = rule.max_factor;
  if (now.inertial_at_deck_rate > 0.0) ceiling = std::min(ceiling, rule.inertial_number / now.inertial_at_deck_rate);
  return std::clamp(factor, rule.min_factor, std::max(rule.min_factor, ceiling));
}

std::string control_kind(AxisMode mode) {
  switch (mode) {
    case AxisMode::Stress:
    case AxisMode::StressRamp: return "stress";  // one kind: summary.json's stress errors hold both
    case AxisMode::MeanStress: return "mean_stress";
    case AxisMode::B: return "b";
    case AxisMode::ConstantVolume: return "volume";
    default: return "strain";
  }
}

namespace {

std::string stage_name(const Program& program) {
  return program.stage == "prepare" ? "the preparation" : "test '" + program.stage + "'";
}
std::string leg_name(const State& state) { return "leg " + std::to_string(state.control.leg); }

// What a leg's end condition watches, and from which side it approaches the target. The side is taken from
// the state when the leg starts or resumes: until the leg ends the quantity stays on that side, so a resumed
// run finds the same side.
class LegEndWatch {
 public:
  // `where` names the stage and leg in messages ("test 'ttc' leg 1").
  LegEndWatch(const Leg& leg, const Model& model, const State& state, std::string where)
      : leg_(leg), where_(std::move(where)) {
    const LegEnd& e = leg.end;
    if (leg.ends_on_driven_strain()) {  // a normal axis's strain, or a shear axis's g_ij
      const bool shear = e.kind == LegEndKind::ShearStrain;
      const double per_step = leg.end_strain_per_step(model.dt);
      const double from = shear ? state.control.leg_start_shear[e.axis] : state.control.leg_start_strains[e.axis];
      if ((e.value - from) * per_step < 0.0)
        throw RunError(where_ + ": axis " + std::string(shear ? kShearAxisNames[e.axis] : kAxisNames[e.axis]) +
                       " moves away from its end strain " + std::to_string(e.value) + " (it starts the leg at " +
                       std::to_string(from) + ")");
      if (leg.adaptive) end_progress_ = (e.value - from) / per_step;  // the axis is at from + progress x per_step
      else steps_ = leg_steps(leg, model.dt, from);
    } else if (e.kind == LegEndKind::Steps) {
      steps_ = leg_steps(leg, model.dt, 0.0);  // as planned: max_steps, when given, caps it
    }
    side_ = value(model, state) < e.value ? 1 : -1;
  }

  bool ended(const Model& model, const State& state) const {
    const LegEnd& e = leg_.end;
    const std::int64_t n = state.control.leg_steps;
    if (steps_ >= 0) return n >= steps_;
    if (end_progress_ >= 0.0)  // (the last step's factor lands on it: remaining_progress)
      return state.control.leg_progress >= end_progress_ * (1.0 - 1e-12) || (e.max_steps > 0 && n >= e.max_steps);
    if (e.kind == LegEndKind::Equilibrium) return false;  // checked after a step
    if (e.kind == LegEndKind::SolidFraction) return value(model, state) >= e.value;
    const bool reached = side_ * (value(model, state) - e.value) >= 0.0;
    if (!reached && e.max_steps > 0 && n >= e.max_steps)
      throw RunError(where_ + " did not reach its end condition in " + std::to_string(n) +
                     " steps (end.max_steps): loosen it or raise max_steps");
    return reached;
  }

  double value(const Model& model, const State& state) const {
    const LegEnd& e = leg_.end;
    switch (e.kind) {
      case LegEndKind::Strain: return axis_strains(state)[e.axis];
      case LegEndKind::ShearStrain: return shear_strains(state)[e.axis];
      case LegEndKind::Ratio: return state.normal_stress[0] / state.normal_stress[2];
      case LegEndKind::Stress: return state.normal_stress[e.axis];
      case LegEndKind::SolidFraction: return model.solid_volume / state.cell.volume();
      default: return 0.0;
    }
  }

  // The share of the leg done, where only its progress tells (an adaptive leg that ends on its driven strain);
  // NaN for the other legs.
  double done_share(const State& state) const {
    return end_progress_ > 0.0 ? std::min(1.0, state.control.leg_progress / end_progress_)
                               : std::numeric_limits<double>::quiet_NaN();
  }
  // An adaptive leg that ends on the strain of an axis it drives: the progress (ControlState::leg_progress)
  // left to its end, which the last step's factor must not pass; infinite for the other legs.
  double remaining_progress(const State& state) const {
    return end_progress_ >= 0.0 ? end_progress_ - state.control.leg_progress : std::numeric_limits<double>::infinity();
  }

 private:
  const Leg& leg_;
  std::string where_;
  std::int64_t steps_ = -1;     // known length
  double end_progress_ = -1.0;  // an adaptive leg's end on its driven strain, in progress (steps at the deck's rate)
  int side_ = 1;
};

bool has_stress_ramp(const Leg& leg) {  // (a principal-axis rotation's targets move too: checked alike)
  return leg.rotation || std::any_of(leg.axes.begin(), leg.axes.end(), [](const AxisControl& a) { return a.mode == AxisMode::StressRamp; });
}

// What a leg's control checks need: its driving increment per step, how many steps of it make the settle
// window and the persistence run (kPersistStrain), and its servo cap. A leg that only a stress ramp drives
// (no strain-driven axis) is checked too: its settle window and persistence run are kRampSettleSteps and
// kMinPersistSteps.
struct LegChecks {
  double driving = 0.0;          // largest |strain per step| of a strain-driven axis (0: nothing drives the leg)
  bool checked = false;          // whether the leg's errors are measured at all
  std::int64_t settle = 0;       // steps before the errors count
  std::int64_t persist = 0;      // consecutive steps above tolerance that fail a control
  LegChecks(const Leg& leg, const Model& model)
      : driving(leg_driving_increment(leg, model.dt)) {
    if (driving == 0.0 && has_stress_ramp(leg)) {
      checked = true;
      settle = kRampSettleSteps;
      persist = kMinPersistSteps;
    } else if (driving > 0.0) {  // whole steps: a quotient rounded just above an integer does not add one
      checked = true;
      const auto steps_for = [&](double strain) {
        return static_cast<std::int64_t>(std::ceil(strain / driving * (1.0 - 1e-12)));
      };
      settle = steps_for(kSettleStrain);
      persist = std::max(kMinPersistSteps, steps_for(kPersistStrain));
    }
  }
};

double worst(double a, double b) { return std::isfinite(a) ? std::max(a, b) : b; }

// The errors of the leg's controls at this step (after the settle window), and the run of steps above the
// tolerance. Returns the axis whose control has just failed (stayed above its tolerance kPersistStrain), or -1.
int track_errors(const Leg& leg, const LegChecks& checks, double dt, const State& state, ControlErrors& errors) {
  for (int k = 0; k < 3; ++k) errors.saturated_steps[k] += state.servo_saturated[k];
  for (int a = 0; a < 3; ++a) errors.saturated_steps[3 + a] += state.shear_servo_saturated[a];
  if (!checks.checked || state.control.leg_steps < checks.settle) return -1;
  const double leg_time = static_cast<double>(state.control.leg_steps) * dt;  // the stresses are the step's end's
  int driver = -1;
  for (int k = 2; k >= 0; --k)
    if (leg.axes[k].strain_driven()) driver = k;
  const Vec3& s = state.normal_stress;
  // The moving targets of a principal-axis rotation's plane (s_ii, s_jj, s_ij), else none.
  std::array<double, 3> rotating = {0.0, 0.0, 0.0};
  int rot_i = -1, rot_j = -1, rot_shear = -1;
  if (leg.rotation) {
    rotating = leg.rotation->targets(leg_time, dt);
    rot_i = kShearAxisEntries[leg.rotation->plane][0], rot_j = kShearAxisEntries[leg.rotation->plane][1];
    rot_shear = leg.rotation->plane;
  }
  int failed = -1;
  for (int k = 0; k < kControlAxes; ++k) {
    double err = std::numeric_limits<double>::quiet_NaN();
    if (k >= 3) {
      const std::optional<AxisControl>& shear = leg.shear[static_cast<std::size_t>(k - 3)];
      if (shear && shear->mode == AxisMode::Stress) {  // relative to max(|target|, p): see ControlErrors
        const double goal = k - 3 == rot_shear ? rotating[2] : shear->value;
        const double scale = std::max(std::abs(goal), s.sum() / 3.0);
        errors.shear_stress = worst(errors.shear_stress, err = std::abs(state.shear_stress[k - 3] - goal) / scale);
      }
    }
    // (a shear axis's error is measured above: none of the normal axes' kinds below applies to it)
    const AxisControl a = k < 3 ? leg.axes[static_cast<std::size_t>(k)] : AxisControl{AxisMode::StrainIncrement, 0.0};
    if (a.mode == AxisMode::Stress || a.mode == AxisMode::StressRamp)
      errors.stress = worst(errors.stress, err = std::abs(s[k] / (k == rot_i   ? rotating[0]
                                                                  : k == rot_j ? rotating[1]
                                                                               : a.stress_target(leg_time)) - 1.0));
    if (a.mode == AxisMode::MeanStress)
      errors.mean_stress = worst(errors.mean_stress, err = std::abs(s.sum() / 3.0 / a.value - 1.0));
    if (a.mode == AxisMode::ConstantVolume)
      errors.volume = worst(errors.volume, err = std::abs(state.cell.volume() / state.control.leg_start_volume - 1.0));
    if (a.mode == AxisMode::B) {
      int minor = -1;
      for (int m = 0; m < 3; ++m)
        if (leg.axes[m].mode == AxisMode::Stress || leg.axes[m].mode == AxisMode::MeanStress) minor = m;
      const double b = (s[k] - s[minor]) / (s[driver] - s[minor]);
      if (std::isfinite(b)) errors.b = worst(errors.b, err = std::abs(b - a.value));
    }
    if (!std::isfinite(err)) continue;
    errors.axis_error[k] = worst(errors.axis_error[k], err);
    if (err > control_tolerance(control_mode(leg, k))) {
      ++errors.over_steps[k];
      errors.over_saturated[k] += k < 3 ? state.servo_saturated[k] : state.shear_servo_saturated[k - 3];
      if (errors.over_steps[k] == checks.persist && !errors.failed[k]) {
        errors.failed[k] = true;
        failed = k;
      }
    } else {
      errors.over_steps[k] = errors.over_saturated[k] = 0;
    }
  }
  ++errors.steps;
  return failed;
}

std::string fmt(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

// A stress ramp that falls to zero has no target a compressive packing can hold (and no relative error): the
// axis whose target for the next step is not positive, or -1.
int spent_ramp(const Leg& leg, double dt, const State& state) {
  const double leg_time = static_cast<double>(state.control.leg_steps + 1) * dt;
  for (int k = 0; k < 3; ++k)
    if (leg.axes[k].mode == AxisMode::StressRamp && !(leg.axes[k].stress_target(leg_time) > 0.0)) return k;
  return -1;
}

// What the failed control of axis k says: where, how far, and what to change (the servo sat at its cap for
// most of the steps out of tolerance: the cap or the rate; else the gains or the rate). `cap`: the cap the steps
// ran with (an adaptive leg's follows its rate).
std::string control_failure_message(const Program& program, int leg_index, double cap, const ControlErrors& e, int k,
                                    const ServoDef& servo) {
  const Leg& leg = program.legs[static_cast<std::size_t>(leg_index)];
  const AxisMode mode = control_mode(leg, k);
  const bool relative = mode != AxisMode::B;
  const double scale = relative ? 100.0 : 1.0;
  const std::string unit = relative ? " %" : "";
  std::string m = stage_name(program) + " leg " + std::to_string(leg_index) + ": the " +
                  (k < 3 ? control_kind(mode) : "shear stress") + " control of axis " + control_axis_name(k) + " stayed outside its tolerance for " +
                  std::to_string(e.over_steps[k]) + " steps in a row (" + fmt(100 * kPersistStrain) +
                  " % of driving strain): error " + fmt(scale * e.axis_error[k]) + unit + ", tolerance " +
                  fmt(scale * control_tolerance(mode)) + unit;
  if (mode == AxisMode::ConstantVolume) return m + " (the volume hold is exact: report this as a bug)";
  if (2 * e.over_saturated[k] > e.over_steps[k])
    return m + "; the servo's increment sat at its cap in " + std::to_string(e.over_saturated[k]) +
           " of these steps: raise servo.max_strain_increment (now " + fmt(cap) +
           (servo.max_strain_increment_given ? "" : ", the default for this leg") + ") or lower the strain rate";
  return m + "; the servo was not at its cap (" + fmt(cap) +
         "): raise servo.gain/integral_gain (now " + fmt(servo.gain) + "/" + fmt(servo.integral_gain) +
         ") or lower the rate";
}

// A strain leg that its end.max_steps stopped short of its end strain (by more than half a step's strain):
// the warning, else empty. Before the run, preflight warns of the legs whose start strain is known ahead;
// `known_ahead` says this leg is one of them, so that the warning is not given twice. The others (a leg after
// one that ends on a ratio, a stress or equilibrium, and the preparation's legs) are only known here.
std::string strain_leg_cut_short(const Program& program, const Model& model, const State& state, bool known_ahead) {
  const Leg& leg = program.legs[static_cast<std::size_t>(state.control.leg)];
  const LegEnd& e = leg.end;
  if (known_ahead || e.kind != LegEndKind::Strain || !leg.axes[e.axis].strain_driven() || e.max_steps <= 0 ||
      state.control.leg_steps < e.max_steps)
    return "";
  const double reached = axis_strains(state)[e.axis];
  if (std::abs(reached - e.value) <= 0.5 * std::abs(leg.strain_per_step(e.axis, model.dt))) return "";
  return stage_name(program) + " " + leg_name(state) + ": end.max_steps " + std::to_string(e.max_steps) +
         " stopped the leg at x" + std::to_string(e.axis + 1) + " strain " + fmt(reached) + ", short of its end strain " +
         fmt(e.value) + " (raise max_steps, or give the leg a step count as its end)";
}

}  // namespace

void run_program(const Model& model, const Program& program, State& state, StageOutput& out,
                 std::vector<ControlErrors>& errors) {
  errors.resize(program.legs.size());
  ControlState& c = state.control;
  bool rebuild = true;
  std::string status;
  const int threads = omp_get_max_threads();
  ThreadGovernor governor(program.adaptive_threads ? threads : 1);
  // Where each leg starts when the plan knows it ahead (NaN where only running tells): preflight has warned of
  // those tests' legs cut short by max_steps.
  std::vector<double> planned_from;
  program_leg_steps(program.legs, model.dt, &planned_from);
  // The adaptive rate's inertial number: the sample's mean diameter and density (measure/quasi_static.hpp).
  const double mean_diameter = mean_particle_diameter(state.particles);
  for (;;) {
    const Leg& leg = program.legs[c.leg];
    const LegEndWatch watch(leg, model, state, stage_name(program) + " " + leg_name(state));
    const LegChecks checks(leg, model);
    const double deck_rate = leg_driving_increment(leg, model.dt) / model.dt;  // [1/s] at factor 1
    const bool ramps = has_stress_ramp(leg);
    // An adaptive leg's next factor, every check_interval steps; the last step is cut to land on the end strain.
    // The contacts it measures are the step's (a row due now reads them too).
    const auto adapt = [&](std::optional<ContactMeasures>& contacts) {
      const AdaptiveRate& rule = *leg.adaptive;
      double factor = c.rate_factor;
      // Not over the leg's settle window (LegChecks): there the start's transient (the state's own unbalanced
      // force, the servo settling on its targets) is not the loading's; the factor starts at 1.
      if (c.leg_steps >= checks.settle && c.leg_steps % rule.check_interval == 0) {
        if (!contacts) contacts = measure_contacts(model, state);
        const double p = state.normal_stress.sum() / 3.0;
        factor = adapted_rate_factor(rule, factor, {contacts->unbalanced_force, contacts->kinetic_energy / contacts->elastic_energy,
                                                    p > 0.0 ? inertial_number(deck_rate, mean_diameter, model.density, p) : 0.0});
      }
      factor = std::min(factor, watch.remaining_progress(state));
      const bool changed = factor != c.rate_factor;
      c.rate_factor = factor;
      return changed;
    };
    bool leg_over = watch.ended(model, state);  // on the state as it stands
    bool leg_done = leg_over;                   // (or an equilibrium leg that is not the last reached it)
    // After each step, on one thread; false to leave the steps' parallel region (the leg is over, or the
    // governor changed the thread count: the loop goes on with the new count).
    const AfterStep after_step = [&](bool) {
      const bool threads_changed = governor.step_done();
      if (const int k = ramps ? spent_ramp(leg, model.dt, state) : -1; k >= 0)
        throw RunError(stage_name(program) + " " + leg_name(state) + ": the stress_ramp target of axis x" +
                       std::to_string(k + 1) + " falls to 0 Pa after " + std::to_string(c.leg_steps) +
                       " steps of the leg: end the leg before (end.stress or end.steps)");
      ControlErrors& e = errors[c.leg];
      if (const int k = track_errors(leg, checks, model.dt, state, e); k >= 0) {
        const std::string message = control_failure_message(
            program, c.leg, servo_cap(model.servo, leg, model.dt, state.driving_factor), e, k, model.servo);
        if (program.control_failure == ControlFailure::Stop)
          throw RunError(message + ". The last checkpoint is kept; with \"control_failure\": \"warn\" the run goes on "
                         "and marks the test uncontrolled");
        if (program.print_control_warnings) std::fprintf(stderr, "warning: %s\n", message.c_str());
      }
      std::optional<ContactMeasures> contacts;  // measured once when the check and the step's row both read them
      if (leg.end.kind == LegEndKind::Equilibrium && c.leg_steps % program.equilibrium->check_interval == 0) {
        const EquilibriumDef& criterion = *program.equilibrium;
        const Vec3 targets =
            stress_targets(leg.axes, state.normal_stress, static_cast<double>(c.leg_steps) * model.dt);
        if (out.row_due(state)) contacts = measure_contacts(model, state);
        const EquilibriumCheck eq = contacts ? check_equilibrium(state, *contacts, criterion, targets)
                                             : check_equilibrium(model, state, criterion, targets);
        status = eq.describe();
        if (eq.reached && c.leg_steps >= criterion.min_steps) {  // before the step's row
          leg_done = true;
          return false;
        }
        if (c.leg_steps >= (leg.end.max_steps > 0 ? leg.end.max_steps : criterion.max_steps)) {
          // A packing held at its pressure whose unbalanced force stays at a test's not-quasi-static level is
          // boiling, not slow: more steps or looser tolerances would not help. (A packing still far from its
          // pressure is loose, and a loose packing's unbalanced force is naturally high.)
          const bool boiling = eq.pressure_error < kHeldAtPressure && eq.unbalanced > kMaxQuasiStaticUnbalanced;
          const std::string who = program.stage == "prepare" ? "the preparation" : stage_name(program) + " " + leg_name(state);
          throw RunError(who + " did not reach equilibrium in " + std::to_string(c.leg_steps) +
                         " servo steps (" + status + "); " +
                         (boiling ? "an unbalanced force ratio above " + fmt(kMaxQuasiStaticUnbalanced) +
                                        " at the target pressure means the packing boils: the time step is likely too close to the "
                                        "stability limit (`celldem plan` gives it per mode) or damping too low"
                                  : "raise " + program.equilibrium_key + ".max_steps or relax its tolerances"));
        }
      }
      const bool rate_changed = leg.adaptive && !leg_done && adapt(contacts);
      // (an adaptive leg's steps are known only by running it: its share of the strain to go stands in)
      const double share = watch.done_share(state);
      const double fraction = program.planned_steps > 0
                                  ? static_cast<double>(c.stage_steps) / static_cast<double>(program.planned_steps)
                              : std::isfinite(share) ? (c.leg + share) / static_cast<double>(program.legs.size())
                                                     : -1.0;
      rebuild = out.after_step(state, fraction, status, contacts ? &*contacts : nullptr);
      leg_over = leg_done = watch.ended(model, state);  // for the next step
      return !leg_over && !threads_changed && !rate_changed;  // (a new rate: a new servo cap, below)
    };
    while (!leg_done) {
      const Loading loading{leg.axes, program.friction, servo_cap(model.servo, leg, model.dt, c.rate_factor), leg.shear,
                            leg.rotation};
      state.driving_rate = deck_rate * c.rate_factor, state.driving_factor = c.rate_factor;
      advance_steps(model, loading, state, rebuild, after_step, program.adaptive_threads ? governor.current() : threads);
    }
    if (c.leg_steps == 0)
      throw RunError(stage_name(program) + " " + leg_name(state) + " ended after 0 steps (its end condition "
                     "held when it started): give it an end it has to reach");
    const bool known_ahead = program.stage != "prepare" && std::isfinite(planned_from[static_cast<std::size_t>(c.leg)]);
    if (const std::string cut = strain_leg_cut_short(program, model, state, known_ahead); !cut.empty()) out.warn(cut);
    if (static_cast<std::size_t>(c.leg) + 1 == program.legs.size()) return;
    if (!leg_over) rebuild = out.after_step(state, -1.0, status);  // an equilibrium leg that is not the last
    out.end_leg(state);  // the leg's end is a row
    begin_leg(state, c.leg + 1);
  }
}

}  // namespace celldem
