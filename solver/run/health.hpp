// Health checks of a running stage: an explicit scheme out of its stable range, a test that is not quasi-
// static, a servo that misses its targets, a time step too close to the stability limit.
#pragma once
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "measure/series.hpp"
#include "run/program.hpp"

namespace celldem {

inline constexpr double kMaxStepMotion = 0.05;       // runaway: a particle moving 5 % of its radius in one step
inline constexpr double kMaxKineticToElastic = 0.5;  // runaway in a test: kinetic energy above half the elastic
inline constexpr double kServoTolerance = 0.005;     // stress-controlled axes should stay within 0.5 % of target
inline constexpr double kBTolerance = 0.01;           // a b axis within 0.01 of its b
inline constexpr double kMeanStressTolerance = 0.005; // the mean stress within 0.5 %
inline constexpr double kVolumeTolerance = 1e-6;      // constant volume within 1e-6 relative

// Checked at every series row; throws RunError naming the cause and the step.
class RunawayMonitor {
 public:
  // check_energy: loading tests only (a preparation starts as a gas).
  RunawayMonitor(std::string stage, bool check_energy) : stage_(std::move(stage)), check_energy_(check_energy) {}
  void check(const Model& model, const State& state);

 private:
  std::string stage_;
  bool check_energy_;
  double previous_kinetic_energy_ = -1.0;  // at the last row; negative: no row yet
};

// Stops the run when a row holds non-finite values in a column that must be finite.
void check_row_finite(const SeriesRow& row, const std::string& stage, std::int64_t step);

// The largest control error of the test over its legs, measured every step after each leg's settle window
// (ControlErrors): of every kind, relative for stress, mean stress and volume, absolute for b. NaN when
// nothing was measured.
double servo_max_error(const std::vector<ControlErrors>& errors);

// One control of a test that failed (stayed outside its tolerance, program.hpp kPersistStrain).
struct ControlFailureRecord {
  std::size_t leg = 0;
  int axis = 0;          // 0-based
  std::string kind;      // stress, mean_stress, b, volume
  double error = 0.0;    // the worst error of the control in the leg
  double tolerance = 0.0;
};
std::vector<ControlFailureRecord> control_failures(const TestDef& test, const std::vector<ControlErrors>& errors);

// Warnings about a finished test (inertial number), and about a deck before it runs.
std::vector<std::string> test_warnings(const TestDef& test, double inertial_number);
std::vector<std::string> deck_warnings(const Deck& deck);
// The test's failed controls (with control_failure "warn"; "stop" ends the stage instead).
std::vector<std::string> control_warnings(const TestDef& test, const std::vector<ControlErrors>& errors);

}  // namespace celldem
