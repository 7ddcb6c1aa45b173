// Series files read back (solver/io/series_file.hpp): celldem's own columns or a subset of them (another code's
// run), NaN for what a file lacks, and every malformed file an error naming it.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "helpers.hpp"
#include "io/series_file.hpp"

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

}  // namespace
}  // namespace celldem
