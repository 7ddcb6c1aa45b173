// Richardson extrapolation with an unknown order: a quantity measured at several rates r (in units of a reference
// rate, the test's: r = 1) is fitted by Q(r) = Q0 + C r^p, with Q0 the quasi-static answer (r -> 0) and p the
// order, fitted rather than assumed (granular quantities go as about sqrt(I), not linearly in the rate). With three
// rates the fit is exact; with more it is least squares. The interval comes from propagating the chaos of one run
// (a standard deviation measured from a few runs at the same rate) through the fit by simulation.
#pragma once
#include <cstdint>
#include <vector>

namespace celldem {

// The order is sought within these bounds: below kMinOrder three rates a factor 4 apart cannot tell a rate's effect
// from a constant (r^0.25 changes by 0.29 over them), above kMaxOrder no rate effect in granular flow is known.
inline constexpr double kMinOrder = 0.25;
inline constexpr double kMaxOrder = 3.0;

struct PowerLawFit {
  double q0 = 0.0;              // the answer at r -> 0
  double c = 0.0;               // Q(1) - Q0: the reference rate's distance from r -> 0
  double order = 1.0;           // p
  double residual = 0.0;        // the sum of squared residuals
  bool order_at_bound = false;  // p at kMinOrder or kMaxOrder: the data do not fix it within them
};
// Least squares over Q0, C (linear for each p) and p in [kMinOrder, kMaxOrder] (a grid in log p, then golden
// section around its best point). `rates` positive, at least three distinct ones, as many as `values`.
PowerLawFit fit_power_law(const std::vector<double>& rates, const std::vector<double>& values);

// The fit with its intervals: each value is the fit's plus one run's chaos, a normal deviate of standard deviation
// `chaos_sd` (itself drawn from its scaled chi-square with `chaos_dof` degrees of freedom: a std from few runs is
// uncertain), refitted `draws` times. distance_lo/hi are the one-sided (1 - alpha) bounds of C (the alpha and
// 1 - alpha quantiles of the refits), order_lo/hi the central (1 - 2 alpha) interval of p. Without chaos
// (chaos_sd not positive or chaos_dof < 1) the bounds are NaN. The draws come from a fixed seed: the same bits on
// every machine.
struct LadderFit {
  PowerLawFit fit;
  double distance_lo = 0.0, distance_hi = 0.0;
  double order_lo = 0.0, order_hi = 0.0;
  double order_at_bound_share = 0.0;  // the share of refits whose p is at a bound
  int draws = 0;
};
LadderFit fit_ladder(const std::vector<double>& rates, const std::vector<double>& values, double chaos_sd,
                     int chaos_dof, double alpha, int draws = 4000, std::uint64_t seed = 20261129);

}  // namespace celldem
