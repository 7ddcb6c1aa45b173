#include "run/adaptive_rate.hpp"

#include <algorithm>

namespace celldem {

double adapted_rate_factor(const AdaptiveRate& rule, double factor, const RateIndicators& now) {
  const double u = std::max({now.unbalanced_force / rule.unbalanced_force_ratio, now.kinetic_to_elastic / rule.kinetic_to_elastic,
                             now.control_over_tolerance});
  if (!(u <= 1.0)) factor *= std::max(kRateLowerMost, 1.0 / u);
  else if (u < kRateCalm) factor *= kRateRaise;
  double ceiling = std::min(rule.max_factor, now.servo_ceiling);
  if (now.inertial_at_deck_rate > 0.0) ceiling = std::min(ceiling, rule.inertial_number / now.inertial_at_deck_rate);
  return std::clamp(factor, rule.min_factor, std::max(rule.min_factor, ceiling));
}

}  // namespace celldem
