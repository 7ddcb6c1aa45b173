// A test's driven measure and its peak, defined once (run/driven_measure.hpp) and judged by run/summary's
// judge_peak: which measure a test drives, its value at a row, the peak a running tracker finds (the first row of
// the largest, as the summary finds it over the whole series), and the evidence a missed peak names.
#include <gtest/gtest.h>

#include <cmath>

#include "run/driven_measure.hpp"
#include "run/summary.hpp"

namespace celldem {
namespace {

TestDef test_driving(int component, double per_step) {
  TestDef t;
  t.name = "t";
  Leg leg;
  leg.axes[static_cast<std::size_t>(component)] = AxisControl{AxisMode::StrainIncrement, per_step};
  t.legs = {leg};
  return t;
}

// Rows of a simple shear on x12 that holds e1 at 0: |s12|/s22 rises to 0.6 at g12 = 1 %, then falls to 0.5;
// s11/s33 keeps rising (its largest is the last row).
std::vector<SeriesRow> shear_rows() {
  std::vector<SeriesRow> rows;
  for (int k = 0; k <= 20; ++k) {
    SeriesRow r;
    r.g12 = 0.001 * k;
    r.s22 = 1e5;
    r.s12 = -1e5 * (k <= 10 ? 0.06 * k : 0.6 - 0.01 * (k - 10));
    r.s11 = 1e5 * (1.0 + 0.01 * k);
    r.s33 = 1e5;
    r.ratio13 = r.s11 / r.s33;
    rows.push_back(r);
  }
  return rows;
}

TEST(DrivenMeasure, ByTheFastestDrivenComponent) {
  EXPECT_EQ(driven_measure(test_driving(0, 1e-6)).kind, TestMeasure::Kind::Axial);
  EXPECT_EQ(driven_measure(test_driving(0, -1e-6)).kind, TestMeasure::Kind::Extension);
  const TestMeasure shear = driven_measure(test_driving(3, 2e-7));
  EXPECT_EQ(shear.kind, TestMeasure::Kind::Shear);
  EXPECT_EQ(shear.component, 3);
  EXPECT_EQ(measure_name(shear), "|s12|/s22");
  EXPECT_EQ(strain_name(shear), "g12");
  TestDef held;
  held.legs = {Leg{}};
  EXPECT_EQ(driven_measure(held).kind, TestMeasure::Kind::Stress);
  EXPECT_FALSE(driven_measure(held).has_peak());
}

TEST(DrivenMeasure, ValueOfARow) {
  SeriesRow r;
  r.s11 = 3e5, r.s22 = 2e5, r.s33 = 1e5, r.s12 = -5e4, r.ratio13 = 3.0;
  EXPECT_DOUBLE_EQ(driven_value(TestMeasure{}, r), 3.0);
  EXPECT_DOUBLE_EQ(driven_value({TestMeasure::Kind::Extension, 0}, r), 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(driven_value({TestMeasure::Kind::Shear, 3}, r), 0.25);
}

TEST(DrivenMeasure, TrackerFindsTheSummarysPeakRowByRow) {
  const TestMeasure shear{TestMeasure::Kind::Shear, 3};
  const std::vector<SeriesRow> rows = shear_rows();
  PeakTracker tracker(shear);
  std::size_t last_peak = 0;
  for (std::size_t k = 0; k < rows.size(); ++k)
    if (tracker.offer(rows[k])) last_peak = k;
  EXPECT_EQ(last_peak, 10u);
  EXPECT_EQ(peak_row(shear, rows), 10u);
  // s11/s33 would have put the peak at the last row, e1 0: the bug of a shear's peak point before.
  EXPECT_EQ(peak_row(TestMeasure{}, rows), rows.size() - 1);
  // Resumed after every row: only a row above all of them is a new peak.
  PeakTracker resumed(shear);
  resumed.seen(rows);
  EXPECT_FALSE(resumed.offer(rows[10]));
}

TEST(JudgePeak, AShearIsJudgedOnItsOwnMeasure) {
  const std::vector<SeriesRow> rows = shear_rows();
  const PeakJudgement j = judge_peak({TestMeasure::Kind::Shear, 3}, rows);
  EXPECT_TRUE(j.reached);
  EXPECT_EQ(j.row, 10u);
  EXPECT_DOUBLE_EQ(j.value, 0.6);
  EXPECT_DOUBLE_EQ(j.strain, 0.010);
  // Cut at the top: no peak, and the evidence names the measure and the row.
  std::vector<SeriesRow> cut(rows.begin(), rows.begin() + 11);
  const PeakJudgement none = judge_peak({TestMeasure::Kind::Shear, 3}, cut);
  EXPECT_FALSE(none.reached);
  EXPECT_NE(none.evidence.find("|s12|/s22 is largest"), std::string::npos) << none.evidence;
  EXPECT_NE(none.evidence.find("last row"), std::string::npos) << none.evidence;
}

TEST(JudgePeak, AnAxialOneOnTheSmoothedPlateauAsTheSummary) {
  // s11/s33 rises, peaks at row 10 and stays within 1 % of it to the end: the raw largest is not the last row, but
  // the smoothed plateau runs to the end, so no peak; the evidence says so.
  std::vector<SeriesRow> rows;
  for (int k = 0; k <= 30; ++k) {
    SeriesRow r;
    r.e1 = 0.001 * k;
    r.ratio13 = k <= 10 ? 1.0 + 0.2 * k : 2.995;
    rows.push_back(r);
  }
  const PeakJudgement j = judge_peak(TestMeasure{}, rows);
  EXPECT_FALSE(j.reached);
  EXPECT_EQ(j.row, 10u);
  EXPECT_EQ(summarize_series(rows, 0).peak_reached.value(), j.reached);
  EXPECT_NE(j.evidence.find("smoothed"), std::string::npos) << j.evidence;
  EXPECT_NE(j.evidence.find("to the test's last row"), std::string::npos) << j.evidence;
}

}  // namespace
}  // namespace celldem
