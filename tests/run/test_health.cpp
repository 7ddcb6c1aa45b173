// The health checks' rules on their own (solver/run/health.hpp): the inertial number's warning and a non-finite
// row named by its column. (The controls' verdict: test_control_verdict.cpp.)
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "run/health.hpp"
#include "run/runner.hpp"

namespace celldem {
namespace {

TestDef three_axis_test(AxisMode x1, AxisMode x2, AxisMode x3) {
  TestDef t;
  t.name = std::string("test");  // (from a literal directly, GCC 12 warns falsely of overlapping memcpy)
  Leg leg;
  leg.axes[0].mode = x1, leg.axes[1].mode = x2, leg.axes[2].mode = x3;
  t.legs = {leg, leg};
  return t;
}

TEST(Health, InertialNumberAboveTheQuasiStaticLimitIsAWarning) {
  const TestDef test = three_axis_test(AxisMode::StrainIncrement, AxisMode::Stress, AxisMode::Stress);
  EXPECT_TRUE(test_warnings(test, 9e-4).empty());
  ASSERT_EQ(test_warnings(test, 2e-3).size(), 1u);
  EXPECT_NE(test_warnings(test, 2e-3)[0].find("inertial number"), std::string::npos);
}

TEST(Health, ANonFiniteRowNamesItsColumnStageAndStep) {
  SeriesRow row;
  row.b = std::numeric_limits<double>::quiet_NaN();  // b is nan by design while s1 - s3 is noise
  EXPECT_NO_THROW(check_row_finite(row, "ttc", 10));
  row.s22 = std::numeric_limits<double>::infinity();
  try {
    check_row_finite(row, "ttc", 10);
    FAIL() << "no error for an infinite s22";
  } catch (const RunError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("s22"), std::string::npos) << m;
    EXPECT_NE(m.find("ttc"), std::string::npos) << m;
    EXPECT_NE(m.find("10"), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace celldem
