// One row of series.csv (solver/measure/series_row.hpp): the dilatancy window's slope, the header, the row
// formatting, and a row measured on a lattice whose values are known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "contact/contact_forces.hpp"
#include "helpers.hpp"
#include "measure/series_row.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {

int column(const std::string& name) {
  const auto& c = series_columns();
  for (std::size_t k = 0; k < c.size(); ++k)
    if (c[k] == name) return static_cast<int>(k);
  ADD_FAILURE() << "no column " << name;
  return -1;
}

// ev = 0.3 - 0.4 e1 (dilating as e1 grows): DI = -d(ev)/d(e1) = 0.4, once the window spans half its width.
TEST(DilatancyWindow, SlopeOfLinearSeries) {
  const double width = 0.01;
  DilatancyWindow w(width);
  int nan_rows = 0;
  for (int k = 0; k <= 100; ++k) {
    const double e1 = k * 1e-3;
    const double di = w.add(e1, 0.3 - 0.4 * e1);
    if (e1 < 0.5 * width - 1e-12) {
      EXPECT_TRUE(std::isnan(di)) << "e1 " << e1;
      ++nan_rows;
    } else {
      EXPECT_NEAR(di, 0.4, 1e-9) << "e1 " << e1;
    }
  }
  EXPECT_EQ(nan_rows, 5);
}

// The window forgets rows older than its width: after a kink, the slope becomes the new one exactly once
// the window has passed the kink.
TEST(DilatancyWindow, ForgetsRowsOutsideWindow) {
  const double width = 0.004;
  DilatancyWindow w(width);
  double last = 0.0;
  for (int k = 0; k <= 200; ++k) {
    const double e1 = k * 1e-4;
    const double ev = e1 < 0.01 ? 0.5 * e1 : 0.005 - 0.2 * (e1 - 0.01);  // compaction, then dilation
    last = w.add(e1, ev);
    if (k == 99) { EXPECT_NEAR(last, -0.5, 1e-9); }
    if (e1 > 0.01 + width + 1e-9) { EXPECT_NEAR(last, 0.2, 1e-9) << "e1 " << e1; }
  }
  EXPECT_NEAR(last, 0.2, 1e-9);
  w.clear();
  EXPECT_TRUE(std::isnan(w.add(0.5, 0.1)));
}

// Extension along x1 (a test driven by a negative strain increment, which the deck allows): e1 decreases.
// DI = -d(ev)/d(e1) is defined just the same; here ev = 0.1 + 0.3 e1, so DI = -0.3 once the window (which
// now trails on the other side of the current e1) spans half its width.
TEST(DilatancyWindow, SlopeWhenE1Decreases) {
  DilatancyWindow w(0.01);
  double last = 0.0;
  for (int k = 0; k <= 100; ++k) {
    const double e1 = -k * 1e-3;
    last = w.add(e1, 0.1 + 0.3 * e1);
  }
  EXPECT_NEAR(last, -0.3, 1e-9);
}

TEST(SeriesRow, HeaderIsTheColumnList) {
  const auto& c = series_columns();
  ASSERT_FALSE(c.empty());
  std::string joined;
  for (const auto& name : c) joined += (joined.empty() ? "" : ",") + name;
  EXPECT_EQ(series_header(), joined + "\n");
  EXPECT_EQ(series_header().rfind("step,time,e1,e2,e3,ev,s11,s22,s33", 0), 0u);
  EXPECT_EQ(c[22], "n_contacts");  // formatted as counts
  EXPECT_EQ(c[23], "n_strong");
}

TEST(SeriesRow, FormatsCountsAndNaN) {
  std::vector<double> row(series_columns().size(), 0.125);
  row[0] = 1000;
  row[17] = std::nan("");
  row[22] = 192;
  const std::string line = format_series_row(row);
  EXPECT_EQ(line.back(), '\n');
  EXPECT_EQ(line.rfind("1000,0.125,", 0), 0u);
  EXPECT_NE(line.find(",nan,"), std::string::npos);
  EXPECT_NE(line.find(",192,"), std::string::npos);
  EXPECT_EQ(std::count(line.begin(), line.end(), ','), static_cast<long>(row.size() - 1));
}

// A simple cubic lattice (spacing a, overlap delta = 2R - a): p = s_ii = kn delta / a^2, q = 0, Z = 6, fabric
// I/3, 3N contacts, no strain yet.
TEST(SeriesRow, LatticeRowHasKnownValues) {
  const int n = 4;
  const double R = 0.5, a = 0.98, kn = 1e4, dt = 1e-4;
  const Model model = make_model(testing::model_deck(kn, kn, dt), std::vector<double>(n * n * n, R));
  State s = testing::lattice_state(n, R, Vec3(a, a, a), 0.05);
  s.control.stage_step = 250;
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  DilatancyWindow di(0.0025);
  const std::vector<double> row = measure_series_row(model, s, di);
  ASSERT_EQ(row.size(), series_columns().size());
  const double p = kn * (2 * R - a) / (a * a);
  EXPECT_EQ(row[column("step")], 250.0);
  EXPECT_NEAR(row[column("time")], 250 * dt, 1e-15);
  for (const char* e : {"e1", "e2", "e3", "ev"}) EXPECT_NEAR(row[column(e)], 0.0, 1e-15) << e;
  for (const char* c : {"s11", "s22", "s33", "p"}) EXPECT_NEAR(row[column(c)], p, 1e-9 * p) << c;
  for (const char* c : {"s12", "s13", "s23"}) EXPECT_NEAR(row[column(c)], 0.0, 1e-9 * p) << c;
  EXPECT_NEAR(row[column("q")], 0.0, 1e-9 * p);
  EXPECT_NEAR(row[column("ratio13")], 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(row[column("DI")]));
  EXPECT_EQ(row[column("Z")], 6.0);
  EXPECT_EQ(row[column("Zm")], 6.0);
  EXPECT_EQ(row[column("n_contacts")], 3.0 * n * n * n);
  // (Which of the equal forces count as "strong" is decided by rounding: not checked here.)
  for (const char* h : {"H11", "H22", "H33"}) EXPECT_NEAR(row[column(h)], 1.0 / 3, 1e-12) << h;
  for (const char* h : {"H12", "H13", "H23"}) EXPECT_NEAR(row[column(h)], 0.0, 1e-12) << h;
  EXPECT_NEAR(row[column("H11_H33")], 1.0, 1e-12);
  EXPECT_NEAR(row[column("void_ratio")], a * a * a / (4.0 / 3.0 * M_PI * R * R * R) - 1.0, 1e-12);
  EXPECT_EQ(row[column("sliding_fraction")], 0.0);
  EXPECT_EQ(row[column("kinetic_energy")], 0.0);
}

// Strains in the row are engineering strains of the cell against the stage start, compression positive.
TEST(SeriesRow, StrainsAgainstStageStart) {
  const Model model = make_model(testing::model_deck(1e4, 1e4, 1e-4), std::vector<double>(27, 0.5));
  State s = testing::lattice_state(3, 0.5, Vec3(1.2, 1.2, 1.2), 0.05);  // nothing touches
  s.cell.h = Vec3(3.6 * 0.99, 3.6 * 1.02, 3.6).asDiagonal();
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  DilatancyWindow di(0.0025);
  const std::vector<double> row = measure_series_row(model, s, di);
  EXPECT_NEAR(row[column("e1")], 0.01, 1e-14);
  EXPECT_NEAR(row[column("e2")], -0.02, 1e-14);
  EXPECT_NEAR(row[column("e3")], 0.0, 1e-14);
  EXPECT_NEAR(row[column("ev")], 1.0 - 0.99 * 1.02, 1e-14);
  EXPECT_EQ(row[column("n_contacts")], 0.0);
  EXPECT_EQ(row[column("unbalanced_force")], 0.0);
}

}  // namespace
}  // namespace celldem
