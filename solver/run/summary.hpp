// The scalars of summary.json. C++ owns every one of them: the tools read them and never recompute them.
#pragma once
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "measure/series.hpp"
#include "run/driven_measure.hpp"
#include "run/program.hpp"
#include "run/stage_observer.hpp"

namespace celldem {

// εv and Z "at the end" of a test: their means over the rows whose end-axis strain lies within this of the
// last row's (a single row of Z jumps by a few hundredths as contacts open and close).
inline constexpr double kEndWindowStrain = 0.005;
// The rate check's end span: εv and Z over this much of the end-axis strain (a few percent, the end state with
// little row-to-row noise; run/verify_rate.hpp).
inline constexpr double kRateCheckWindow = 0.02;
// "ε1 at peak" as a range: the rows whose σ11/σ33 stays within this fraction of the peak.
inline constexpr double kPeakPlateau = 0.01;
// The robust peak: σ11/σ33 smoothed by a centred moving average over this much ε1 (rows within half of it
// on either side, in row order), its maximum, the contiguous ε1 range around it where the smoothed curve
// stays within kPeakPlateau of the maximum, and b (axis and principal) averaged over that range.
inline constexpr double kPeakSmoothing = 0.005;

// What a series alone determines (C++ owns these definitions; `celldem summarize` applies them to any series,
// another code's included): the peak of s11/s33 (its first row, e1 there and the plateau within kPeakPlateau,
// b and the principal values there), the robust peak, whether a peak was reached (not the last row, and the
// robust plateau ends before the last row), the last row and the end-window means over the last
// kEndWindowStrain of `end_axis` (0-based). Non-finite values are null.
// The quantities a rate check compares (run/verify_rate.hpp kRateCheckQuantities), typed as summarize_series gives
// them: NaN where summary.json has null.
struct ComparedValues {
  double peak_ratio13 = NAN;         // summary.json peak_ratio13
  double peak_robust_ratio13 = NAN;  // peak_robust.ratio13
  double end_window_ev = NAN;        // end_window.ev
  double end_window_Z = NAN;         // end_window.Z
  double end_span_ev = NAN;          // the mean of ev over the last kRateCheckWindow (not in summary.json)
  double end_span_Z = NAN;           // of Z
};
// `values`, when given, receives those of the JSON's values a rate check compares.
nlohmann::json summarize_series(const std::vector<SeriesRow>& rows, int end_axis, ComparedValues* values = nullptr);

// Whether a test's measure (driven_measure) reached its peak, and the evidence it was judged on: s11/s33 (and the
// tests with no peak to reach, followed on it) by its smoothed curve (the robust peak's plateau must end before the
// last row), s33/s11 and tau/sigma_n by their rows (the ratio must fall by more than kPeakPlateau after its
// largest); either way the largest must not be the last row. `evidence`: in words, for the console and messages.
struct PeakJudgement {
  std::size_t row = 0;  // the peak: the first row of the largest value (peak_row)
  double value = 0.0;   // the measure there
  double strain = 0.0;  // the strain there (driven_strain: e1, or the driven g_ij)
  bool reached = false;
  std::string evidence;
};
PeakJudgement judge_peak(const TestMeasure& measure, const std::vector<SeriesRow>& rows);

// What the test's kind adds to its summary: "driven_measure"; for a shear test "shear" (the peak of tau/sigma_n,
// g at the peak, the residual ratio, dilation) and "peak_reached" of that ratio; for a rotation "rotation" (how
// its principal values and angle tracked their targets; summarize_test leaves peak_reached out: no peak to reach).
nlohmann::json summarize_driven_measure(const TestDef& test, const std::vector<SeriesRow>& rows, double dt);
// A test's scalars from its rows as series.csv holds them (as_printed), so that a resumed run reports the
// same bytes. `warnings` receives what the health checks say about the finished test.
// Per leg ("legs"): its rows' peak of s11/s33, e1 and the controlled quantities there (b, p, volumetric
// strain), and the worst errors of its controls.
nlohmann::json summarize_test(const Deck& deck, const TestDef& test, const std::vector<SeriesRow>& rows,
                              const std::vector<ControlErrors>& errors, double wall_seconds, std::int64_t steps,
                              std::size_t particles, std::vector<std::string>& warnings,
                              ComparedValues* values = nullptr);

// A finished test's summary: summary.json's tests.<test> (summarize_test), and what the run reads of it, typed.
struct TestSummary {
  nlohmann::json json;
  TestMeasure measure;           // driven_measure
  PeakJudgement peak;            // of the measure (followed on s11/s33 for a test with no peak to reach)
  bool peak_reached = true;      // the peak reached, or none to reach (json's peak_reached, absent then)
  bool controlled = true;        // no control failed
  ComparedValues compared;       // what a rate check compares
  double wall_s = 0.0;
  double particle_steps_per_s = 0.0;
};
TestSummary summarize_finished_test(const Deck& deck, const TestDef& test, const StageResult& stage,
                                    std::vector<std::string>& warnings);

// The prepared sample: void ratio, coordination, stresses, cost, and the equilibrium criterion in words.
nlohmann::json summarize_preparation(const Model& model, const State& state, const PrepareDef& prepare,
                                     double wall_seconds);

// The settings a run used (the physics and the thread count).
nlohmann::json run_settings(const Deck& deck, int threads);

// A grading asked for and the one these diameters [m] realise: the percent passing each sieve size by the
// grading's basis, asked and realised, and the largest difference (percentage points). `celldem plan` prints
// it for the sample the seed draws; summary.json's "grading" holds it for the run's sample.
nlohmann::json grading_json(const GradingDef& grading, const std::vector<double>& diameters);

// The diameters [m] of the sample a run starts from: the grid sample the seed draws (graded decks only), or
// initial_state's spheres.
std::vector<double> run_sample_diameters(const Deck& deck);

}  // namespace celldem
