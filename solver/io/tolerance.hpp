// `--tolerance T`: a deck's cost knobs rewritten by the time-to-answer rules, data calibrated by the speed-accuracy
// study and the rate ladder (io/time_to_answer_rules.json, compiled into the binary) instead of constants in code.
// T is in noise floors of the deck's own size, measured from the quasi-static answer (I -> 0): the strain-driven
// legs run at the inertial number whose rate bias, by the fitted laws b(I) = C I^p of each quantity at their 95 %
// upper bound, is T floors (the floor model at the conservative end of its exponent's interval), whatever rate
// the deck is written at; the time steps and the preparation's knobs come from the table's levels.
#pragma once
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/deck.hpp"

namespace celldem {

// One level of the table: the knobs at a tolerance.
struct ToleranceLevel {
  double tolerance = 0.0;                    // [noise floors]
  double time_step_fraction = 0.0;           // the tests' time step / the stability limit (critical_time_step)
  double prepare_time_step_fraction = 0.0;   // the preparation's
  double inertial_number = 0.0;              // strain-driven test legs: I = rate d_mean sqrt(rho / p)
  double fast_strain_increment_scale = 1.0;  // the preparation's fast (strain-driven) legs: strain per step x this
  double damping_scale = 1.0;                // body damping x this
};

// One quantity's rate bias: |Q(I) - Q(0)| = exp(log_coefficient) (I / reference)^order, fitted on the rate ladder,
// with the covariance of (log_coefficient, order) that carries the fit's uncertainty into the promise.
struct RateBiasLaw {
  std::string quantity;  // e.g. "ttc end_span.Z"
  double floor = 0.0;    // the seed-to-seed std of the quantity at the model's particle count
  double log_coefficient = 0.0, order = 1.0;
  double var_log_coefficient = 0.0, covariance = 0.0, var_order = 0.0;
};
// A path whose servo-held components were measured: the cell's actual inertial number over the imposed one.
struct MeasuredPath {
  std::string path;                                                // e.g. "axial"
  int normal_driven = 0, normal_zero_strain = 0, normal_held = 0;  // its normal axes (held: stress, mean_stress)
  int normal_b = 0;  // an axis held at b, with its value (NaN without one)
  double b = std::numeric_limits<double>::quiet_NaN();
  int shear_driven = 0;  // its shears at a strain rate other than 0 (the rest at zero strain: none servo-held)
  double ratio = 1.0;
};
struct RateBiasModel {
  double reference_inertial_number =
      2.2e-4;            // I of the laws' coefficient (the cell's actual: measure/quasi_static cell_inertial_number)
  int particles = 1000;  // the ladder's, where the floors were measured
  double floor_exponent = -0.5, floor_exponent_low = -0.5, floor_exponent_high = -0.5;  // floors as N^b
  double confidence = 0.95;           // of each law's one-sided upper bound
  double max_inertial_number = 1e-3;  // the top of the measured range: I is never set above it
  std::vector<RateBiasLaw> laws;
  std::vector<MeasuredPath> paths;  // actual_to_imposed.paths
  double path_margin = 1.0;         // actual_to_imposed.margin: each measured ratio is used times this
};

// How a leg's actual inertial number compares with its imposed one (core/plan inertial_strain_rate), which is all a
// plan knows: exactly 2/sqrt(3) where every component is strain-driven (the two scales of one tensor), the measured
// ratio of its path where servos hold some (their response adds to the rate; a b axis: the larger of the two measured
// b around its own), the largest measured one otherwise.
struct PathRatio {
  std::string path;  // "strain-driven", a measured path's name, or "unmeasured"
  double ratio = 0.0;
  std::string basis;  // in words
};
// `axes`: the leg's deck object (x1..x23); `simple_shear`: the leg is a simple_shear leg (g12 driven, x2 held).
PathRatio actual_to_imposed(const RateBiasModel& model, const nlohmann::json& axes, bool simple_shear);

// --tolerance's promise against a finished test: the mean actual inertial number of its strain-driven rows (the
// series' inertial_number, where imposed_inertial_number > 0) against the one the laws allowed, and each law's
// distance from I -> 0 at it in this deck's floors. kept: every law's upper bound within T.
struct ToleranceCheck {
  double tolerance = 0.0;                // [floors]
  double inertial_number_allowed = 0.0;  // inertial_number_for_tolerance
  double inertial_number = 0.0;          // measured: the rows' mean actual
  double imposed_inertial_number = 0.0;  // the same rows' mean imposed
  struct Distance {
    std::string quantity;
    double central = 0.0, upper = 0.0;  // [floors]
  };
  std::vector<Distance> distances;
  bool kept = false;
  nlohmann::json to_json() const;
};
ToleranceCheck check_tolerance(const RateBiasModel& model, double tolerance, double particles, double inertial_number,
                               double imposed_inertial_number);
// A quantity's bias at inertial number I in floors of a deck of `particles` spheres: the laws' central value in the
// central floor model, or (`upper`) its one-sided upper bound at the model's confidence in the floors of the
// interval's end that makes them narrowest at this size.
double rate_bias_floors(const RateBiasModel& model, const RateBiasLaw& law, double inertial_number, double particles,
                        bool upper);
// The largest inertial number whose upper bias is at most `tolerance` floors for every law (capped at the model's
// measured top), and the law that limits it; 0 when a law exceeds it even at 1e-9 (resolve_tolerance refuses).
struct RateForTolerance {
  double inertial_number = 0.0;
  std::string limiting;  // the quantity that sets it ("" where the cap does)
};
RateForTolerance inertial_number_for_tolerance(const RateBiasModel& model, double tolerance, double particles);

struct ToleranceRules {
  std::vector<ToleranceLevel> levels;  // ascending tolerance, at least one
  RateBiasModel rate_bias;             // the strain-driven legs' inertial number (levels' inertial_number unused)
  // The particle count of the scene the levels were measured on ("particles"; 0: not given). Its floors are
  // sqrt(N / particles) times a deck of N spheres' (floors as 1/sqrt(N): tools/study.py floors, docs/study.md),
  // and a rate's bias does not shrink with N.
  int particles = 0;
};

// T floors of a deck of `particles` spheres in floors of the rules' scene: T sqrt(rules.particles / N) for a
// larger deck (its floors are narrower, the bias the same); T itself for a smaller one (its wider floors are not
// spent: the floor model is measured from 500 spheres up) or where the rules give no count.
double calibration_tolerance(const ToleranceRules& rules, double tolerance, double particles);

// The table as the binary carries it (CMake embeds the file at build time: no file is read at run time).
const std::string& time_to_answer_rules_text();
const ToleranceRules& time_to_answer_rules();
// Parses a table; DeckError naming the entry on a malformed one (levels not ascending, a number not positive).
ToleranceRules parse_tolerance_rules(const std::string& json_text);

// The knobs at `tolerance`: between the two levels around it, each number's logarithm linear in T. Outside
// the table's range a DeckError names `key_path` ("tolerance" or "--tolerance") and the range.
ToleranceLevel interpolate_rules(const ToleranceRules& rules, double tolerance, const std::string& key_path);

// The deck (as written, and its JSON text) rewritten for `tolerance` floors of its own and read again: every stage
// gets its own time step at the fraction of the stability limit of the table's level at calibration_tolerance
// (clamped to the table's range); each strain-driven test leg the strain rate of inertial_number_for_tolerance at
// the leg's confining stress (its stress targets, else the test's, else the deck's
// largest), its strain-driven axes scaled together and its step ends kept at their strain; the preparation's
// fast legs their strain per step x the scale; legs without a strain-driven axis keep the physical time of their
// step ends; equilibrium min_steps and check_interval and the preparation's output interval their physical time;
// the tests' output intervals their rows per unit strain; an explicit servo cap rises with the fastest leg's
// strain per step. The result records `tolerance` and, as JSON text, the resolved settings of every stage
// beside the deck's (tolerance_settings). `key_path` names where the tolerance came from.
Deck resolve_tolerance(const Deck& written, const std::string& json_text, double tolerance,
                       const std::string& key_path = "tolerance");

// A resolved deck as its run directory keeps it (resolved_deck.json): the deck celldem ran, which runs again as
// written, with initial_state made absolute (the run directory is elsewhere than the deck).
std::string resolved_deck_json(const Deck& deck);

}  // namespace celldem
