// Grading curves: sphere sizes drawn from a curve of percent passing, by mass (a sieve curve) or by number,
// at sieve sizes, interpolated linearly in log d between sieves (the semi-log grading plot of soil mechanics).
#pragma once
#include <vector>

#include "core/choices.hpp"
#include "core/rng.hpp"

namespace celldem {

struct GradingDef {
  GradingBasis by = GradingBasis::Mass;
  std::vector<double> sizes;    // [m] sieve sizes d_0 < d_1 < ... (n >= 2)
  std::vector<double> passing;  // [%] passing each size P_0 = 0 <= P_1 <= ... <= P_{n-1} = 100 (n entries)
};

// The number distribution of diameters that a grading implies. Between sieves k and k+1 the asked curve is
// linear in x = ln d, so its density in x is constant there, (P_{k+1} - P_k) / ln(d_{k+1} / d_k). By number
// that is the number density; by mass the number density is the mass density over d^3 (one particle
// density), proportional to e^{-3x} within the interval. With a = 3 (mass) or 0 (number), interval k holds
// the number fraction
//   w_k ∝ (P_{k+1} - P_k) / ln(d_{k+1} / d_k) · ∫_{ln d_k}^{ln d_{k+1}} e^{-a x} dx,
// and inside it x has the density ∝ e^{-a x}. draw() inverts this CDF exactly (one uniform per sphere).
class SizeDistribution {
 public:
  explicit SizeDistribution(const GradingDef& grading);

  // The diameter [m] whose number CDF is u in [0, 1).
  double quantile(double u) const;
  // One diameter [m] by inverse transform: quantile(rng.uniform()).
  double draw(Rng& rng) const { return quantile(rng.uniform()); }
  // The fraction of spheres, by number, with a diameter <= d [m].
  double number_cdf(double d) const;
  // E[d^p] over the number distribution [m^p].
  double mean_power(int p) const;
  double smallest() const { return sizes_.front(); }
  double largest() const { return sizes_.back(); }

 private:
  std::vector<double> sizes_;       // [m] the sieve sizes
  std::vector<double> cumulative_;  // number CDF at each sieve size: 0, ..., 1
  int a_ = 0;                       // the number density in ln d goes as d^-a within an interval
};

// The diameters [m] of `count` spheres, drawn in order from rng.
std::vector<double> draw_diameters(const GradingDef& grading, int count, Rng& rng);

// The percent passing each sieve size of the grading, by its basis, for these diameters [m]: by mass (each
// sphere weighs in proportion to d^3, one density) or by number. A sphere passes a sieve when d <= its size.
std::vector<double> realised_passing(const GradingDef& grading, const std::vector<double>& diameters);

}  // namespace celldem
