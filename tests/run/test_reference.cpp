// The reference deck against reference values taken from a seed ensemble (tests/run/reference.json, made by
// tests/run/make_reference.sh, the one way to regenerate it): the deck's own seed, which is not in the ensemble,
// is one more seed of it. Each quantity gets a two-sided p-value as one more sample (prediction, Student t with
// n - 1 degrees of freedom from Boost.Math), Holm's step-down procedure adjusts the family, and a quantity fails
// when its adjusted p is below the family-wise false-alarm rate stored with the data (0.1 %): the test fails by
// chance on at most one unchanged code in a thousand. Swapping the tests' references (the PSC judged as a TTC,
// the TTC as a PSC) must fail: the reference can tell one test from the other. As LAMMPS's force-style tests
// keep a reference value with its tolerance beside it.
#include <gtest/gtest.h>

#include <algorithm>
#include <boost/math/distributions/students_t.hpp>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>

#include "cli.hpp"
#include "helpers.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// "ttc.end_window.ev" in a summary: tests.ttc.end_window.ev; "prepared.Z": prepared.Z; "paired.ttc-psc.X": the
// same seed's tests.ttc.X - tests.psc.X (as ensemble.json's paired differences). Empty when missing.
std::optional<double> value_of(const Json& summary, const std::string& path) {
  const std::string group = path.substr(0, path.find('.'));
  std::string rest = path.substr(path.find('.') + 1);
  if (group == "paired") {
    const std::string pair = rest.substr(0, rest.find('.'));
    const std::string quantity = rest.substr(rest.find('.') + 1);
    const std::string b = pair.substr(0, pair.find('-')), a = pair.substr(pair.find('-') + 1);
    const auto vb = value_of(summary, b + "." + quantity), va = value_of(summary, a + "." + quantity);
    if (!vb || !va) return std::nullopt;
    return *vb - *va;
  }
  const Json* node = group == "prepared" ? &summary["prepared"] : &summary["tests"][group];
  while (node && !rest.empty()) {
    const auto dot = rest.find('.');
    const std::string key = rest.substr(0, dot);
    node = node->contains(key) ? &(*node)[key] : nullptr;
    rest = dot == std::string::npos ? "" : rest.substr(dot + 1);
  }
  if (!node || !node->is_number()) return std::nullopt;
  return node->get<double>();
}

// Two-sided p of x as one more sample of an ensemble (mean, std, n): t = (x - mean) / (std sqrt(1 + 1/n)).
double prediction_p(double x, const Json& ref) {
  const double n = ref["n"].get<double>();
  const double scale = ref["std"].get<double>() * std::sqrt(1.0 + 1.0 / n);
  if (scale == 0.0) return x == ref["mean"].get<double>() ? 1.0 : 0.0;
  const double t = std::abs(x - ref["mean"].get<double>()) / scale;
  const boost::math::students_t_distribution<double> dist(n - 1.0);
  return 2.0 * boost::math::cdf(boost::math::complement(dist, t));
}

// Holm's step-down procedure: the adjusted p-values (running maximum of (m - k) p_(k), capped at 1).
std::vector<double> holm(const std::vector<double>& p) {
  std::vector<std::size_t> order(p.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p[a] < p[b]; });
  std::vector<double> adjusted(p.size());
  double running = 0.0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    running = std::max(running, std::min(1.0, static_cast<double>(p.size() - k) * p[order[k]]));
    adjusted[order[k]] = running;
  }
  return adjusted;
}

struct Judged {
  std::vector<std::string> names;
  std::vector<double> values, adjusted;
  std::vector<std::string> failed;  // adjusted p below the family's alpha
};

// Judges the values of `summary` against the reference's quantities; `rename` maps a reference quantity's test
// to the summary's (the swap: {"ttc" -> "psc"}); quantities of other groups are left out.
Judged judge(const Json& reference, const Json& summary, const std::map<std::string, std::string>& rename = {}) {
  Judged j;
  std::vector<double> p;
  for (const auto& [path, ref] : reference["values"].items()) {
    std::string where = path;
    const std::string group = path.substr(0, path.find('.'));
    if (!rename.empty()) {
      const auto it = rename.find(group);
      if (it == rename.end()) continue;
      where = it->second + path.substr(group.size());
    }
    const std::optional<double> value = value_of(summary, where);
    EXPECT_TRUE(value.has_value()) << where << " missing from summary.json";
    if (!value) continue;
    j.names.push_back(path + (where == path ? "" : " (from " + where + ")"));
    j.values.push_back(*value);
    p.push_back(prediction_p(*value, ref));
  }
  j.adjusted = holm(p);
  const double alpha = reference["family_alpha"].get<double>();
  for (std::size_t k = 0; k < p.size(); ++k)
    if (j.adjusted[k] < alpha) j.failed.push_back(j.names[k]);
  return j;
}

TEST(Reference, HolmAgainstAWorkedExample) {
  // m = 4: sorted 0.010, 0.015, 0.030, 0.040 -> 0.040, 0.045, 0.060, max(0.060, 0.040) = 0.060.
  const std::vector<double> a = holm({0.030, 0.010, 0.040, 0.015});
  const std::vector<double> want = {0.06, 0.04, 0.06, 0.045};
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k], want[k], 1e-15) << k;
  // one more sample exactly on the 95 % prediction interval's edge: p = 0.05
  const Json ref = {{"mean", 1.0}, {"std", 2.0}, {"n", 8}};
  const double edge = 1.0 + 2.3646242510102993 * 2.0 * std::sqrt(1.125);
  EXPECT_NEAR(prediction_p(edge, ref), 0.05, 1e-9);
}

TEST(Reference, SmallDeckWithinTheEnsembleAndApartFromTheOtherTest) {
  const fs::path here = fs::path(__FILE__).parent_path();
  const Json reference = Json::parse(testing::read_bytes(here / "reference.json"));
  const fs::path dir = testing::test_dir("reference");
  const testing::Result r = testing::celldem(dir, testing::run_args(here / "reference_deck.json", dir / "run", "--quiet"));
  ASSERT_EQ(r.code, 0) << r.err;
  const Json summary = Json::parse(testing::read_bytes(dir / "run" / "summary.json"));
  ASSERT_GE(reference["values"].size(), 6u);
  ASSERT_LE(reference["family_alpha"].get<double>(), 0.001);

  const Judged own = judge(reference, summary);
  for (std::size_t k = 0; k < own.names.size(); ++k)
    EXPECT_GE(own.adjusted[k], reference["family_alpha"].get<double>())
        << own.names[k] << " = " << own.values[k] << " lies outside the reference's prediction interval: mean "
        << reference["values"][own.names[k]]["mean"] << " +- " << reference["values"][own.names[k]]["tolerance"]
        << " (Holm-adjusted p " << own.adjusted[k] << ")";

  // A PSC that behaves like a TTC (and the other way round) would fail: each test's values judged against the
  // other's reference fall outside it.
  const Judged psc_as_ttc = judge(reference, summary, {{"ttc", "psc"}});
  EXPECT_FALSE(psc_as_ttc.failed.empty()) << "the PSC's values pass as a TTC's: the reference cannot tell them apart";
  const Judged ttc_as_psc = judge(reference, summary, {{"psc", "ttc"}});
  EXPECT_FALSE(ttc_as_psc.failed.empty()) << "the TTC's values pass as a PSC's: the reference cannot tell them apart";

  // The sharper case: a PSC whose strength and dilatancy are the TTC's while its boundary conditions still give
  // it its own b (and the other way round) fails the whole family, through its peak and the paired difference.
  ASSERT_TRUE(reference["values"].contains("paired.ttc-psc.peak_robust.ratio13"));
  for (const auto& [like, as] : {std::pair{"ttc", "psc"}, std::pair{"psc", "ttc"}}) {
    Json doctored = summary;
    for (const char* q : {"peak_robust", "end_window"})
      for (const char* key : {"ratio13", "ev"})
        if (summary["tests"][like][q].contains(key)) doctored["tests"][as][q][key] = summary["tests"][like][q][key];
    const Judged j = judge(reference, doctored);
    EXPECT_FALSE(j.failed.empty()) << "a " << as << " with the " << like
                                   << "'s peak and dilatancy passes: the reference cannot tell them apart";
    const bool paired_failed =
        std::find(j.failed.begin(), j.failed.end(), "paired.ttc-psc.peak_robust.ratio13") != j.failed.end();
    EXPECT_TRUE(paired_failed) << "the paired peak difference does not tell a " << as << " from a " << like;
  }
}

}  // namespace
}  // namespace celldem
