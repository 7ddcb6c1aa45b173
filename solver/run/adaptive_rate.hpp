// The adaptive loading rate's rule (Leg::adaptive, checked every check_interval steps of the leg): u, the largest
// of the unbalanced force ratio and the kinetic-to-elastic energy ratio over their targets and of the controls'
// present average error over half their tolerance (run/control_verdict.hpp), raises the factor by kRateRaise while
// u < kRateCalm (the packing and the servo both keep up with the loading), lowers it by max(kRateLowerMost, 1/u)
// when u > 1 (or not finite), and holds it between. Then it is kept within [min_factor, max_factor], under the
// inertial-number ceiling (inertial_number / the inertial number at the deck's rate: the cell's actual one,
// measure/quasi_static.hpp cell_inertial_number, over the factor it ran at, since the next factor must be chosen
// before its steps and every component's rate, servo-held ones included, follows the driving rate) and under what the servo
// can follow: with a servo cap the deck fixes (servo.max_strain_increment), a factor whose driving increment
// needs more than the cap allows (core/plan.hpp kMinServoCapRatio) is not taken; the default cap follows the
// factor (core/plan.hpp servo_cap). Raising by a quarter and lowering by at most a half: the stress-controlled
// components' servo sees a step in the driving rate at each change, and follows a quarter's step within a few
// hundred steps.
#pragma once
#include <limits>

#include "core/deck.hpp"

namespace celldem {

inline constexpr double kRateRaise = 1.25;
inline constexpr double kRateCalm = 0.5;
inline constexpr double kRateLowerMost = 0.5;
// The controls' indicator is their sustained error over half their tolerance: the rate backs off while the
// servo's average error is still half the tolerance from failing (the average lags the rate by its span).
inline constexpr double kControlShareOfTolerance = 2.0;

struct RateIndicators {
  double unbalanced_force = 0.0;       // ratio (measure/micro.hpp ContactMeasures)
  double kinetic_to_elastic = 0.0;     // kinetic over elastic energy
  double control_over_tolerance = 0.0; // the controls' present average error over kControlShareOfTolerance x ... (0: none)
  double inertial_at_deck_rate = 0.0;  // the leg's inertial number at factor 1: the actual over the factor (0: no ceiling)
  double servo_ceiling = std::numeric_limits<double>::infinity();  // the largest factor the servo's cap follows
};

// The leg's next rate factor from the present one.
double adapted_rate_factor(const AdaptiveRate& rule, double factor, const RateIndicators& now);

}  // namespace celldem
