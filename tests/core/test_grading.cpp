// Grading curves (solver/core/grading.hpp): the number distribution a grading implies, against closed forms
// and an independent numerical integration; large draws against it within statistical bounds; the realised
// curve of hand-made samples.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "core/grading.hpp"

namespace celldem {
namespace {

// Simpson's rule on n (even) intervals.
double simpson(const std::function<double(double)>& f, double a, double b, int n = 2000) {
  const double h = (b - a) / n;
  double s = f(a) + f(b);
  for (int i = 1; i < n; ++i) s += f(a + i * h) * (i % 2 ? 4.0 : 2.0);
  return s * h / 3.0;
}

// The number CDF by direct integration of the number density, interval by interval: the asked curve's density
// in d, (P_{k+1} - P_k) / (ln(d_{k+1}/d_k) d) (linear in ln d between sieves), itself (by number) or over d^3
// (by mass), normalised over all sizes. Independent of SizeDistribution's closed forms.
double integrated_number_cdf(const GradingDef& g, double d) {
  const auto integral = [&g](double hi) {
    double s = 0.0;
    for (std::size_t k = 0; k + 1 < g.sizes.size() && g.sizes[k] < hi; ++k) {
      const double c = (g.passing[k + 1] - g.passing[k]) / std::log(g.sizes[k + 1] / g.sizes[k]);
      const auto n = [&g, c](double x) { return c / x / (g.by == GradingBasis::Mass ? x * x * x : 1.0); };
      s += simpson(n, g.sizes[k], std::min(hi, g.sizes[k + 1]));
    }
    return s;
  };
  return integral(d) / integral(g.sizes.back());
}

// The largest |F_n(x) - F(x)| over x at 100 points in each interval between sieves (geometrically spaced),
// for the empirical CDF F_n of the draws: a lower bound of the Kolmogorov-Smirnov distance.
double ks_distance_on_grid(std::vector<double> draws, const GradingDef& g) {
  std::sort(draws.begin(), draws.end());
  const double n = static_cast<double>(draws.size());
  double worst = 0.0;
  for (std::size_t k = 0; k + 1 < g.sizes.size(); ++k)
    for (int i = 0; i < 100; ++i) {
      const double x = g.sizes[k] * std::pow(g.sizes[k + 1] / g.sizes[k], i / 100.0);
      const double fn = static_cast<double>(std::upper_bound(draws.begin(), draws.end(), x) - draws.begin()) / n;
      worst = std::max(worst, std::abs(fn - integrated_number_cdf(g, x)));
    }
  return worst;
}

// Dvoretzky-Kiefer-Wolfowitz (Massart's constant): P(sup |F_n - F| > eps) <= 2 exp(-2 n eps^2), so
// eps = sqrt(ln(2/alpha) / (2n)) is exceeded with probability at most alpha.
double dkw_bound(std::size_t n, double alpha) { return std::sqrt(std::log(2.0 / alpha) / (2.0 * n)); }

constexpr double kAlpha = 1e-6;   // false-alarm rate of each statistical check
constexpr int kDraws = 200'000;

GradingDef sand(GradingBasis by) {  // a well-graded sand, 0.1 to 4 mm, with an empty interval
  return {by, {1e-4, 2.5e-4, 5e-4, 1e-3, 2e-3, 4e-3}, {0.0, 10.0, 35.0, 35.0, 80.0, 100.0}};
}

// One interval, by mass, linear in ln d between d1 and d2: the mass density in x = ln d is constant, the
// number density goes as e^{-3x}, so F_n(d) = (d1^-3 - d^-3) / (d1^-3 - d2^-3).
TEST(Grading, OneIntervalByMassHasTheClosedFormNumberCdf) {
  const double d1 = 1e-3, d2 = 3e-3;
  const SizeDistribution dist({GradingBasis::Mass, {d1, d2}, {0.0, 100.0}});
  const auto closed = [&](double d) { return (1 / (d1 * d1 * d1) - 1 / (d * d * d)) / (1 / (d1 * d1 * d1) - 1 / (d2 * d2 * d2)); };
  for (double d : {1e-3, 1.1e-3, 1.5e-3, 2e-3, 2.9e-3, 3e-3}) {
    EXPECT_NEAR(dist.number_cdf(d), closed(d), 1e-14) << d;
    EXPECT_NEAR(dist.quantile(closed(d)), d, 1e-15) << d;
  }
  // E[d] = ∫ d d^-4 dd / ∫ d^-4 dd = (3/2) (d1^-2 - d2^-2) / (d1^-3 - d2^-3)
  const double mean = 1.5 * (1 / (d1 * d1) - 1 / (d2 * d2)) / (1 / (d1 * d1 * d1) - 1 / (d2 * d2 * d2));
  EXPECT_NEAR(dist.mean_power(1), mean, 1e-15);
  // E[d^3] = ∫ d^-1 / ∫ d^-4 = 3 ln(d2/d1) / (d1^-3 - d2^-3)
  EXPECT_NEAR(dist.mean_power(3), 3 * std::log(d2 / d1) / (1 / (d1 * d1 * d1) - 1 / (d2 * d2 * d2)), 1e-22);
}

// By number, ln d is uniform on one interval: F_n(d) = ln(d/d1) / ln(d2/d1), E[d] = (d2 - d1) / ln(d2/d1).
TEST(Grading, OneIntervalByNumberIsLogUniform) {
  const double d1 = 1e-3, d2 = 3e-3;
  const SizeDistribution dist({GradingBasis::Number, {d1, d2}, {0.0, 100.0}});
  for (double d : {1e-3, 1.5e-3, 2e-3, 3e-3}) EXPECT_NEAR(dist.number_cdf(d), std::log(d / d1) / std::log(d2 / d1), 1e-14);
  EXPECT_NEAR(dist.mean_power(1), (d2 - d1) / std::log(d2 / d1), 1e-16);
  EXPECT_EQ(dist.number_cdf(0.5e-3), 0.0);
  EXPECT_EQ(dist.number_cdf(4e-3), 1.0);
}

TEST(Grading, NumberCdfAgreesWithIntegratingTheAskedCurve) {
  for (GradingBasis by : {GradingBasis::Mass, GradingBasis::Number}) {
    const GradingDef g = sand(by);
    const SizeDistribution dist(g);
    for (double d : {1e-4, 1.7e-4, 2.5e-4, 4e-4, 7e-4, 1e-3, 1.4e-3, 3e-3, 4e-3})
      EXPECT_NEAR(dist.number_cdf(d), integrated_number_cdf(g, d), 1e-9) << d;
    // By number the curve is the asked one at each sieve.
    if (by == GradingBasis::Number) {
      for (std::size_t k = 0; k < g.sizes.size(); ++k) EXPECT_NEAR(dist.number_cdf(g.sizes[k]), g.passing[k] / 100, 1e-14);
    }
  }
}

// The distance of 200k draws' empirical CDF from the integrated number CDF stays within the DKW bound at a
// false-alarm rate of 1e-6 (eps = 0.0060): this checks the drawing and the choice of interval.
TEST(Grading, LargeDrawFollowsTheNumberCdf) {
  for (GradingBasis by : {GradingBasis::Mass, GradingBasis::Number}) {
    const GradingDef g = sand(by);
    Rng rng(12345);
    const std::vector<double> d = draw_diameters(g, kDraws, rng);
    EXPECT_LE(ks_distance_on_grid(d, g), dkw_bound(d.size(), kAlpha))
        << (by == GradingBasis::Mass ? "mass" : "number");
    for (double x : d) {
      EXPECT_GE(x, g.sizes.front());
      EXPECT_LE(x, g.sizes.back());
      EXPECT_FALSE(x > 5e-4 && x < 1e-3) << x;  // the empty interval (35 % at both ends) is never drawn
    }
  }
}

// The realised curve of a large draw against the asked one, at each sieve. By number the percent passing is
// an empirical CDF: within 100 x the DKW bound. By mass it is a ratio of sums, sum_{d <= s} d^3 / sum d^3,
// asymptotically normal (delta method) with standard error
//   se = sqrt(sum_i d_i^6 (1{d_i <= s} - p)^2) / sum_i d_i^3;
// each sieve is within z se, z = 5.33 (two-sided normal tail 1e-7 per sieve, 6 sieves: below 1e-6).
TEST(Grading, RealisedCurveOfALargeDrawMatchesTheAskedOne) {
  for (GradingBasis by : {GradingBasis::Mass, GradingBasis::Number}) {
    const GradingDef g = sand(by);
    Rng rng(777);
    const std::vector<double> d = draw_diameters(g, kDraws, rng);
    const std::vector<double> realised = realised_passing(g, d);
    ASSERT_EQ(realised.size(), g.sizes.size());
    EXPECT_EQ(realised.front(), 0.0);
    EXPECT_EQ(realised.back(), 100.0);
    for (std::size_t k = 0; k < g.sizes.size(); ++k) {
      double tol = 100.0 * dkw_bound(d.size(), kAlpha);
      if (by == GradingBasis::Mass) {
        double m = 0.0, v = 0.0;
        for (double x : d) m += x * x * x;
        const double p = realised[k] / 100.0;
        for (double x : d) {
          const double e = x * x * x * ((x <= g.sizes[k] ? 1.0 : 0.0) - p);
          v += e * e;
        }
        tol = 100.0 * 5.33 * std::sqrt(v) / m;
      }
      EXPECT_NEAR(realised[k], g.passing[k], tol) << "sieve " << k << (by == GradingBasis::Mass ? " mass" : " number");
    }
  }
}

// Hand-counted: diameters 1, 2, 2, 3 through sieves 1, 2, 3 pass 1, 3, 4 of 4 by number, and 1, 17, 44 of 44
// by mass (d^3: 1, 8, 8, 27).
TEST(Grading, RealisedPassingCountsNumberAndMass) {
  const std::vector<double> d = {2.0, 1.0, 3.0, 2.0};
  const std::vector<double> by_number = realised_passing({GradingBasis::Number, {1, 2, 3}, {0, 50, 100}}, d);
  const std::vector<double> by_mass = realised_passing({GradingBasis::Mass, {1, 2, 3}, {0, 50, 100}}, d);
  ASSERT_EQ(by_number.size(), 3u);
  EXPECT_DOUBLE_EQ(by_number[0], 25.0);
  EXPECT_DOUBLE_EQ(by_number[1], 75.0);
  EXPECT_DOUBLE_EQ(by_number[2], 100.0);
  EXPECT_DOUBLE_EQ(by_mass[0], 100.0 / 44);
  EXPECT_DOUBLE_EQ(by_mass[1], 1700.0 / 44);
  EXPECT_DOUBLE_EQ(by_mass[2], 100.0);
}

TEST(Grading, DrawIsDeterministic) {
  Rng a(5), b(5), c(6);
  const GradingDef g = sand(GradingBasis::Mass);
  EXPECT_EQ(draw_diameters(g, 1000, a), draw_diameters(g, 1000, b));
  EXPECT_NE(draw_diameters(g, 1000, b), draw_diameters(g, 1000, c));
}

}  // namespace
}  // namespace celldem
