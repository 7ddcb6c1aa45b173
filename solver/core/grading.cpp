#include "core/grading.hpp"

#include <algorithm>
#include <cmath>

namespace celldem {
namespace {

// ∫_{ln lo}^{ln hi} e^{c x} dx for x = ln d.
double integral_exp(double c, double lo, double hi) {
  return c == 0.0 ? std::log(hi / lo) : (std::pow(hi, c) - std::pow(lo, c)) / c;
}

}  // namespace

SizeDistribution::SizeDistribution(const GradingDef& grading)
    : sizes_(grading.sizes), a_(grading.by == GradingBasis::Mass ? 3 : 0) {
  const std::size_t n = sizes_.size();
  cumulative_.assign(n, 0.0);
  const double d0 = sizes_.front();  // sizes in units of the smallest: (d0/d)^3 stays near 1
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const double lo = sizes_[k] / d0, hi = sizes_[k + 1] / d0;
    const double w = (grading.passing[k + 1] - grading.passing[k]) / std::log(hi / lo) * integral_exp(-a_, lo, hi);
    cumulative_[k + 1] = cumulative_[k] + w;
  }
  const double total = cumulative_.back();
  for (double& c : cumulative_) c /= total;
  cumulative_.back() = 1.0;
}

double SizeDistribution::quantile(double u) const {
  const std::size_t n = sizes_.size();
  if (!(u < 1.0)) return sizes_.back();
  // The interval k with C_k <= u < C_{k+1} (intervals holding nothing are never chosen).
  const std::size_t k =
      static_cast<std::size_t>(std::upper_bound(cumulative_.begin(), cumulative_.end(), u) - cumulative_.begin()) - 1;
  if (k + 1 >= n) return sizes_.back();
  const double t = std::clamp((u - cumulative_[k]) / (cumulative_[k + 1] - cumulative_[k]), 0.0, 1.0);
  const double lo = sizes_[k], hi = sizes_[k + 1];
  double d;
  if (a_ == 0) {
    d = lo * std::pow(hi / lo, t);  // ln d uniform in the interval
  } else {
    // density ∝ e^{-3x}: d^-3 is uniform between lo^-3 and hi^-3
    const double r3 = std::pow(lo / hi, 3);
    d = lo / std::cbrt(1.0 - t * (1.0 - r3));
  }
  return std::clamp(d, lo, hi);
}

double SizeDistribution::number_cdf(double d) const {
  if (!(d >= sizes_.front())) return 0.0;
  if (d >= sizes_.back()) return 1.0;
  const std::size_t k =
      static_cast<std::size_t>(std::upper_bound(sizes_.begin(), sizes_.end(), d) - sizes_.begin()) - 1;
  const double lo = sizes_[k], hi = sizes_[k + 1];
  const double g = a_ == 0 ? std::log(d / lo) / std::log(hi / lo)
                           : (1.0 - std::pow(lo / d, 3)) / (1.0 - std::pow(lo / hi, 3));
  return cumulative_[k] + (cumulative_[k + 1] - cumulative_[k]) * g;
}

double SizeDistribution::mean_power(int p) const {
  double m = 0.0;
  for (std::size_t k = 0; k + 1 < sizes_.size(); ++k) {
    const double w = cumulative_[k + 1] - cumulative_[k];
    if (w == 0.0) continue;
    const double lo = sizes_[k], hi = sizes_[k + 1];
    // E[d^p] in the interval: ∫ e^{(p - a) x} dx / ∫ e^{-a x} dx, x = ln d
    m += w * integral_exp(p - a_, lo, hi) / integral_exp(-a_, lo, hi);
  }
  return m;
}

std::vector<double> draw_diameters(const GradingDef& grading, int count, Rng& rng) {
  const SizeDistribution dist(grading);
  std::vector<double> d(static_cast<std::size_t>(count));
  for (double& x : d) x = dist.draw(rng);
  return d;
}

std::vector<double> realised_passing(const GradingDef& grading, const std::vector<double>& diameters) {
  const std::vector<double>& sizes = grading.sizes;
  // bin[b]: the weight of the spheres with sizes[b-1] < d <= sizes[b] (bin[n]: larger than every sieve)
  std::vector<double> bin(sizes.size() + 1, 0.0);
  for (double d : diameters) {
    const std::size_t b = static_cast<std::size_t>(std::lower_bound(sizes.begin(), sizes.end(), d) - sizes.begin());
    bin[b] += grading.by == GradingBasis::Mass ? d * d * d : 1.0;
  }
  double total = 0.0;  // summed as the passing sums are: all spheres through the last sieve give 100 exactly
  for (double w : bin) total += w;
  std::vector<double> passing(sizes.size(), 0.0);
  double below = 0.0;
  for (std::size_t j = 0; j < sizes.size(); ++j) {
    below += bin[j];
    passing[j] = total > 0.0 ? 100.0 * (below / total) : 0.0;
  }
  return passing;
}

}  // namespace celldem
