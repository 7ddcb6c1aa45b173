#include "run/program.hpp"

#include <omp.h>

#include <cmath>

#include "cell/control.hpp"
#include "core/plan.hpp"
#include "measure/quasi_static.hpp"
#include "run/runner.hpp"
#include "run/stage_output.hpp"
#include "run/thread_governor.hpp"
#include "step.hpp"

namespace celldem {
using Json = nlohmann::json;

Json to_json(const ControlErrors& e) {
  return {{"stress", e.stress}, {"b", e.b}, {"mean_stress", e.mean_stress}, {"volume", e.volume}, {"steps", e.steps}};
}

ControlErrors control_errors_from_json(const Json& j) {
  return {j.value("stress", 0.0), j.value("b", 0.0), j.value("mean_stress", 0.0), j.value("volume", 0.0),
          j.value("steps", std::int64_t{0})};
}

namespace {

std::string leg_name(const State& state) { return "leg " + std::to_string(state.control.phase); }

// What a leg's end condition watches, and from which side it approaches the target. The side is taken from
// the state when the leg starts or resumes: until the leg ends the quantity stays on that side, so a resumed
// run finds the same side.
class LegEndWatch {
 public:
  LegEndWatch(const Leg& leg, const Model& model, const State& state) : leg_(leg) {
    const LegEnd& e = leg.end;
    if (e.kind == LegEndKind::Strain && leg.axes[e.axis].strain_driven()) {
      const double per_step = leg.strain_per_step(e.axis, model.dt);
      const double from = state.control.leg_start_strains[e.axis];
      if ((e.value - from) * per_step < 0.0)
        throw RunError(leg_name(state) + ": axis x" + std::to_string(e.axis + 1) + " moves away from its end strain " +
                       std::to_string(e.value) + " (it starts the leg at " + std::to_string(from) + ")");
      steps_ = leg_steps(leg, model.dt, from);
    } else if (e.kind == LegEndKind::Steps) {
      steps_ = leg_steps(leg, model.dt, 0.0);  // as planned: max_steps, when given, caps it
    }
    side_ = value(model, state) < e.value ? 1 : -1;
  }

  bool ended(const Model& model, const State& state) const {
    const LegEnd& e = leg_.end;
    const std::int64_t n = state.control.phase_steps;
    if (steps_ >= 0) return n >= steps_;
    if (e.kind == LegEndKind::Equilibrium) return false;  // checked after a step
    if (e.kind == LegEndKind::SolidFraction) return value(model, state) >= e.value;
    const bool reached = side_ * (value(model, state) - e.value) >= 0.0;
    if (!reached && e.max_steps > 0 && n >= e.max_steps)
      throw RunError(leg_name(state) + " did not reach its end condition in " + std::to_string(n) +
                     " steps (end.max_steps): loosen it or raise max_steps");
    return reached;
  }

 private:
  double value(const Model& model, const State& state) const {
    const LegEnd& e = leg_.end;
    switch (e.kind) {
      case LegEndKind::Strain: return axis_strains(state)[e.axis];
      case LegEndKind::Ratio: return state.normal_stress[0] / state.normal_stress[2];
      case LegEndKind::Stress: return state.normal_stress[e.axis];
      case LegEndKind::SolidFraction: return model.solid_volume / state.cell.volume();
      default: return 0.0;
    }
  }

  const Leg& leg_;
  std::int64_t steps_ = -1;  // known length
  int side_ = 1;
};

// The errors of the leg's controls at this step (after its first kSettleStrain of driving strain).
void track_errors(const Leg& leg, const State& state, ControlErrors& errors) {
  int driver = -1;
  for (int k = 2; k >= 0; --k)
    if (leg.axes[k].strain_driven()) driver = k;
  const Vec3 e = axis_strains(state);
  if (driver < 0 || std::abs(e[driver] - state.control.leg_start_strains[driver]) < kSettleStrain) return;
  const Vec3& s = state.normal_stress;
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = leg.axes[k];
    if (a.mode == AxisMode::Stress) errors.stress = std::max(errors.stress, std::abs(s[k] / a.value - 1.0));
    if (a.mode == AxisMode::MeanStress)
      errors.mean_stress = std::max(errors.mean_stress, std::abs(s.sum() / 3.0 / a.value - 1.0));
    if (a.mode == AxisMode::ConstantVolume)
      errors.volume = std::max(errors.volume, std::abs(state.cell.volume() / state.control.leg_start_volume - 1.0));
    if (a.mode == AxisMode::B) {
      int minor = -1;
      for (int m = 0; m < 3; ++m)
        if (leg.axes[m].mode == AxisMode::Stress || leg.axes[m].mode == AxisMode::MeanStress) minor = m;
      const double b = (s[k] - s[minor]) / (s[driver] - s[minor]);
      errors.b = std::max(errors.b, std::abs(b - a.value));
    }
  }
  ++errors.steps;
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
  for (;;) {
    const Leg& leg = program.legs[c.phase];
    const LegEndWatch watch(leg, model, state);
    const Loading loading{leg.axes, program.friction};
    bool leg_over = watch.ended(model, state);  // on the state as it stands
    bool leg_done = leg_over;                   // (or an equilibrium leg that is not the last reached it)
    // After each step, on one thread; false to leave the steps' parallel region (the leg is over, or the
    // governor changed the thread count: the loop goes on with the new count).
    const AfterStep after_step = [&](bool) {
      const bool threads_changed = governor.step_done();
      track_errors(leg, state, errors[c.phase]);
      if (leg.end.kind == LegEndKind::Equilibrium && c.phase_steps % program.equilibrium->check_interval == 0) {
        const EquilibriumDef& criterion = *program.equilibrium;
        const EquilibriumCheck eq =
            check_equilibrium(model, state, criterion, stress_targets(leg.axes, state.normal_stress));
        status = eq.describe();
        if (eq.reached && c.phase_steps >= criterion.min_steps) {  // before the step's row
          leg_done = true;
          return false;
        }
        if (c.phase_steps >= (leg.end.max_steps > 0 ? leg.end.max_steps : criterion.max_steps))
          throw RunError("the preparation did not reach equilibrium in " + std::to_string(c.phase_steps) +
                         " servo steps (" + status + "); raise prepare.equilibrium.max_steps or relax its tolerances");
      }
      const double fraction = program.planned_steps > 0
                                  ? static_cast<double>(c.stage_steps) / static_cast<double>(program.planned_steps)
                                  : -1.0;
      rebuild = out.after_step(state, fraction, status);
      leg_over = leg_done = watch.ended(model, state);  // for the next step
      return !leg_over && !threads_changed;
    };
    while (!leg_done)
      advance_steps(model, loading, state, rebuild, after_step, program.adaptive_threads ? governor.current() : threads);
    if (static_cast<std::size_t>(c.phase) + 1 == program.legs.size()) return;
    if (!leg_over) rebuild = out.after_step(state, -1.0, status);  // an equilibrium leg that is not the last
    begin_leg(state, c.phase + 1);
  }
}

}  // namespace celldem
