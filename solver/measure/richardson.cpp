#include "measure/richardson.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>

namespace celldem {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kGrid = 160;        // points of the log-p grid
constexpr int kGoldenSteps = 60;  // golden-section steps around the grid's best point

// Q0 and C of the linear least squares at order p, and the residual.
PowerLawFit linear_at(const std::vector<double>& r, const std::vector<double>& q, double p) {
  const std::size_t n = r.size();
  double xm = 0.0, qm = 0.0;
  std::vector<double> x(n);
  for (std::size_t i = 0; i < n; ++i)
    x[i] = std::pow(r[i], p), xm += x[i] / static_cast<double>(n), qm += q[i] / static_cast<double>(n);
  double sxx = 0.0, sxq = 0.0;
  for (std::size_t i = 0; i < n; ++i) sxx += (x[i] - xm) * (x[i] - xm), sxq += (x[i] - xm) * (q[i] - qm);
  PowerLawFit f;
  f.order = p;
  f.c = sxx > 0.0 ? sxq / sxx : 0.0;
  f.q0 = qm - f.c * xm;
  for (std::size_t i = 0; i < n; ++i) {
    const double e = q[i] - f.q0 - f.c * x[i];
    f.residual += e * e;
  }
  return f;
}

// A uniform deviate in (0, 1) from the engine's 53 high bits (the engine is the standard's, its output fixed).
double uniform(std::mt19937_64& rng) { return (static_cast<double>(rng() >> 11) + 0.5) * 0x1p-53; }

double quantile_of_sorted(const std::vector<double>& v, double p) {
  const double at = p * static_cast<double>(v.size() - 1);
  const std::size_t k = static_cast<std::size_t>(at);
  if (k + 1 >= v.size()) return v.back();
  return v[k] + (at - static_cast<double>(k)) * (v[k + 1] - v[k]);
}

}  // namespace

PowerLawFit fit_power_law(const std::vector<double>& rates, const std::vector<double>& values) {
  if (rates.size() != values.size() || rates.size() < 3)
    throw std::invalid_argument("fit_power_law: at least three rates, one value each");
  for (const double r : rates)
    if (!(r > 0.0) || !std::isfinite(r)) throw std::invalid_argument("fit_power_law: rates must be positive");
  const double lo = std::log(kMinOrder), hi = std::log(kMaxOrder);
  const auto at = [&](double log_p) { return linear_at(rates, values, std::exp(log_p)); };
  int best = 0;
  double best_residual = std::numeric_limits<double>::infinity();
  for (int k = 0; k < kGrid; ++k) {
    const double residual = at(lo + (hi - lo) * k / (kGrid - 1)).residual;
    if (residual < best_residual) best_residual = residual, best = k;
  }
  // golden section over the grid's neighbours of the best point
  double a = lo + (hi - lo) * std::max(0, best - 1) / (kGrid - 1);
  double b = lo + (hi - lo) * std::min(kGrid - 1, best + 1) / (kGrid - 1);
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = at(c).residual, fd = at(d).residual;
  for (int i = 0; i < kGoldenSteps; ++i) {
    if (fc < fd)
      b = d, d = c, fd = fc, c = b - g * (b - a), fc = at(c).residual;
    else
      a = c, c = d, fc = fd, d = a + g * (b - a), fd = at(d).residual;
  }
  PowerLawFit fit = at(0.5 * (a + b));
  for (const double edge : {lo, hi})  // the bounds themselves, where the minimum lies at one
    if (const PowerLawFit e = at(edge); e.residual < fit.residual) fit = e;
  const double span = hi - lo;
  fit.order_at_bound = std::log(fit.order) - lo < 1e-3 * span || hi - std::log(fit.order) < 1e-3 * span;
  return fit;
}

LadderFit fit_ladder(const std::vector<double>& rates, const std::vector<double>& values, double chaos_sd,
                     int chaos_dof, double alpha, int draws, std::uint64_t seed) {
  LadderFit out;
  out.fit = fit_power_law(rates, values);
  if (!(chaos_sd > 0.0) || chaos_dof < 1 || draws < 10) {
    out.distance_lo = out.distance_hi = out.order_lo = out.order_hi = kNaN;
    return out;
  }
  std::mt19937_64 rng(seed);
  const boost::math::normal_distribution<double> normal;
  const boost::math::chi_squared_distribution<double> chi2(chaos_dof);
  std::vector<double> fitted(rates.size()), drawn(rates.size()), distance, order;
  for (std::size_t i = 0; i < rates.size(); ++i) fitted[i] = out.fit.q0 + out.fit.c * std::pow(rates[i], out.fit.order);
  int at_bound = 0;
  for (int k = 0; k < draws; ++k) {
    // the chaos's std as the runs measured it could be: s sqrt(dof / chi2_dof)
    const double sd = chaos_sd * std::sqrt(chaos_dof / boost::math::quantile(chi2, uniform(rng)));
    for (std::size_t i = 0; i < rates.size(); ++i)
      drawn[i] = fitted[i] + sd * boost::math::quantile(normal, uniform(rng));
    const PowerLawFit f = fit_power_law(rates, drawn);
    distance.push_back(f.c), order.push_back(f.order);
    at_bound += f.order_at_bound ? 1 : 0;
  }
  std::sort(distance.begin(), distance.end());
  std::sort(order.begin(), order.end());
  out.distance_lo = quantile_of_sorted(distance, alpha);
  out.distance_hi = quantile_of_sorted(distance, 1.0 - alpha);
  out.order_lo = quantile_of_sorted(order, alpha);
  out.order_hi = quantile_of_sorted(order, 1.0 - alpha);
  out.order_at_bound_share = static_cast<double>(at_bound) / draws;
  out.draws = draws;
  return out;
}

}  // namespace celldem
