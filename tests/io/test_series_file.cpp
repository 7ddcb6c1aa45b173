// Series files read back (solver/io/series_file.hpp) and what a series alone determines (run/summary's
// summarize_series), on series whose answers are worked out by hand: celldem's own columns or a subset
// of them (another code's run), NaN for what a file lacks, and every malformed file an error naming it.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "helpers.hpp"
#include "io/series_file.hpp"
#include "run/summary.hpp"

namespace celldem {
namespace {

std::filesystem::path write(const testing::TempDir& dir, const std::string& text) {
  const std::filesystem::path path = dir.path() / "series.csv";
  std::ofstream(path) << text;
  return path;
}

TEST(SeriesFile, ReadsColumnsByNameAndLeavesMissingOnesNaN) {
  testing::TempDir dir;
  // Columns in any order, one celldem does not know, an empty field and "nan".
  const auto rows = read_series_file(write(dir, "Z,other,e1,ev,ratio13,b\n6,9,0,0,1,\n5,9,0.01,-0.001,3,nan\n"));
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].e1, 0.01);
  EXPECT_EQ(rows[1].ev, -0.001);
  EXPECT_EQ(rows[1].Z, 5.0);
  EXPECT_EQ(rows[1].ratio13, 3.0);
  EXPECT_TRUE(std::isnan(rows[0].b));
  EXPECT_TRUE(std::isnan(rows[1].b));
  EXPECT_TRUE(std::isnan(rows[1].s22));  // not in the file
}

TEST(SeriesFile, TakesS11OverS33WithoutRatio13) {
  testing::TempDir dir;
  const auto rows = read_series_file(write(dir, "e1,ev,Z,s11,s33\n0,0,6,1e5,1e5\n0.01,0,5,3.5e5,1e5\n"));
  EXPECT_EQ(rows[1].ratio13, 3.5);
}

TEST(SeriesFile, RefusesWhatItCannotRead) {
  testing::TempDir dir;
  auto message = [&](const std::string& text) {
    try {
      read_series_file(write(dir, text));
    } catch (const SeriesFileError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("e1,ev\n0,0\n").find("no column \"Z\""), std::string::npos);
  EXPECT_NE(message("e1,ev,Z\n0,0,6\n").find("nor \"s11\" and \"s33\""), std::string::npos);
  EXPECT_NE(message("e1,ev,Z,ratio13\n0,0,6\n").find("series.csv:2: 3 fields under a header of 4"), std::string::npos);
  EXPECT_NE(message("e1,ev,Z,ratio13\n0,0,6,x1\n").find("column \"ratio13\": \"x1\" is not a number"),
            std::string::npos);
  EXPECT_NE(message("e1,ev,Z,ratio13\n").find("a header and no rows"), std::string::npos);
  EXPECT_NE(message("").find("empty file"), std::string::npos);
  EXPECT_THROW(read_series_file(dir.path() / "missing.csv"), SeriesFileError);
}

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
  EXPECT_TRUE(summarize_series(rows, 0)["b_at_peak"].is_null());
}

}  // namespace
}  // namespace celldem
