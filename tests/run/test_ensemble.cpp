// Seed ensembles (solver/run/ensemble.hpp): the seed list, the statistics against values worked by hand,
// and the paired differences of two tests on the same seeds.
#include <gtest/gtest.h>

#include <cmath>

#include "run/ensemble.hpp"

namespace celldem {
namespace {

using Json = nlohmann::json;

TEST(Ensemble, SeedLists) {
  EXPECT_EQ(parse_seed_list("1-3,5,3"), (std::vector<std::uint64_t>{1, 2, 3, 5}));
  EXPECT_EQ(parse_seed_list("7,2"), (std::vector<std::uint64_t>{7, 2}));
  for (const char* bad : {"", "1", "3-1", "a-b", "1-", "1,x", "2.5,3"}) EXPECT_THROW(parse_seed_list(bad), DeckError) << bad;
  EXPECT_EQ(parse_seed_list("3", /*allow_one=*/true), (std::vector<std::uint64_t>{3}));  // a job array's share
  EXPECT_EQ(parse_seed_list("3-3", /*allow_one=*/true), (std::vector<std::uint64_t>{3}));
  EXPECT_THROW(parse_seed_list("", /*allow_one=*/true), DeckError);
}

TEST(Ensemble, StatisticsOfFourValues) {
  // mean 2.5; sample variance ((1.5^2 + 0.5^2) * 2) / 3 = 5/3; t(0.975, 3) = 3.182446305284263.
  const Json d = describe({1.0, 2.0, 3.0, 4.0});
  EXPECT_EQ(d["n"], 4);
  EXPECT_DOUBLE_EQ(d["mean"].get<double>(), 2.5);
  EXPECT_NEAR(d["std"].get<double>(), std::sqrt(5.0 / 3.0), 1e-15);
  EXPECT_NEAR(d["sem"].get<double>(), std::sqrt(5.0 / 3.0) / 2.0, 1e-15);
  const double t = 3.182446305284263, sd = std::sqrt(5.0 / 3.0);
  EXPECT_NEAR(d["ci95"][0].get<double>(), 2.5 - t * sd / 2.0, 1e-9);
  EXPECT_NEAR(d["ci95"][1].get<double>(), 2.5 + t * sd / 2.0, 1e-9);
  // one more sample: t s sqrt(1 + 1/n)
  EXPECT_NEAR(d["pi95"][0].get<double>(), 2.5 - t * sd * std::sqrt(1.25), 1e-9);
  EXPECT_NEAR(d["pi95"][1].get<double>(), 2.5 + t * sd * std::sqrt(1.25), 1e-9);
  EXPECT_EQ(describe({})["n"], 0);
}

TEST(Ensemble, StudentQuantilesFromBoost) {
  // Reference values from SciPy 1.10's t.ppf, which agrees with Boost.Math to about 1e-8.
  EXPECT_NEAR(student_t_quantile(0.975, 7), 2.3646242510102993, 1e-8);
  EXPECT_NEAR(student_t_quantile(0.975, 40), 2.0210753829953374, 2e-8);  // not 1.96 past 30 dof
  EXPECT_NEAR(student_t_quantile(0.9995, 7), 5.407882520977668, 1e-8);
}

TEST(Ensemble, UncontrolledTestsAndMissingPeaksLeftOut) {
  const Json ok = {{"peak_ratio13", 3.0}, {"end_window", {{"ev", 0.01}}}};
  Json uncontrolled = {{"peak_ratio13", 9.0}, {"end_window", {{"ev", 0.5}}}, {"controlled", false}};
  Json no_peak = {{"peak_ratio13", 7.0}, {"b_at_peak", 0.9}, {"end_window", {{"ev", 0.03}}}, {"peak_reached", false}};
  const std::vector<Json> summaries = {{{"tests", {{"psc", ok}, {"ttc", ok}}}},
                                       {{"tests", {{"psc", uncontrolled}, {"ttc", no_peak}}}},
                                       {{"tests", {{"psc", ok}, {"ttc", ok}}}}};
  const Json e = ensemble_statistics({1, 2, 3}, summaries);
  EXPECT_EQ(e["tests"]["psc"]["peak_ratio13"]["n"], 2);
  EXPECT_DOUBLE_EQ(e["tests"]["psc"]["end_window.ev"]["mean"].get<double>(), 0.01);
  EXPECT_EQ(e["tests"]["ttc"]["peak_ratio13"]["n"], 2);      // the no-peak seed's peak left out
  EXPECT_EQ(e["tests"]["ttc"]["end_window.ev"]["n"], 3);     // its other quantities kept
  EXPECT_FALSE(e["tests"]["ttc"].contains("b_at_peak"));
  EXPECT_EQ(e["paired"]["ttc-psc"]["end_window.ev"]["n"], 2);  // seed 2's psc is out of the pairs too
  EXPECT_EQ(e["excluded"]["tests"]["psc"]["uncontrolled"], Json::array({2}));
  EXPECT_EQ(e["excluded"]["tests"]["ttc"]["no_peak"], Json::array({2}));
  const Json all = ensemble_statistics({1, 2, 3}, summaries, true);
  EXPECT_EQ(all["tests"]["psc"]["peak_ratio13"]["n"], 3);
  EXPECT_TRUE(all["excluded"]["tests"]["psc"]["uncontrolled"].empty());
}

TEST(Ensemble, QuantitiesAndPairedDifferences) {
  const std::vector<Json> summaries = {
      {{"prepared", {{"void_ratio", 0.56}}},
       {"tests", {{"psc", {{"peak_ratio13", 3.8}, {"peak_state", {{"sigma1", 2.0}}}}},
                  {"ttc", {{"peak_ratio13", 2.9}, {"verify_rate", {{"tolerance_floors", 1.0}}}}}}}},
      {{"prepared", {{"void_ratio", 0.58}}},
       {"tests", {{"psc", {{"peak_ratio13", 3.6}, {"peak_state", {{"sigma1", 4.0}}}, {"verify_rate", {{"tolerance_floors", 2.0}}}}},
                  {"ttc", {{"peak_ratio13", 2.9}, {"verify_rate", {{"tolerance_floors", 1.0}}}}}}}}};
  const Json e = ensemble_statistics({1, 2}, summaries);
  EXPECT_NEAR(e["prepared"]["void_ratio"]["mean"].get<double>(), 0.57, 1e-15);
  EXPECT_NEAR(e["tests"]["psc"]["peak_ratio13"]["mean"].get<double>(), 3.7, 1e-15);
  EXPECT_DOUBLE_EQ(e["tests"]["psc"]["peak_state.sigma1"]["mean"].get<double>(), 3.0);
  // ttc - psc on each seed: -0.9 and -0.7.
  const Json paired = e["paired"]["ttc-psc"]["peak_ratio13"];
  EXPECT_EQ(paired["n"], 2);
  EXPECT_NEAR(paired["mean"].get<double>(), -0.8, 1e-12);
  EXPECT_FALSE(e["paired"]["ttc-psc"].contains("peak_state.sigma1"));  // only quantities both tests have
  // the rate check's settings are described per test but not differenced (seed 2 has both tests' check)
  EXPECT_EQ(e["tests"]["ttc"]["verify_rate.tolerance_floors"]["n"], 2);
  EXPECT_FALSE(e["paired"]["ttc-psc"].contains("verify_rate.tolerance_floors"));
}

// --tolerance's check after each test, over the seeds: each seed counted as kept, not kept (named) or not checked,
// and its numbers not differenced between tests.
TEST(Ensemble, TheToleranceCheckIsCountedOverTheSeeds) {
  const auto test = [](Json kept) {
    return Json{{"peak_ratio13", 3.0}, {"tolerance", {{"kept", kept}, {"inertial_number", 1e-4}}}};
  };
  const std::vector<Json> summaries = {{{"tests", {{"ttc", test(true)}, {"psc", test(true)}}}},
                                       {{"tests", {{"ttc", test(false)}, {"psc", test(true)}}}},
                                       {{"tests", {{"ttc", test(nullptr)}, {"psc", test(true)}}}}};
  const Json e = ensemble_statistics({4, 5, 6}, summaries);
  EXPECT_EQ(e["tolerance"]["ttc"]["seeds"], 3);
  EXPECT_EQ(e["tolerance"]["ttc"]["kept"], 1);
  EXPECT_EQ(e["tolerance"]["ttc"]["not_kept"], Json::array({5}));
  EXPECT_EQ(e["tolerance"]["ttc"]["not_checked"], Json::array({6}));
  EXPECT_EQ(e["tolerance"]["psc"]["kept"], 3);
  EXPECT_FALSE(e["paired"]["ttc-psc"].contains("tolerance.inertial_number"));
  EXPECT_FALSE(ensemble_statistics({1}, {{{"tests", {{"ttc", {{"peak_ratio13", 3.0}}}}}}}).contains("tolerance"));
}

}  // namespace
}  // namespace celldem
