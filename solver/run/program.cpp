#include "run/program.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "cell/control.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "measure/micro.hpp"
#include "measure/quasi_static.hpp"
#include "run/adaptive_rate.hpp"
#include "run/health.hpp"
#include "run/errors.hpp"
#include "run/stage_output.hpp"
#include "run/thread_governor.hpp"
#include "step.hpp"

namespace celldem {

namespace {


std::string stage_name(const Program& program) {
  return program.kind == StageKind::Preparation ? "the preparation" : "test '" + program.stage + "'";
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
      const double per_step = leg.end_strain_per_step(model.dt);
      const double from = state.control.leg_start_strains[e.axis];
      if ((e.value - from) * per_step < 0.0)
        throw RunError(where_ + ": axis " + component_name(e.axis) +
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
      case LegEndKind::Strain: return component_strains(state)[e.axis];
      case LegEndKind::Ratio: return state.stress[0] / state.stress[2];
      case LegEndKind::Stress: return state.stress[e.axis];
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

// A stress ramp that falls to zero has no target a compressive packing can hold (and no relative error): the
// axis whose target for the next step is not positive, or -1.
int check_ramp(const Leg& leg, double dt, const State& state) {
  const double leg_time = static_cast<double>(state.control.leg_steps + 1) * dt;
  for (int k = 0; k < 3; ++k)
    if (leg.axes[k].mode == AxisMode::StressRamp && !(leg.axes[k].stress_target(leg_time) > 0.0)) return k;
  return -1;
}

// A strain leg that its end.max_steps stopped short of its end strain (by more than half a step's strain):
// the warning, else empty. Before the run, preflight warns of the legs whose start strain is known ahead;
// `known_ahead` says this leg is one of them, so that the warning is not given twice. The others (a leg after
// one that ends on a ratio, a stress or equilibrium, and the preparation's legs) are only known here.
std::string strain_leg_cut_short(const Program& program, const Model& model, const State& state, bool known_ahead) {
  const Leg& leg = program.legs[static_cast<std::size_t>(state.control.leg)];
  const LegEnd& e = leg.end;
  if (known_ahead || e.kind != LegEndKind::Strain || !leg.axes[static_cast<std::size_t>(e.axis)].strain_driven() || e.max_steps <= 0 ||
      state.control.leg_steps < e.max_steps)
    return "";
  const double reached = component_strains(state)[e.axis];
  if (std::abs(reached - e.value) <= 0.5 * std::abs(leg.strain_per_step(e.axis, model.dt))) return "";
  return stage_name(program) + " " + leg_name(state) + ": end.max_steps " + std::to_string(e.max_steps) +
         " stopped the leg at " + component_name(e.axis) + " strain " + fmt3(reached) + ", short of its end strain " +
         fmt3(e.value) + " (raise max_steps, or give the leg a step count as its end)";
}

}  // namespace

namespace {

// One leg of the program, run step by step; after each step its named checks, in this order:
//   check_ramp         a stress ramp whose target falls to zero stops the stage;
//   track_controls     every controlled component measured and judged (run/control_verdict.hpp);
//   check_equilibrium  an equilibrium leg's criterion (it ends the leg, or stops a leg that never gets there);
//   adapt_rate         an adaptive leg's next rate factor;
//   progress           the step's row, snapshot and progress line (StageOutput::record_step);
//   the leg's end      then the checkpoint, unless the leg ends at this step (StageOutput::checkpoint_step).
class LegRun {
 public:
  LegRun(const Model& model, const Program& program, State& state, StageOutput& out, ControlErrors& errors,
         ThreadGovernor& governor, double mean_diameter)
      : model_(model), program_(program), state_(state), out_(out), errors_(errors), governor_(governor),
        leg_(program.legs[static_cast<std::size_t>(state.control.leg)]),
        watch_(leg_, model, state, stage_name(program) + " " + leg_name(state)),
        checks_(leg_, model),
        deck_rate_(leg_driving_increment(leg_, model.dt) / model.dt),
        inertial_rate_(leg_inertial_rate(leg_, model.dt)),
        mean_diameter_(mean_diameter) {}

  // Runs the leg to its end; `rebuild` carries the neighbour list's state from leg to leg. Returns whether the
  // leg's end condition (not an equilibrium that is not the last leg's) ended it.
  bool run(bool& rebuild) {
    ControlState& c = state_.control;
    leg_over_ = leg_done_ = watch_.ended(model_, state_);  // on the state as it stands
    const int threads = omp_get_max_threads();
    while (!leg_done_) {
      const Loading loading{leg_.axes, program_.friction, servo_cap(model_.servo, leg_, model_.dt, c.rate_factor),
                            leg_.rotation};
      state_.driving_rate = deck_rate_ * c.rate_factor, state_.driving_factor = c.rate_factor;
      state_.inertial_rate = inertial_rate_ * c.rate_factor;
      advance_steps(model_, loading, state_, rebuild, [&](bool) { return after_step(rebuild); },
                    program_.adaptive_threads ? governor_.current() : threads);
    }
    if (c.leg_steps == 0)
      throw RunError(stage_name(program_) + " " + leg_name(state_) + " ended after 0 steps (its end condition "
                     "held when it started): give it an end it has to reach");
    if (const int k = judge_leg_end(state_, errors_); k >= 0) control_failed(k);
    return leg_over_;
  }

  const std::string& status() const { return status_; }

 private:
  // After each step, on one thread; false to leave the steps' parallel region (the leg is over, or the governor
  // changed the thread count, or the rate factor changed: the loop goes on with the new count or servo cap).
  bool after_step(bool& rebuild) {
    const bool threads_changed = governor_.step_done();
    check_ramp_now();
    if (const int k = track_controls(leg_, checks_, model_.dt, state_, errors_); k >= 0) control_failed(k);
    std::optional<ContactMeasures> contacts;  // measured once when a check and the step's row both read them
    if (check_equilibrium_now(contacts)) {
      leg_done_ = true;
      return false;
    }
    const bool rate_changed = leg_.adaptive && !leg_done_ && adapt_rate(contacts);
    progress(contacts);
    leg_over_ = leg_done_ = watch_.ended(model_, state_);  // for the next step
    rebuild = out_.checkpoint_step(state_, leg_over_);     // (none where the leg ends)
    return !leg_over_ && !threads_changed && !rate_changed;
  }

  void check_ramp_now() const {
    if (const int k = check_ramp(leg_, model_.dt, state_); k >= 0)
      throw RunError(stage_name(program_) + " " + leg_name(state_) + ": the stress_ramp target of axis x" +
                     std::to_string(k + 1) + " falls to 0 Pa after " + std::to_string(state_.control.leg_steps) +
                     " steps of the leg: end the leg before (end.stress or end.steps)");
  }

  void control_failed(int k) const {
    const std::string message = control_failure_message(
        stage_name(program_) + " " + leg_name(state_), errors_, k,
        servo_cap(model_.servo, leg_, model_.dt, state_.control.rate_factor), model_.servo, state_, checks_);
    if (program_.control_failure == ControlFailure::Stop)
      throw RunError(message + ". The last checkpoint is kept; with \"control_failure\": \"warn\" the run goes on "
                     "and marks the test uncontrolled");
    if (program_.print_control_warnings) std::fprintf(stderr, "warning: %s\n", message.c_str());
  }

  // An equilibrium leg's criterion, every check_interval steps: true when the leg has reached it.
  bool check_equilibrium_now(std::optional<ContactMeasures>& contacts) {
    const ControlState& c = state_.control;
    if (leg_.end.kind != LegEndKind::Equilibrium || c.leg_steps % program_.equilibrium->check_interval != 0) return false;
    const EquilibriumDef& criterion = *program_.equilibrium;
    const Vec3 targets = stress_targets(leg_.axes, state_.normal_stress(), static_cast<double>(c.leg_steps) * model_.dt);
    if (out_.row_due(state_)) contacts = measure_contacts(model_, state_);
    const EquilibriumCheck eq = contacts ? check_equilibrium(state_, *contacts, criterion, targets)
                                         : check_equilibrium(model_, state_, criterion, targets);
    status_ = eq.describe();
    if (eq.reached && c.leg_steps >= criterion.min_steps) return true;  // before the step's row
    if (c.leg_steps >= (leg_.end.max_steps > 0 ? leg_.end.max_steps : criterion.max_steps)) {
      // A packing held at its pressure whose unbalanced force stays at a test's not-quasi-static level is
      // boiling, not slow: more steps or looser tolerances would not help. (A packing still far from its
      // pressure is loose, and a loose packing's unbalanced force is naturally high.)
      const bool boiling = eq.pressure_error < kHeldAtPressure && eq.unbalanced > kMaxQuasiStaticUnbalanced;
      const std::string who = program_.kind == StageKind::Preparation ? "the preparation" : stage_name(program_) + " " + leg_name(state_);
      throw RunError(who + " did not reach equilibrium in " + std::to_string(c.leg_steps) + " servo steps (" + status_ +
                     "); " +
                     (boiling ? "an unbalanced force ratio above " + fmt3(kMaxQuasiStaticUnbalanced) +
                                    " at the target pressure means the packing boils: the time step is likely too close to the "
                                    "stability limit (`celldem plan` gives it per mode) or damping too low"
                              : "raise " + program_.equilibrium_key + ".max_steps or relax its tolerances"));
    }
    return false;
  }

  // An adaptive leg's next factor, every check_interval steps; the last step is cut to land on the end strain.
  // The contacts it measures are the step's (a row due now reads them too). True when the factor changed.
  bool adapt_rate(std::optional<ContactMeasures>& contacts) {
    ControlState& c = state_.control;
    const AdaptiveRate& rule = *leg_.adaptive;
    double factor = c.rate_factor;
    // Not over the leg's settle window (LegChecks): there the start's transient (the state's own unbalanced
    // force, the servo settling on its targets) is not the loading's; the factor starts at 1.
    if (c.leg_progress >= static_cast<double>(checks_.settle) && c.leg_steps % rule.check_interval == 0) {
      if (!contacts) contacts = measure_contacts(model_, state_);
      const double p = state_.mean_stress();
      // The inertial number at factor 1: the cell's own (its last step's velocity gradient, servo axes included)
      // over the present factor, the rate of every component following the driving one.
      RateIndicators now{contacts->unbalanced_force, contacts->kinetic_energy / contacts->elastic_energy,
                         kControlShareOfTolerance * present_over_tolerance(errors_),
                         p > 0.0 ? inertial_number(deviatoric_shear_rate(state_.cell.velocity_gradient), mean_diameter_,
                                                   model_.density, p) / c.rate_factor
                                 : 0.0};
      if (model_.servo.max_strain_increment_given)  // a fixed cap: the factor the servo's components can follow
        now.servo_ceiling = model_.servo.max_strain_increment / (kMinServoCapRatio * leg_driving_increment(leg_, model_.dt));
      factor = adapted_rate_factor(rule, factor, now);
    }
    factor = std::min(factor, watch_.remaining_progress(state_));
    const bool changed = factor != c.rate_factor;
    c.rate_factor = factor;
    return changed;
  }

  // The step's row and progress line.
  void progress(const std::optional<ContactMeasures>& contacts) {
    const ControlState& c = state_.control;
    // (an adaptive leg's steps are known only by running it: its share of the strain to go stands in)
    const double share = watch_.done_share(state_);
    const double fraction = program_.planned_steps > 0
                                ? static_cast<double>(c.stage_steps) / static_cast<double>(program_.planned_steps)
                            : std::isfinite(share) ? (c.leg + share) / static_cast<double>(program_.legs.size())
                                                   : -1.0;
    out_.record_step(state_, fraction, status_, contacts ? &*contacts : nullptr);
  }

  const Model& model_;
  const Program& program_;
  State& state_;
  StageOutput& out_;
  ControlErrors& errors_;
  ThreadGovernor& governor_;
  const Leg& leg_;
  const LegEndWatch watch_;
  const LegChecks checks_;
  const double deck_rate_;      // [1/s] at factor 1
  const double inertial_rate_;  // [1/s] the inertial number's scale at factor 1 (leg_inertial_rate)
  const double mean_diameter_;
  std::string status_;
  bool leg_over_ = false;  // the leg's end condition holds
  bool leg_done_ = false;  // ... or an equilibrium leg that is not the last reached its equilibrium
};

}  // namespace

void run_program(const Model& model, const Program& program, State& state, StageOutput& out,
                 std::vector<ControlErrors>& errors) {
  errors.resize(program.legs.size());
  ControlState& c = state.control;
  bool rebuild = true;
  ThreadGovernor governor(program.adaptive_threads ? omp_get_max_threads() : 1);
  // Where each leg starts when the plan knows it ahead (NaN where only running tells): preflight has warned of
  // those tests' legs cut short by max_steps.
  std::vector<double> planned_from;
  program_leg_steps(program.legs, model.dt, &planned_from);
  // The adaptive rate's inertial number: the sample's mean diameter and density (measure/quasi_static.hpp).
  const double mean_diameter = mean_particle_diameter(state.particles);
  for (;;) {
    LegRun leg(model, program, state, out, errors[static_cast<std::size_t>(c.leg)], governor, mean_diameter);
    const bool leg_over = leg.run(rebuild);
    const bool known_ahead = program.kind == StageKind::Test && std::isfinite(planned_from[static_cast<std::size_t>(c.leg)]);
    if (const std::string cut = strain_leg_cut_short(program, model, state, known_ahead); !cut.empty()) out.warn(cut);
    const bool observer_ends = out.leg_ends_stage(state);  // (every observer asked at every leg's end)
    if (static_cast<std::size_t>(c.leg) + 1 == program.legs.size() || observer_ends) return;
    if (!leg_over) {  // an equilibrium leg that is not the last: its last step's row (no checkpoint at a leg's end)
      out.record_step(state, -1.0, leg.status());
      rebuild = out.checkpoint_step(state, /*leg_ends=*/true);
    }
    out.end_leg(state);  // the leg's end is a row
    begin_leg(state, c.leg + 1);
  }
}

}  // namespace celldem
