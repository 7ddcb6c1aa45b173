// Health checks of a running stage: an explicit scheme out of its stable range, a test that is not quasi-
// static, a servo that misses its targets, a time step too close to the stability limit.
#pragma once
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "measure/series.hpp"

namespace celldem {

inline constexpr double kMaxStepMotion = 0.05;       // runaway: a particle moving 5 % of its radius in one step
inline constexpr double kMaxKineticToElastic = 0.5;  // runaway in a test: kinetic energy above half the elastic
// A loaded state whose deepest overlap exceeds this fraction of the smaller radius (10 x a packing's at its
// stress) releases enough energy to look like an unstable time step: a runaway then names the overlaps.
inline constexpr double kLoadedOverlapNote = 0.01;
inline constexpr double kServoTolerance = 0.005;     // stress-controlled axes should stay within 0.5 % of target
inline constexpr double kBTolerance = 0.01;           // a b axis within 0.01 of its b
inline constexpr double kMeanStressTolerance = 0.005; // the mean stress within 0.5 %
inline constexpr double kVolumeTolerance = 1e-6;      // constant volume within 1e-6 relative

// A loading test is no longer quasi-static when, at kQuasiStaticRows rows in a row after its first
// kQuasiStaticSettleRows rows, its unbalanced force ratio exceeds kMaxQuasiStaticUnbalanced and its kinetic
// energy kMaxQuasiStaticKineticToElastic of the elastic energy. Measured past the first 5 rows: the shipped
// decks (paper, fast, balanced, failure_surface, rolling on 1000 spheres to e1 = 2 %; small_run,
// reference_deck) stay within 0.0004-0.0075 and 5e-6-0.0024; the test suite's 300-sphere samples reach 0.073
// and 0.0043, 0.012 when loaded too fast (inertial number above 1e-3: a warning, not a stop). A boiling sample
// (kt = 10 kn at dt = 0.49 sqrt(m/kn), 2.9 times the tangential-rotational limit) sits at 0.39-0.46 and 0.14;
// one at 0.96 of the normal mode's limit (kt = kn / 10) at 0.41 and 0.037.
inline constexpr double kMaxQuasiStaticUnbalanced = 0.2;
inline constexpr double kMaxQuasiStaticKineticToElastic = 0.02;
inline constexpr int kQuasiStaticSettleRows = 5;
// A packing that misses equilibrium within this fraction of its target pressure is held at it: a high
// unbalanced force ratio there (above kMaxQuasiStaticUnbalanced) means it boils, not that it is still loose.
// 5 %: a loose packing on its way to the pressure is further off (the fast leg ends at 45 % solids, well below
// it), while a boiling one sits within the servo's tolerance of it.
inline constexpr double kHeldAtPressure = 0.05;
inline constexpr int kQuasiStaticRows = 5;

// What a test that stops being quasi-static most likely suffers from: a time step close to the limit of the
// stiffest mode, or a loading too fast for its inertial number; both named when neither stands out.
std::string not_quasi_static_cause(const Deck& deck, const TestDef& test);

// Checked at every series row, on the row's contact measures; throws RunError naming the cause and the step.
class RunawayMonitor {
 public:
  // check_energy: loading tests only (a preparation starts as a gas). quasi_static_cause: a loading test that
  // must stay quasi-static (not declared dynamic), with the likely cause when it does not; empty: not checked.
  RunawayMonitor(std::string stage, bool check_energy, std::string quasi_static_cause = "")
      : stage_(std::move(stage)), check_energy_(check_energy), quasi_static_cause_(std::move(quasi_static_cause)) {}
  void check(const Model& model, const State& state, const ContactMeasures& contacts);
  // A stage that starts from a loaded state with overlaps well above a packing's: a runaway names them first.
  void set_start_cause(std::string cause) { start_cause_ = std::move(cause); }

 private:
  std::string stage_;
  std::string start_cause_;
  bool check_energy_;
  std::string quasi_static_cause_;
  double previous_kinetic_energy_ = -1.0;  // at the last row; negative: no row yet
  int rows_ = 0;                           // rows checked in this stage (since the start or a resume)
  int dynamic_rows_ = 0;                   // consecutive rows past both quasi-static limits
};

// Stops the run when a row holds non-finite values in a column that must be finite.
void check_row_finite(const SeriesRow& row, const std::string& stage, std::int64_t step);

// Warnings about a finished test (inertial number), and about a deck before it runs.
std::vector<std::string> test_warnings(const TestDef& test, double inertial_number);
std::vector<std::string> deck_warnings(const Deck& deck);

}  // namespace celldem
