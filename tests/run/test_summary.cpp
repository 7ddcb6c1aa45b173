// What a series alone determines (run/summary's summarize_series, also `celldem summarize`), on rows whose
// answers are worked out by hand: the peak and its plateau, whether a peak was reached, the end window.
#include <gtest/gtest.h>

#include <cmath>

#include "run/summary.hpp"
#include "run/summary_schema.hpp"

namespace celldem {
namespace {

// Rows every 0.1 % of e1 to 3 %: s11/s33 rises to 3 at 1 %, stays within 1 % of it to 1.2 %, then falls;
// ev and Z linear in e1.
std::vector<SeriesRow> hand_rows() {
  std::vector<SeriesRow> rows;
  for (int k = 0; k <= 30; ++k) {
    SeriesRow r;
    r.e1 = 0.001 * k;
    r.ratio13 = k <= 10 ? 1.0 + 0.2 * k : k <= 12 ? 2.98 : 3.0 - 0.05 * (k - 12);
    r.ev = -0.001 * k;
    r.Z = 6.0 - 0.05 * k;
    r.b = 0.01 * k;
    rows.push_back(r);
  }
  return rows;
}

TEST(SummarizeSeries, PeakPlateauAndEndWindowByHand) {
  const nlohmann::json s = summarize_series(hand_rows(), 0);
  EXPECT_DOUBLE_EQ(s["peak_ratio13"].get<double>(), 3.0);
  EXPECT_DOUBLE_EQ(s["e1_at_peak"].get<double>(), 0.010);
  EXPECT_DOUBLE_EQ(s["b_at_peak"].get<double>(), 0.10);
  // Within 1 % of 3: 2.98 at 1.1 % and 1.2 %, 3.0 at 1 %; 2.95 at 1.3 % is not.
  EXPECT_DOUBLE_EQ(s["e1_peak_range"][0].get<double>(), 0.010);
  EXPECT_DOUBLE_EQ(s["e1_peak_range"][1].get<double>(), 0.012);
  EXPECT_TRUE(s["peak_reached"].get<bool>());
  // The end window: rows with e1 within 0.5 % of 3 %, i.e. 2.5 % .. 3 % (six rows): means of ev and Z.
  EXPECT_NEAR(s["end_window"]["ev"].get<double>(), -0.0275, 1e-12);
  EXPECT_NEAR(s["end_window"]["Z"].get<double>(), 6.0 - 0.05 * 27.5, 1e-12);
  EXPECT_DOUBLE_EQ(s["final_e1"].get<double>(), 0.030);
  EXPECT_DOUBLE_EQ(s["Z_final"].get<double>(), 4.5);
}

TEST(SummarizeSeries, APeakOnTheLastRowIsNoPeak) {
  std::vector<SeriesRow> rows = hand_rows();
  rows.resize(11);  // ends at the top of the rise
  const nlohmann::json s = summarize_series(rows, 0);
  EXPECT_FALSE(s["peak_reached"].get<bool>());
  EXPECT_DOUBLE_EQ(s["e1_at_peak"].get<double>(), 0.010);
}

TEST(SummarizeSeries, NaNIsNull) {
  std::vector<SeriesRow> rows = hand_rows();
  for (SeriesRow& r : rows) r.b = std::nan("");
  EXPECT_FALSE(std::isfinite(summarize_series(rows, 0).b_at_peak));
}

// Every key path of a JSON value, array indices dropped.
void key_paths(const nlohmann::json& j, const std::string& prefix, std::vector<std::string>& out) {
  if (j.is_object())
    for (const auto& [k, v] : j.items()) {
      const std::string p = prefix.empty() ? k : prefix + "." + k;
      out.push_back(p);
      key_paths(v, p, out);
    }
  else if (j.is_array())
    for (const nlohmann::json& v : j) key_paths(v, prefix, out);
}

// A test's summary with every optional record filled: each key its field tables write is in the schema (the
// tables write and list from one list), and a key made up is not.
TEST(SummarySchema, ListsEveryKeyATestSummaryWrites) {
  TestSummary t;
  t.series = summarize_series(hand_rows(), 0);
  t.driven.shear = ShearRecord{};
  t.driven.extension = ExtensionRecord{};
  t.driven.rotation = RotationRecord{};
  t.adaptive_rate = AdaptiveRateRecord{};
  t.control_failures.push_back({});
  LegSummary leg;
  leg.end = LegEndRow{};
  leg.peak = LegPeak{};
  leg.control_errors = to_json(ControlErrors{});
  t.legs.push_back(leg);
  const nlohmann::json written = t;
  std::vector<std::string> paths;
  key_paths(written, "tests.ttc", paths);
  EXPECT_GT(paths.size(), 100u);
  const std::vector<SchemaEntry> schema = summary_schema();
  for (const std::string& p : paths) EXPECT_TRUE(summary_schema_lists(schema, p)) << p;
  EXPECT_FALSE(summary_schema_lists(schema, "tests.ttc.no_such_key"));
  EXPECT_FALSE(summary_schema_lists(schema, "no_such_key"));
  for (const SchemaEntry& e : schema) EXPECT_FALSE(e.doc.empty()) << e.path;
}

// A record with its optional left empty writes no key for it (absent, not null); a Nullable writes null.
TEST(SummarySchema, EmptyOptionalsAreAbsentNullablesNull) {
  SeriesSummary s;
  const nlohmann::json j = s;
  EXPECT_FALSE(j.contains("peak_reached"));
  EXPECT_TRUE(j["peak_robust"].is_null());
  EXPECT_TRUE(j["e1_peak_range"].is_null());
  EXPECT_TRUE(j["peak_ratio13"].is_null());
}

}  // namespace
}  // namespace celldem
