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
}

TEST(Ensemble, StatisticsOfFourValues) {
  // mean 2.5; sample variance ((1.5^2 + 0.5^2) * 2) / 3 = 5/3; t(0.975, 3) = 3.182.
  const Json d = describe({1.0, 2.0, 3.0, 4.0});
  EXPECT_EQ(d["n"], 4);
  EXPECT_DOUBLE_EQ(d["mean"].get<double>(), 2.5);
  EXPECT_NEAR(d["std"].get<double>(), std::sqrt(5.0 / 3.0), 1e-15);
  EXPECT_NEAR(d["sem"].get<double>(), std::sqrt(5.0 / 3.0) / 2.0, 1e-15);
  EXPECT_NEAR(d["ci95"][0].get<double>(), 2.5 - 3.182 * std::sqrt(5.0 / 3.0) / 2.0, 1e-12);
  EXPECT_NEAR(d["ci95"][1].get<double>(), 2.5 + 3.182 * std::sqrt(5.0 / 3.0) / 2.0, 1e-12);
  EXPECT_EQ(describe({})["n"], 0);
}

TEST(Ensemble, QuantitiesAndPairedDifferences) {
  const std::vector<Json> summaries = {
      {{"prepared", {{"void_ratio", 0.56}}},
       {"tests", {{"psc", {{"peak_ratio13", 3.8}, {"peak_state", {{"sigma1", 2.0}}}}}, {"ttc", {{"peak_ratio13", 2.9}}}}}},
      {{"prepared", {{"void_ratio", 0.58}}},
       {"tests", {{"psc", {{"peak_ratio13", 3.6}, {"peak_state", {{"sigma1", 4.0}}}}}, {"ttc", {{"peak_ratio13", 2.9}}}}}}};
  const Json e = ensemble_statistics({1, 2}, summaries);
  EXPECT_NEAR(e["prepared"]["void_ratio"]["mean"].get<double>(), 0.57, 1e-15);
  EXPECT_NEAR(e["tests"]["psc"]["peak_ratio13"]["mean"].get<double>(), 3.7, 1e-15);
  EXPECT_DOUBLE_EQ(e["tests"]["psc"]["peak_state.sigma1"]["mean"].get<double>(), 3.0);
  // ttc - psc on each seed: -0.9 and -0.7.
  const Json paired = e["paired"]["ttc-psc"]["peak_ratio13"];
  EXPECT_EQ(paired["n"], 2);
  EXPECT_NEAR(paired["mean"].get<double>(), -0.8, 1e-12);
  EXPECT_FALSE(e["paired"]["ttc-psc"].contains("peak_state.sigma1"));  // only quantities both tests have
}

}  // namespace
}  // namespace celldem
