// Running a stage's load program: its legs in order, each from where the previous one ended, until the
// last leg's end condition; and how well each leg's controls held their targets.
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

class StageOutput;

// How well a leg's controls held their targets, measured at every step after the leg's first kSettleStrain
// of driving strain (the start-up transient). NaN (null in JSON) where nothing was measured: a control the
// leg does not have, a leg shorter than the settle window, a leg that no axis drives.
inline constexpr double kSettleStrain = 0.002;
// A control fails when its error stays above its tolerance (run/health.hpp) for kPersistStrain of driving
// strain in a row, and at least kMinPersistSteps steps. Why these: the servo removes an error with a time
// constant of about 1/gain steps (20 at the default gain) and the integral term's of about 1/integral_gain
// (500), so the stress spike of a slip event is corrected within a few hundred steps and the error falls back
// inside the tolerance; a saturated servo falls behind a little more at every step and never comes back.
// 0.1 % of strain is 5000 steps at the paper's 2e-7 per step and 1000 at 1e-6: well past a slip's recovery,
// and caught long before a test's peak (1-3 % of strain). The floor keeps fast legs from counting a spike.
inline constexpr double kPersistStrain = 0.001;
inline constexpr std::int64_t kMinPersistSteps = 500;
// A leg that only a stress ramp drives (no strain-driven axis) has no driving strain to measure its settle
// window in: its errors count after this many steps, twice the integral term's time constant at the default
// integral_gain (the ramp's lag under the proportional term alone is removed by then).
inline constexpr std::int64_t kRampSettleSteps = 1000;
// Axes of the per-axis records below: x1, x2, x3, then the shear axes x12, x13, x23 (control_axis_name).
inline constexpr int kControlAxes = 6;
std::string control_axis_name(int k);
struct ControlErrors {
  double stress = std::numeric_limits<double>::quiet_NaN();       // stress axes: max |s - target| / target
  double b = std::numeric_limits<double>::quiet_NaN();            // b axis: max |b - target| (axis stresses)
  double mean_stress = std::numeric_limits<double>::quiet_NaN();  // mean_stress axes: max |p - target| / target
  double volume = std::numeric_limits<double>::quiet_NaN();       // constant-volume axes: max |V/V(leg start) - 1|
  // Shear stress axes: max |s_ij - target| / max(|target|, p), p the mean stress: a shear target (0 most of
  // all) has no scale of its own, and the mean stress is the one the packing carries (summary.json
  // `shear_stress`, written with `shear_axes` only by legs that have such an axis; tolerance as `stress`).
  double shear_stress = std::numeric_limits<double>::quiet_NaN();
  std::int64_t steps = 0;                                         // steps checked
  // Per axis (x1, x2, x3, x12, x13, x23): its worst error (of its kind, as above), the steps of the leg whose
  // servo increment sat at its cap, the present run of consecutive checked steps above the tolerance and how
  // many of those were at the cap, and whether the control failed (stayed above the tolerance, see
  // kPersistStrain).
  std::array<double, kControlAxes> axis_error = {
      std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
      std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN(),
      std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  std::array<std::int64_t, kControlAxes> saturated_steps = {};
  std::array<std::int64_t, kControlAxes> over_steps = {};
  std::array<std::int64_t, kControlAxes> over_saturated = {};
  std::array<bool, kControlAxes> failed = {};
};
nlohmann::json to_json(const ControlErrors& e);
ControlErrors control_errors_from_json(const nlohmann::json& j);

// The tolerance of a control of this kind (run/health.hpp), and its name in messages and summary.json.
double control_tolerance(AxisMode mode);
std::string control_kind(AxisMode mode);
// The control mode of axis k (control_axis_name) in the leg; a shear axis the leg does not name is held
// (a strain control).
AxisMode control_mode(const Leg& leg, int k);

// The adaptive loading rate's rule (Leg::adaptive, checked every check_interval steps of the leg): u, the
// largest of the unbalanced force ratio and the kinetic-to-elastic energy ratio over their targets, raises the
// factor by kRateRaise while u < kRateCalm (well inside both targets: the packing keeps up with the loading),
// lowers it by max(kRateLowerMost, 1/u) when u > 1 (or not finite), and holds it between. Then it is kept within
// [min_factor, max_factor] and under the inertial-number ceiling (inertial_number / the inertial number at the
// deck's rate). Raising by a quarter and lowering by at most a half: the stress-controlled axes' servo sees a
// step in the driving rate at each change, and follows a quarter's step within a few hundred steps.
inline constexpr double kRateRaise = 1.25;
inline constexpr double kRateCalm = 0.5;
inline constexpr double kRateLowerMost = 0.5;
struct RateIndicators {
  double unbalanced_force = 0.0;       // ratio (measure/micro.hpp ContactMeasures)
  double kinetic_to_elastic = 0.0;     // kinetic over elastic energy
  double inertial_at_deck_rate = 0.0;  // the inertial number of the leg at factor 1 (0: no ceiling)
};
double adapted_rate_factor(const AdaptiveRate& rule, double factor, const RateIndicators& now);

struct Program {
  const std::vector<Leg>& legs;
  Friction friction;  // sliding and rolling
  const EquilibriumDef* equilibrium = nullptr;  // for legs that end in equilibrium
  std::int64_t planned_steps = -1;              // all legs, when known (progress and ETA)
  bool adaptive_threads = true;                 // a ThreadGovernor may drop to one thread under contention
  std::string stage = "prepare";                // the stage's name (messages)
  ControlFailure control_failure = ControlFailure::Stop;  // a failed control stops the stage, or is recorded
  std::string equilibrium_key = "prepare.equilibrium";    // where the deck sets `equilibrium` (messages)
  bool print_control_warnings = true;  // with control_failure warn: print a failed control (probes record it only)
};

// Runs the program from the state's current leg (state.control.leg) to its end. `errors` holds one entry
// per leg (kept across a resume by the stage's checkpoints). Each leg's end is a row of the series. Throws
// RunError for a leg that ends after no step, and (control_failure stop) for a control that fails, naming
// the stage, leg, axis, the error and what to change.
void run_program(const Model& model, const Program& program, State& state, StageOutput& out,
                 std::vector<ControlErrors>& errors);

}  // namespace celldem
