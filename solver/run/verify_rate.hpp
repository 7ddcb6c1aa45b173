// A run's own convergence check (`celldem run --verify-rate`): the test is run again from the same starting state
// (the prepared sample) over its whole path at a fraction of its driving rate (half by default), and each summary
// quantity of the two runs is compared in units of the seed-to-seed noise floor. A twin (the same test from the same
// state at 1.001 times its rate: a change whose own effect is negligible, but which parts the two runs from the
// first step as the slower run does) measures what chaos alone makes of one pair of runs, and the verdict accounts
// for it at a stated confidence:
//   converged      the rate's effect is within the tolerance T at 95 % (|d| + c s <= T; both one-sided tests of
//                  TOST reject |effect| >= T),
//   not converged  the effect is beyond T at 95 % (|d| - c s > T),
//   unresolved     the rest,
// with d the difference (test - slower run) in floors, s the chaos of one pair in floors and c its one-sided 95 %
// quantile. Across an ensemble's seeds the mean paired difference is judged the same way by TOST on the seeds
// (rate_check_across_seeds). The test's own series and summary are untouched: the runs write <test>/verify/<run>/.
#pragma once
#include <cstdint>
#include <optional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/state.hpp"
#include "run/summary.hpp"

namespace celldem {

class RunDirectory;
struct RunOptions;

// What a rate check asks for: the command line's (--verify-rate and its options) or a test's verify_rate key.
// The defaults are the key table's (core/deck_schema.hpp).
struct VerifyRateOptions {
  bool enabled = false;                                         // --verify-rate: every test is checked
  double rate_factor = keys::verify_rate_rate_factor.fallback;  // the slower run's rate over the test's
  bool twin = true;          // run the twin (false: the chaos of a pair is taken at its bound, sqrt 2 floors)
  double tolerance = 1.0;    // [noise floors] the largest effect of a converged quantity (a run's --tolerance over it)
  std::string floors_path;   // an ensemble.json or {"ratio13", "ev", "Z"} stds (optionally per test); empty: default
  // Given on the command line: these replace a test's verify_rate values.
  bool factor_given = false, twin_given = false;
};

// The rate check of one test: the deck's tests[].verify_rate with the command line's given values over it, or the
// command line's alone (--verify-rate); nullopt when neither asks for one.
std::optional<VerifyRateOptions> verify_rate_for(const VerifyRateOptions& command_line, const TestDef& test);

// The seed-to-seed standard deviations that make one noise floor of each compared quantity, and where they
// came from (words, for summary.json).
struct NoiseFloors {
  double ratio13 = 0.0;  // s11/s33 (the peaks)
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

// The summary quantities a rate check compares (dotted paths of summary.json's tests.<test>), each with the floor
// that measures it: the whole-test peaks of s11/s33 (the first row of the largest, and the robust peak) and the
// end-window means of ev and Z.
struct ComparedQuantity {
  const char* path;   // its place in summary.json (comparisons.<path>)
  const char* floor;  // "ratio13", "ev" or "Z"
  bool peak;          // a peak quantity: compared only when both runs reached their peak
  double ComparedValues::*value;  // the test summary's (TestSummary::compared)
};
inline constexpr ComparedQuantity kRateCheckQuantities[] = {
    {"peak_ratio13", "ratio13", true, &ComparedValues::peak_ratio13},
    {"peak_robust.ratio13", "ratio13", true, &ComparedValues::peak_robust_ratio13},
    {"end_window.ev", "ev", false, &ComparedValues::end_window_ev},
    {"end_window.Z", "Z", false, &ComparedValues::end_window_Z},
};

// The 95 % half-width [floors] of the chaos of one pair of runs from the same state, for one quantity: the smaller
// of t(0.975, 1) |twin difference| (the twin is one sample of the pair's chaos: Student's t with 1 degree of
// freedom) and z(0.975) sqrt 2 (two runs from one prepared sample differ by chaos at most as two seeds do), each at
// 97.5 % so that the smaller holds at 95 % (Bonferroni). Without a twin difference, or a twin that did not part
// from the test, the bound.
struct PairChaos {
  double half_width = 0.0;  // [floors]
  double twin = 0.0;        // [floors] the twin's half-width (NaN: none)
  double bound = 0.0;       // [floors] the bound's
  std::string from;         // "twin" or "bound"
};
PairChaos pair_chaos(double twin_floors, bool twin_parted);

// The verdict of an error d [floors] whose chaos has this 95 % half-width, against tolerance T: converged when
// |d| + half_width <= T, not converged when |d| - half_width > T, else unresolved ("not compared" for no d).
std::string rate_verdict(double d, double half_width, double tolerance);

// What a check costs before it runs: the particle-steps of the slower run and of the twin (from the test's plan),
// and their time at `particle_steps_per_s` (0: unknown).
struct RateCheckCost {
  std::int64_t slow_steps = -1;  // -1: known only by running
  std::int64_t twin_steps = 0;
  double particle_steps = 0.0;
  double seconds = 0.0;
  std::string words() const;
};
RateCheckCost rate_check_cost(const Deck& deck, const TestDef& test, const VerifyRateOptions& check,
                              double particle_steps_per_s);

// The test's legs at `factor` times its rate: strain increments and rates of the strain-driven axes, stress ramps'
// and rotations' rates; a leg that ends on a step count takes 1/factor as many steps, and the output interval
// follows, so the slower run writes as many rows per strain.
TestDef slowed_test(const TestDef& test, double factor);

// Runs the slower run (and the twin) of a finished test from `start` (the state the test started from, with its
// forces) and returns summary.json's "verify_rate" of the test: the settings, the floors, the pair chaos, per
// quantity the test's, the slower run's and the twin's values, the difference in floors and its verdict, and the
// test's verdict. A run that fails is recorded as such (its error), not thrown.
nlohmann::json verify_test_rate(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                                const VerifyRateOptions& check, const State& start, const TestSummary& summary);

// The check across an ensemble's seeds (ensemble.json "verify_rate"): per test and quantity the seeds' differences
// in floors, their mean and its one-sided 95 % bounds (Student's t, n - 1), and the TOST verdict within the
// tolerance; `summaries` are the seeds' summary.json.
nlohmann::json rate_check_across_seeds(const std::vector<std::uint64_t>& seeds, const std::vector<nlohmann::json>& summaries);

}  // namespace celldem
