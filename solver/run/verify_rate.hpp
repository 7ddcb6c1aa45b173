// A run's own convergence check (`celldem run --verify-rate`), by a ladder of rates: the test is run again from
// the same starting state (the prepared sample) over its whole path at slower rungs (half and a quarter of its rate by
// default), and each summary quantity Q is fitted over the rungs and the test as Q(r) = Q0 + C r^p (Richardson
// extrapolation with the order p fitted: measure/richardson.hpp), so that C, the test's distance from the
// quasi-static answer Q0 (I -> 0), is measured whatever the order of the rate's effect. Twins (the test from the
// same state at 1.001, 1.002 ... times its rate: a change whose own effect is negligible, but which parts the runs
// from the first step) measure the chaos of one run, whose standard deviation is propagated through the fit into
// one-sided 95 % bounds on C. Each quantity in units of its noise floor, the verdicts:
//   converged      every quantity's bounds within (-T, T) at 95 % each (an intersection-union test: the test is
//                  converged only when each quantity is, so no adjustment for their number is needed),
//   not converged  some quantity's bounds beyond T on one side at 95 % over the family (Bonferroni: each at
//                  0.05 / m for m quantities compared),
//   unresolved     the rest; without twins (the chaos unknown) a single run is unresolved and the seeds judge.
// Across an ensemble's seeds the mean distance is judged by TOST on the seeds (rate_check_across_seeds). The test's
// own series and summary are untouched: the runs write <test>/verify/<run>/.
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
struct VerifyRateOptions {
  bool enabled = false;                     // --verify-rate: every test is checked
  std::vector<double> rungs = {0.5, 0.25};  // the slower rungs' rates over the test's, descending, in (0, 1)
  int twins = 2;                            // runs at (1 + k 0.001) times the rate, k = 1..twins; 0: none
  double tolerance = 1.0;   // [noise floors] the largest distance of a converged quantity (a run's --tolerance)
  std::string floors_path;  // an ensemble.json or {"ratio13", "ev", "Z"} stds (optionally per test); empty: default
  // Given on the command line: these replace a test's verify_rate values.
  bool rungs_given = false, twins_given = false;
};
inline constexpr double kMinRung = 1e-3;   // the slowest rung: 1000 times the test's steps
inline constexpr double kMaxRung = 0.999;  // a rung is slower than the test
inline constexpr int kMaxTwins = 8;

// The rungs of "0.5,0.25" (--verify-rate-rungs): at least two, each in [kMinRung, kMaxRung], no two equal; sorted
// descending. std::invalid_argument saying what is wrong.
std::vector<double> parse_rungs(const std::string& text);
// The same rules on a list already read (a deck's verify_rate.rungs): the sorted rungs, or std::invalid_argument.
std::vector<double> checked_rungs(std::vector<double> rungs);
// The rungs a single factor f stands for (--verify-rate-factor, verify_rate.rate_factor): f and f^2.
std::vector<double> rungs_of_factor(double factor);

// The rate check of one test: the deck's tests[].verify_rate with the command line's given values over it, or the
// command line's alone (--verify-rate); nullopt when neither asks for one.
std::optional<VerifyRateOptions> verify_rate_for(const VerifyRateOptions& command_line, const TestDef& test);

// The seed-to-seed standard deviations that make one noise floor of each compared quantity, and where they
// came from (words, for summary.json).
struct NoiseFloors {
  double ratio13 = 0.0;  // s11/s33 (the peaks)
  double ev = 0.0;       // volumetric strain [-]
  double Z = 0.0;        // coordination number
  bool Z_sheared = true;  // Z's floor is of the sheared sample's Z (false: the prepared sample's stands in)
  std::string source;
};

// The floors of test `test` of a deck of `particles` spheres: from `path` (an ensemble.json, whose
// tests.<test>.{peak_ratio13, ev_final, Z_final}.std it reads, or a JSON of {"ratio13", "ev", "Z"} stds, at the
// top level or under tests.<test>) when given, else the default: the reference ensemble's stds
// (tests/run/reference.json, 16 seeds of 400 spheres, built in) scaled by sqrt(400 / particles). Throws
// UsageError naming the file and key for a floor that is missing or not positive.
NoiseFloors noise_floors(const std::string& path, const std::string& test, int particles);

// The summary quantities a rate check compares, each with the floor that measures it: the whole-test peaks of
// s11/s33 (the first row of the largest, and the robust peak) and the means of ev and Z over the last
// kRateCheckWindow of the driving strain (the end of the test, with less row-to-row noise than the 0.5 % end
// window), judged against the floors of the same quantities at the end of the test.
struct ComparedQuantity {
  const char* path;   // its name in verify_rate.comparisons
  const char* floor;  // "ratio13", "ev" or "Z"
  bool peak;          // a peak quantity: compared only when every run reached its peak
  double ComparedValues::*value;  // the test summary's (TestSummary::compared)
};
inline constexpr ComparedQuantity kRateCheckQuantities[] = {
    {"peak_ratio13", "ratio13", true, &ComparedValues::peak_ratio13},
    {"peak_robust.ratio13", "ratio13", true, &ComparedValues::peak_robust_ratio13},
    {"end_span.ev", "ev", false, &ComparedValues::end_span_ev},
    {"end_span.Z", "Z", false, &ComparedValues::end_span_Z},
};

// What a check costs before it runs: per rung and twin its steps (from the test's plan), and their particle-steps
// and time at `particle_steps_per_s`.
struct RateCheckCost {
  std::vector<std::string> names;      // each run's: "rung 0.5x", "twin 1.001x"
  std::vector<std::int64_t> steps;     // -1: known only by running
  std::vector<double> particle_steps;  // per run (0 where unknown)
  double total_particle_steps = 0.0;
  double particle_steps_per_s = 0.0;       // the speed the times are at
  bool known = true;                       // every run's steps known
  std::vector<std::string> lines() const;  // for the console: one per run, then the total
};
RateCheckCost rate_check_cost(const Deck& deck, const TestDef& test, const VerifyRateOptions& check,
                              double particle_steps_per_s);

// The test's legs at `factor` times its rate: strain increments and rates of the strain-driven axes, stress ramps'
// and rotations' rates; a leg that ends on a step count takes 1/factor as many steps, and the output interval
// follows, so the slower run writes as many rows per strain.
TestDef slowed_test(const TestDef& test, double factor);

// One run of the check as summary.json records it.
struct RateCheckRun {
  std::string name;  // "rung-1" (the first slower rung), "twin-1"
  double factor = 1.0;
  std::string series;  // relative to the run folder
  std::int64_t steps = 0;
  double wall_s = 0.0;
  bool controlled = true, peak_reached = true;
  nlohmann::json inertial_number;
  std::string error;  // a run that failed: its error
  ComparedValues compared;
};

// One quantity's ladder: its values, the chaos, the fit and the distance from I -> 0 with its bounds, in floors.
struct QuantityLadder {
  std::string path, floor_name;
  double floor = 0.0;
  double test = 0.0;
  std::vector<double> rungs, twins;  // the values at the rungs (descending rate) and at the twins
  double chaos_sd = 0.0;             // one run's chaos [the quantity's units] from the test and its twins; NaN: none
  int chaos_dof = 0;
  double q0 = 0.0;  // the fitted answer at I -> 0
  double order = 0.0, order_lo = 0.0, order_hi = 0.0;
  bool order_at_bound = false;
  double error_floors = 0.0;                              // (test - Q0) / floor: the test's distance from I -> 0
  double lo_floors = 0.0, hi_floors = 0.0;                // its one-sided 95 % bounds
  double family_lo_floors = 0.0, family_hi_floors = 0.0;  // its one-sided bounds at 0.05 / m
  double linear_floors = 0.0;  // (test - first rung) / (1 - first rung) / floor: what a linear extrapolation says
  std::string verdict;         // converged, not converged, unresolved, not compared
  std::string reason;          // of "not compared"
};

// The rate check of one test, as summary.json's tests.<test>.verify_rate holds it (to_json).
struct RateCheckResult {
  std::vector<double> rungs;  // the slower rungs
  int twins = 0;
  double tolerance = 1.0;
  NoiseFloors floors;
  RateCheckCost cost;
  std::vector<RateCheckRun> runs;
  std::vector<QuantityLadder> quantities;
  int family = 0;  // the quantities compared (Bonferroni's m)
  std::string verdict, reason;
  std::string largest_quantity;
  double largest = -1.0;  // [floors]
  nlohmann::json to_json() const;
};

// The verdict of a quantity whose distance has one-sided bounds [lo, hi] at 95 % and [family_lo, family_hi] at the
// family's level, against tolerance T: converged when -T < lo and hi < T, not converged when family_lo > T or
// family_hi < -T, else unresolved (NaN bounds: unresolved).
std::string ladder_verdict(double lo, double hi, double family_lo, double family_hi, double tolerance);

// Runs the rungs and the twins of a finished test from `start` (the state the test started from, with its forces)
// and judges each quantity. A run that fails is recorded as such (its error), not thrown.
RateCheckResult verify_test_rate(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                                 const VerifyRateOptions& check, const State& start, const TestSummary& summary);

// The check across an ensemble's seeds (ensemble.json "verify_rate"): per test and quantity the seeds' distances
// in floors, their mean and its one-sided 95 % bounds (Student's t, n - 1), and the TOST verdict within the
// tolerance; `summaries` are the seeds' summary.json.
nlohmann::json rate_check_across_seeds(const std::vector<std::uint64_t>& seeds, const std::vector<nlohmann::json>& summaries);

}  // namespace celldem
