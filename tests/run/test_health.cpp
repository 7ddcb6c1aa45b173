// The health checks' rules on their own (solver/run/health.hpp): the largest control error over every kind of
// control, failed controls as records with their kind and tolerance, and a non-finite row named by its column.
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

TEST(Health, ControlErrorMaximaKeepEachUnitAndNaNWhenNothingWasMeasured) {
  for (const auto& errors : {std::vector<ControlErrors>{}, std::vector<ControlErrors>{{}, {}}}) {  // a hold leg
    const ControlErrorMaxima m = control_error_maxima(errors);
    EXPECT_TRUE(std::isnan(m.servo) && std::isnan(m.b) && std::isnan(m.volume) && std::isnan(m.over_tolerance));
  }
  ControlErrors stress, b;
  stress.stress = 0.003;
  b.b = 0.008, b.mean_stress = 0.001;  // b is absolute: never mixed into the servo's fraction
  ControlErrorMaxima m = control_error_maxima({stress, b});
  EXPECT_EQ(m.servo, 0.003);
  EXPECT_EQ(m.b, 0.008);
  EXPECT_TRUE(std::isnan(m.volume));
  EXPECT_DOUBLE_EQ(m.over_tolerance, 0.8);  // b: 0.008 of 0.01, the closest to its tolerance
  ControlErrors volume;
  volume.volume = 2e-6;
  m = control_error_maxima({stress, ControlErrors{}, volume});
  EXPECT_EQ(m.volume, 2e-6);
  EXPECT_DOUBLE_EQ(m.over_tolerance, 2.0);
}

TEST(Health, ControlFailuresNameLegAxisKindAndTolerance) {
  const TestDef test = three_axis_test(AxisMode::StrainIncrement, AxisMode::B, AxisMode::MeanStress);
  std::vector<ControlErrors> errors(2);
  errors[1].failed[1] = true, errors[1].axis_error[1] = 0.3;
  errors[1].failed[2] = true, errors[1].axis_error[2] = 0.04;
  const std::vector<ControlFailureRecord> f = control_failures(test, errors);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_EQ(f[0].leg, 1u);
  EXPECT_EQ(f[0].axis, 1);
  EXPECT_EQ(f[0].kind, "b");
  EXPECT_EQ(f[0].tolerance, kBTolerance);
  EXPECT_EQ(f[0].error, 0.3);
  EXPECT_EQ(f[1].kind, "mean_stress");
  EXPECT_EQ(f[1].tolerance, kMeanStressTolerance);
  // A warning per failure (control_failure "warn"), naming the test.
  const std::vector<std::string> w = control_warnings(test, errors);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NE(w[0].find("'test'"), std::string::npos) << w[0];
  EXPECT_TRUE(control_failures(test, std::vector<ControlErrors>(2)).empty());
}

// A shear stress axis's failure (axis 3 + 0..2: x12, x13, x23) is named by its axis and kind, and its error
// enters the maxima as a servo error; its record round-trips through summary.json's shear_axes.
TEST(Health, ShearStressControlFailuresNameTheShearAxis) {
  TestDef test = three_axis_test(AxisMode::StrainIncrement, AxisMode::Stress, AxisMode::Stress);
  for (Leg& leg : test.legs) leg.shear[1] = AxisControl{AxisMode::Stress, 0.0};
  std::vector<ControlErrors> errors(test.legs.size());
  ControlErrors& e = errors.back();
  e.failed[4] = true, e.axis_error[4] = 0.02, e.shear_stress = 0.02, e.over_steps[4] = 600, e.saturated_steps[4] = 7;
  const std::vector<ControlFailureRecord> f = control_failures(test, errors);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].axis, 4);
  EXPECT_EQ(f[0].kind, "shear_stress");
  EXPECT_EQ(f[0].tolerance, kServoTolerance);
  EXPECT_EQ(control_axis_name(f[0].axis), "x13");
  const std::vector<std::string> w = control_warnings(test, errors);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("axis x13"), std::string::npos) << w[0];
  EXPECT_EQ(control_error_maxima(errors).servo, 0.02);
  EXPECT_DOUBLE_EQ(control_error_maxima(errors).over_tolerance, 0.02 / kServoTolerance);
  const nlohmann::json j = to_json(e);
  ASSERT_TRUE(j.contains("shear_axes"));
  const ControlErrors back = control_errors_from_json(j);
  EXPECT_EQ(back.shear_stress, 0.02);
  EXPECT_TRUE(back.failed[4]);
  EXPECT_EQ(back.over_steps[4], 600);
  EXPECT_EQ(back.saturated_steps[4], 7);
  EXPECT_FALSE(to_json(ControlErrors{}).contains("shear_axes"));  // legs without shear stress axes as before
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
