// A run's own convergence check (`celldem run --verify-rate`): at chosen points of a loading test (the peak of
// s11/s33, the end) the test is run again from a state taken a short window of driving strain before the
// point, at a fraction of its driving rate, and the branch's result at the point is compared with the test's
// own, in units of the seed-to-seed noise floor. A run that is quasi-static enough does not notice its rate
// halved; a run that is too fast does.
//
// The states to branch from are copies of the test's State taken at its rows as it runs (BranchPoints: a short
// ring behind the newest row, and the state one window before the best peak so far), so a branch costs only
// its window. The test's own series and summary are untouched: each branch writes <test>/verify/<point>/.
#pragma once
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/state.hpp"
#include "measure/series.hpp"

namespace celldem {

class RunDirectory;
struct RunOptions;

// What a rate check asks for: the command line's (--verify-rate and its options) or a test's verify_rate key.
// The defaults are the key table's (core/deck_schema.hpp). The window (0.5 % of driving strain) is long enough for
// the branch's rate to set the stresses (the inertial stresses follow the rate within a few hundred steps) and
// short enough to cost a fraction of the test (2 points x 0.5 % at half rate: a third of a 3 % test).
struct VerifyRateOptions {
  bool enabled = false;                           // --verify-rate: every test is checked
  std::vector<std::string> at = {"peak", "end"};  // the points, by name (kVerifyPointNames)
  double window_strain = keys::verify_rate_window_strain.fallback;  // [-] driving strain of each branch
  double rate_factor = keys::verify_rate_rate_factor.fallback;      // the branch's rate over the test's
  double tolerance = 1.0;    // [noise floors] the largest difference of a converged point (a run's --tolerance over it)
  std::string floors_path;   // an ensemble.json or {"ratio13", "ev", "Z"} stds (optionally per test); empty: default
  // Given on the command line: these replace a test's verify_rate values.
  bool at_given = false, window_given = false, factor_given = false;
};

// Names of the points a branch can end at (for the command line's check).
inline const std::vector<std::string> kVerifyPoints(kVerifyPointNames.begin(), kVerifyPointNames.end());

// The rate check of one test: the deck's tests[].verify_rate with the command line's given values over it, or the
// command line's alone (--verify-rate); nullopt when neither asks for one.
std::optional<VerifyRateOptions> verify_rate_for(const VerifyRateOptions& command_line, const TestDef& test);

// UsageError when the check's window is longer than the test's driving strain (the largest strain a leg of the test
// ends at): a branch would start before the test and compare less than it asks for.
void check_verify_window(const VerifyRateOptions& check, const TestDef& test);

// The seed-to-seed standard deviations that make one noise floor of each compared quantity, and where they
// came from (words, for summary.json).
struct NoiseFloors {
  double ratio13 = 0.0;  // s11/s33 (the peak and the window's end)
  double ev = 0.0;       // volumetric strain [-]
  double Z = 0.0;        // coordination number
  std::string source;
};

// The floors of test `test` of a deck of `particles` spheres: from `path` (an ensemble.json, whose
// tests.<test>.{peak_ratio13, ev_final, Z_final}.std it reads, or a JSON of {"ratio13", "ev", "Z"} stds, at the
// top level or under tests.<test>) when given, else the default: the reference ensemble's stds
// (tests/run/reference.json, 16 seeds of 400 spheres, built in) scaled by sqrt(400 / particles). Throws
// UsageError naming the file and key for a floor that is missing or not positive.
NoiseFloors noise_floors(const std::string& path, const std::string& test, int particles);

// The states a test's branches start from, taken at its rows.
class BranchPoints {
 public:
  BranchPoints(const TestDef& test, const Deck& deck, const VerifyRateOptions& options);
  // After each row of the test (`row` as printed): keeps a copy of the state every quarter window of driving
  // strain, drops what is more than a window behind, and pins the branch start of a new largest s11/s33.
  void on_row(const State& state, const SeriesRow& row);
  // A resumed test: the rows read back count (the peak so far among them), and the state it resumes from is the
  // only one kept before them.
  void resume(const State& state, const std::vector<SeriesRow>& rows);

  struct Start {
    std::shared_ptr<const State> state;  // null: no state to branch from
    int leg = -1;                        // the leg the branch drives (the point's)
    int axis = -1;                       // its driving axis (0-based)
    double from_strain = 0.0;            // the driving axis's strain (against the stage start) at the branch start
    double point_strain = 0.0;           // ... at the point
    std::size_t point_row = 0;           // the point's row in the test's series
    std::string missing;                 // with no state: why
  };
  Start peak() const { return peak_; }
  Start end() const;  // from the newest state at least a window before the last row

 private:
  struct Kept {
    std::shared_ptr<const State> state;
    int leg;
    double strain;  // of the leg's driving axis
  };
  Start start_for(int leg, int axis, double strain, std::size_t row) const;
  double window_reached() const { return options_.window_strain * (1.0 - 1e-9); }  // up to round-off

  const TestDef& test_;
  double dt_;
  VerifyRateOptions options_;
  std::vector<Kept> ring_;  // oldest first
  double best_ratio_ = -1.0;
  std::size_t rows_ = 0;
  bool resumed_ = false;
  Start peak_;
  Start last_;
};

// Runs the branches of a finished test (the test's rows as series.csv holds them) and returns summary.json's
// "verify_rate" of the test: per point the window, both values of each quantity, their difference in floors,
// the floors, and the verdict. A branch that fails is recorded as such (its error), not thrown. Without a peak
// (`peak_reached`: summary.json's, s11/s33 largest at the last row) the peak is not checked.
nlohmann::json verify_test_rate(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                                const VerifyRateOptions& check, const BranchPoints& points,
                                const std::vector<SeriesRow>& rows, bool peak_reached);

}  // namespace celldem
