// Richardson extrapolation with an unknown order (measure/richardson.hpp) against synthetic ladders whose order,
// limit and noise are known.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "measure/richardson.hpp"

namespace celldem {
namespace {

std::vector<double> law(const std::vector<double>& rates, double q0, double c, double p) {
  std::vector<double> q;
  for (const double r : rates) q.push_back(q0 + c * std::pow(r, p));
  return q;
}

TEST(Richardson, ThreeRatesGiveTheOrderExactly) {
  // Z going as sqrt(I) -like, at the default ladder (the test, half and a quarter of its rate)
  const std::vector<double> rates = {1.0, 0.5, 0.25};
  for (const double p : {0.3, 0.525, 0.75, 1.0, 2.0}) {
    const PowerLawFit f = fit_power_law(rates, law(rates, 4.3, -0.05, p));
    EXPECT_NEAR(f.order, p, 1e-6) << p;
    EXPECT_NEAR(f.c, -0.05, 1e-8) << p;
    EXPECT_NEAR(f.q0, 4.3, 1e-8) << p;
    EXPECT_FALSE(f.order_at_bound);
  }
  // the closed form for rates in ratio 2: p = log2((Q1 - Q1/2) / (Q1/2 - Q1/4))
  const std::vector<double> q = {2.937, 2.894, 2.866};
  EXPECT_NEAR(fit_power_law(rates, q).order, std::log2((q[0] - q[1]) / (q[1] - q[2])), 1e-6);
}

TEST(Richardson, MoreRatesAreFittedByLeastSquares) {
  const std::vector<double> rates = {8.0, 4.0, 2.0, 1.0, 0.5, 0.25};
  const PowerLawFit f = fit_power_law(rates, law(rates, -0.06, 0.004, 0.64));
  EXPECT_NEAR(f.order, 0.64, 1e-6);
  EXPECT_NEAR(f.c, 0.004, 1e-9);
  EXPECT_LT(f.residual, 1e-18);
  // a law with an order below the bounds is fitted at the bound, and says so
  const PowerLawFit low = fit_power_law(rates, law(rates, 1.0, 0.1, 0.05));
  EXPECT_TRUE(low.order_at_bound);
  EXPECT_NEAR(low.order, kMinOrder, 1e-9);
  EXPECT_THROW(fit_power_law({1.0, 0.5}, {1.0, 2.0}), std::invalid_argument);
}

TEST(Richardson, ALinearExtrapolationUnderstatesASquareRootLaw) {
  // the review's point: (Q1 - Qf) / (1 - f) is C (1 - f^p) / (1 - f), 0.59 of C at p = 1/2 and f = 1/2
  const std::vector<double> rates = {1.0, 0.5, 0.25};
  const std::vector<double> q = law(rates, 0.0, 1.0, 0.5);
  EXPECT_NEAR((q[0] - q[1]) / 0.5, 2.0 * (1.0 - std::sqrt(0.5)), 1e-12);
  EXPECT_NEAR(fit_power_law(rates, q).c, 1.0, 1e-8);
}

TEST(Richardson, TheBoundsCoverTheTrueDistanceAtTheirLevel) {
  // Ladders of a known law plus chaos of a known std, the chaos estimated as the runs would: the sample std of the
  // test's value and two twins'. The one-sided 95 % bounds must each hold at least about 95 % of the time.
  const std::vector<double> rates = {1.0, 0.5, 0.25};
  const double q0 = 4.0, c = -0.2, p = 0.55, sd = 0.03;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> z;
  const int trials = 200;
  int below = 0, above = 0, without = 0;
  for (int t = 0; t < trials; ++t) {
    std::vector<double> q = law(rates, q0, c, p);
    for (double& x : q) x += sd * z(rng);
    const std::vector<double> runs = {q[0], q0 + c + sd * z(rng), q0 + c + sd * z(rng)};
    double m = 0.0, ss = 0.0;
    for (const double x : runs) m += x / 3.0;
    for (const double x : runs) ss += (x - m) * (x - m);
    const LadderFit f = fit_ladder(rates, q, std::sqrt(ss / 2.0), 2, 0.05, 400, 100 + t);
    ASSERT_TRUE(std::isfinite(f.distance_lo) && std::isfinite(f.distance_hi));
    below += c < f.distance_lo ? 1 : 0;  // the lower bound above the truth
    above += c > f.distance_hi ? 1 : 0;
    without += (f.order_lo <= p && p <= f.order_hi) ? 0 : 1;
  }
  // each miss rate at most 5 %; 200 trials: allow up to 10 % (binomial 99 % quantile of 200 x 0.05 is 19)
  EXPECT_LE(below, 20) << "lower bound above the true distance in " << below << " of " << trials;
  EXPECT_LE(above, 20) << "upper bound below the true distance in " << above << " of " << trials;
  EXPECT_LE(without, 40) << "the 90 % interval of the order missed it in " << without << " of " << trials;
  // no chaos: no bounds
  const LadderFit none = fit_ladder(rates, law(rates, q0, c, p), 0.0, 2, 0.05);
  EXPECT_TRUE(std::isnan(none.distance_lo));
  EXPECT_NEAR(none.fit.c, c, 1e-8);
}

}  // namespace
}  // namespace celldem
