// The one verdict on a leg's controls: every controlled component of the six (core/choices.hpp kComponentNames)
// on every leg, whatever drives it (stress, stress_ramp, mean_stress, b, constant_volume, a shear stress, a
// principal-axis rotation's moving targets), with or without a strain-driven axis or an adaptive rate, is
// measured at every step against the same targets the servo aims at (cell/control.hpp control_targets), and
// judged by one rule:
//
//   after the leg's settle window, the component's error is averaged over a span of kPersistStrain of driving
//   strain (at least kMinPersistSteps steps; a leg that no strain drives: kMinPersistSteps) as an exponential
//   moving average with the span as its time constant (bias-corrected, so that a short leg averages what it
//   ran); the control fails when that average, its sustained error, exceeds the tolerance (run/health.hpp) -
//   once a whole span has been checked, and at the leg's end whatever was checked.
//
// Why an average over a span and not the worst step: the servo removes an error with a time constant of about
// 1/gain steps (20 at the default gain) and the integral term's of about 1/integral_gain (500), so the stress
// spike of a slip event is corrected within a few hundred steps and weighs little in a span of 5000 (0.1 % of
// strain at the paper's 2e-7 per step); a saturated servo falls further behind at every step, a target that
// moves faster than the servo follows oscillates about it, and a packing loaded faster than it responds drifts
// off: all three keep the average above the tolerance. The worst single step is reported too (`error`), as a
// peak, not a verdict. summary.json's control_error_over_tolerance is the largest sustained error over its
// tolerance, so a test is controlled exactly when it is at most 1.
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// The start-up transient of a leg driven by a strain: its first kSettleStrain of driving strain are not judged.
inline constexpr double kSettleStrain = 0.002;
// The span of the sustained error: kPersistStrain of driving strain and at least kMinPersistSteps steps. 0.1 %
// of strain is 5000 steps at the paper's 2e-7 per step and 1000 at 1e-6: well past a slip's recovery, and
// caught long before a test's peak (1-3 % of strain). The floor keeps fast legs from counting a spike.
inline constexpr double kPersistStrain = 0.001;
inline constexpr std::int64_t kMinPersistSteps = 500;
// A leg that no strain drives (stress ramps, a rotation, stresses held for a number of steps) has no driving
// strain to measure its settle window in: its errors count after this many steps, twice the integral term's
// time constant at the default integral_gain (the ramp's lag under the proportional term alone is removed by
// then).
inline constexpr std::int64_t kRampSettleSteps = 1000;

// How well a leg's controls held their targets, per component (x1 x2 x3 x12 x13 x23). NaN (null in JSON) where
// nothing was measured: a component the leg does not control, a leg shorter than its settle window, a leg that
// ends in equilibrium (the equilibrium criterion is its verdict).
struct ControlErrors {
  static constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  std::array<AxisMode, kComponents> mode = {AxisMode::Held, AxisMode::Held, AxisMode::Held,
                                            AxisMode::Held, AxisMode::Held, AxisMode::Held};  // what was judged
  std::int64_t steps = 0;                                       // steps checked
  std::array<double, kComponents> error = {kNone, kNone, kNone, kNone, kNone, kNone};      // worst single step
  std::array<double, kComponents> sustained = {kNone, kNone, kNone, kNone, kNone, kNone};  // worst judged average
  // The moving averages now, the span's weight checked so far (progress, or steps where nothing drives) and the
  // product of (1 - alpha) over it, which corrects the averages' bias (kept across a resume).
  std::array<double, kComponents> average = {0, 0, 0, 0, 0, 0};
  double weight = 0.0;
  double decay = 1.0;
  std::array<std::int64_t, kComponents> saturated_steps = {};  // steps of the leg whose servo increment sat at its cap
  std::array<std::int64_t, kComponents> over_steps = {};       // checked steps above the tolerance
  std::array<std::int64_t, kComponents> over_saturated = {};   // ... of which at the cap
  std::array<bool, kComponents> failed = {};
  // The component's target and what it reached at the last checked step, and at the failure (in the error's
  // quantity: Pa, b, or V/V0).
  std::array<double, kComponents> last_target = {kNone, kNone, kNone, kNone, kNone, kNone};
  std::array<double, kComponents> last_reached = {kNone, kNone, kNone, kNone, kNone, kNone};
  std::array<double, kComponents> target_at_failure = {kNone, kNone, kNone, kNone, kNone, kNone};
  std::array<double, kComponents> reached_at_failure = {kNone, kNone, kNone, kNone, kNone, kNone};
  // The worst single-step and sustained errors of one kind (control_kind) over the components; NaN if none.
  double worst(const std::string& kind, bool judged = false) const;
};
nlohmann::json to_json(const ControlErrors& e);
ControlErrors control_errors_from_json(const nlohmann::json& j);

// The tolerance of a control of this kind (run/health.hpp), and its name in messages and summary.json:
// stress (normal stresses and stress ramps, a rotation's normal targets), shear_stress, mean_stress, b, volume.
double control_tolerance(AxisMode mode, int component);
std::string control_kind(AxisMode mode, int component);

// What a leg's control checks need: its driving increment per step, the settle window and the span in steps.
struct LegChecks {
  double driving = 0.0;          // largest |strain per step| of a strain-driven component (0: nothing drives it)
  bool checked = false;          // whether the leg's errors are judged at all
  std::int64_t settle = 0;       // steps before the errors count
  std::int64_t span = 0;         // the sustained error's span (its moving average's time constant) [steps]
  LegChecks(const Leg& leg, const Model& model);
};


// One step's measurement of every controlled component, judged once a whole span has been checked. Returns the
// component whose control has just failed, or -1.
int track_controls(const Leg& leg, const LegChecks& checks, double dt, const State& state, ControlErrors& errors);
// The judgement at the leg's end, on whatever was checked (a leg shorter than a span is judged on what it ran).
// Returns the first component that fails there, or -1.
int judge_leg_end(const State& state, ControlErrors& errors);
// The controls' present sustained error over its tolerance (0 while nothing has been checked): what the adaptive
// rate reads.
double present_over_tolerance(const ControlErrors& errors);

// The largest control errors of a test over its legs (summary.json): the worst single steps per unit, so that no
// number mixes a fraction with an absolute b, and the largest sustained error over its tolerance.
struct ControlErrorMaxima {
  double servo;            // stress, shear stress and mean-stress components: max |error| (servo_max_error)
  double b;                // b axes: max |b - target|, absolute (b_max_error)
  double volume;           // constant-volume axes: max |V/V(leg start) - 1| (volume_max_error)
  double over_tolerance;   // the largest sustained error over its tolerance: above 1 is a failed control
};
ControlErrorMaxima control_error_maxima(const std::vector<ControlErrors>& errors);

// One failed control of a test.
struct ControlFailureRecord {
  std::size_t leg = 0;
  int component = 0;     // 0-based, kComponentNames
  std::string kind;      // control_kind
  double error = 0.0;    // its sustained error
  double tolerance = 0.0;
  double target = 0.0;   // at the failure, in the error's quantity
  double reached = 0.0;
};
std::vector<ControlFailureRecord> control_failures(const std::vector<ControlErrors>& errors);

// What the failed control of component k says: where, its target, what it reached, how far, and why (the servo
// sat at its cap for most of the steps out of tolerance: the cap or the rate, and for a shear stress a target
// beyond the packing's shear strength; else the gains or the rate). `where`: "test 'ttc' leg 1"; `cap`: the cap
// the steps ran with.
std::string control_failure_message(const std::string& where, const ControlErrors& e, int k, double cap,
                                    const ServoDef& servo, const State& state, const LegChecks& checks);

// The test's failed controls as warnings (control_failure "warn"; "stop" ends the stage instead).
std::vector<std::string> control_warnings(const std::string& test_name, const std::vector<ControlErrors>& errors);

}  // namespace celldem
