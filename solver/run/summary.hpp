// The scalars of summary.json. C++ owns every one of them: the tools read them and never recompute them.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "measure/series.hpp"
#include "run/driven_measure.hpp"
#include "run/program.hpp"
#include "run/stage_observer.hpp"
#include "run/summary_fields.hpp"

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
// them: NaN where summary.json has null. A test whose driven measure is not s11/s33 (shear, extension) compares the
// driven measure's peak as peak_ratio13 and has no robust peak.
struct ComparedValues {
  double peak_ratio13 = NAN;         // summary.json peak_ratio13 (the driven measure's peak value)
  double peak_robust_ratio13 = NAN;  // peak_robust.ratio13
  double end_window_ev = NAN;        // end_window.ev
  double end_window_Z = NAN;         // end_window.Z
  double end_span_ev = NAN;          // the mean of ev over the last kRateCheckWindow (not in summary.json)
  double end_span_Z = NAN;           // of Z
};

// The records below are summary.json's, each with its field table (run/summary_fields.hpp): the table writes the
// record and `celldem schema --summary` lists it, so every key written has its unit and meaning there.

// peak_robust: s11/s33 smoothed, its peak and the plateau around it.
struct RobustPeak {
  static constexpr bool kRecord = true;
  std::string smoother = "centred moving average of s11/s33 over 0.5 % of e1";
  double ratio13 = NAN;
  double e1 = NAN;
  std::array<double, 2> plateau_e1 = {NAN, NAN};
  std::size_t plateau_rows = 0;
  double b_mean = NAN, b_std = NAN, b_principal_mean = NAN, b_principal_std = NAN;
};
template <class V>
void visit_fields(const RobustPeak& r, V&& v) {
  v(FieldDoc{"smoother", "", "how s11/s33 was smoothed"}, r.smoother);
  v(FieldDoc{"ratio13", "1", "the smoothed s11/s33's largest value"}, r.ratio13);
  v(FieldDoc{"e1", "1", "e1 at the smoothed peak (compression +)"}, r.e1);
  v(FieldDoc{"plateau_e1", "1", "[lowest, highest] e1 where the smoothed curve stays within 1 % of its peak"},
    r.plateau_e1);
  v(FieldDoc{"plateau_rows", "rows", "the rows of that plateau"}, r.plateau_rows);
  v(FieldDoc{"b_mean", "1", "b = (s22 - s33)/(s11 - s33) averaged over the plateau"}, r.b_mean);
  v(FieldDoc{"b_std", "1", "its standard deviation over the plateau"}, r.b_std);
  v(FieldDoc{"b_principal_mean", "1", "b of the principal stresses averaged over the plateau"}, r.b_principal_mean);
  v(FieldDoc{"b_principal_std", "1", "its standard deviation over the plateau"}, r.b_principal_std);
}

// peak_state: the stress state on the peak row.
struct PeakState {
  static constexpr bool kRecord = true;
  double sigma1 = NAN, sigma2 = NAN, sigma3 = NAN, p = NAN, q = NAN, sin_phi = NAN, b = NAN, b_principal = NAN,
         lode_angle = NAN, ev = NAN;
};
template <class V>
void visit_fields(const PeakState& s, V&& v) {
  v(FieldDoc{"sigma1", "Pa", "the largest principal stress (compression +)"}, s.sigma1);
  v(FieldDoc{"sigma2", "Pa", "the intermediate principal stress"}, s.sigma2);
  v(FieldDoc{"sigma3", "Pa", "the smallest principal stress"}, s.sigma3);
  v(FieldDoc{"p", "Pa", "the mean stress (s11 + s22 + s33)/3"}, s.p);
  v(FieldDoc{"q", "Pa", "the deviator stress (series.csv q)"}, s.q);
  v(FieldDoc{"sin_phi", "1", "(sigma1 - sigma3)/(sigma1 + sigma3), the mobilised friction"}, s.sin_phi);
  v(FieldDoc{"b", "1", "(s22 - s33)/(s11 - s33) of the axis stresses"}, s.b);
  v(FieldDoc{"b_principal", "1", "(sigma2 - sigma3)/(sigma1 - sigma3)"}, s.b_principal);
  v(FieldDoc{"lode_angle", "rad", "the Lode angle of the principal stresses (series.csv lode_angle)"}, s.lode_angle);
  v(FieldDoc{"ev", "1", "the volumetric strain (compression +)"}, s.ev);
}

// end_window: means over the last rows.
struct EndWindow {
  static constexpr bool kRecord = true;
  double strain = NAN, ev = NAN, Z = NAN;
};
template <class V>
void visit_fields(const EndWindow& w, V&& v) {
  v(FieldDoc{"strain", "1", "the window: rows whose end-axis strain lies within this of the last row's"}, w.strain);
  v(FieldDoc{"ev", "1", "the volumetric strain's mean over the window"}, w.ev);
  v(FieldDoc{"Z", "1", "the coordination number's mean over the window"}, w.Z);
}

// The scalars summarize_series gives: summary.json's tests.<test> peak and end keys. A shear or extension test's
// s11/s33 peak keys (peak_ratio13, e1_peak_range, e1_at_peak_centre, peak_robust) are null and the other "at peak"
// keys are on its driven measure's peak row (summarize_test): its own record (shear, extension) carries the peak.
struct SeriesSummary {
  static constexpr bool kRecord = true;
  double peak_ratio13 = NAN;
  std::optional<bool> peak_reached;
  double e1_at_peak = NAN;
  Nullable<std::array<double, 2>> e1_peak_range;
  double e1_at_peak_centre = NAN;
  double b_at_peak = NAN, b_principal_at_peak = NAN, ratio_principal_at_peak = NAN;
  Nullable<RobustPeak> peak_robust;
  PeakState peak_state;
  double b_final = NAN, final_e1 = NAN, ev_final = NAN, Z_final = NAN;
  EndWindow end_window;
};
template <class V>
void visit_fields(const SeriesSummary& s, V&& v) {
  v(FieldDoc{"peak_ratio13", "1",
             "the largest s11/s33 of the rows (null for a shear or extension test: its record "
             "carries its driven measure's peak)"},
    s.peak_ratio13);
  v(FieldDoc{"peak_reached", "",
             "whether the driven measure reached its peak before the test's end (the evidence: "
             "docs/physics.md); absent for a test with no peak to reach (rotation, stresses)"},
    s.peak_reached);
  v(FieldDoc{"e1_at_peak", "1", "e1 on the peak row (the driven measure's)"}, s.e1_at_peak);
  v(FieldDoc{"e1_peak_range", "1", "[lowest, highest] e1 of the rows within 1 % of the s11/s33 peak"}, s.e1_peak_range);
  v(FieldDoc{"e1_at_peak_centre", "1", "the centre of e1_peak_range"}, s.e1_at_peak_centre);
  v(FieldDoc{"b_at_peak", "1", "b = (s22 - s33)/(s11 - s33) on the peak row"}, s.b_at_peak);
  v(FieldDoc{"b_principal_at_peak", "1", "b of the principal stresses on the peak row"}, s.b_principal_at_peak);
  v(FieldDoc{"ratio_principal_at_peak", "1", "sigma1/sigma3 on the peak row"}, s.ratio_principal_at_peak);
  v(FieldDoc{"peak_robust", "", "the peak of s11/s33 smoothed over 0.5 % of e1 (null for shear and extension)"},
    s.peak_robust);
  v(FieldDoc{"peak_state", "", "the stress state on the peak row"}, s.peak_state);
  v(FieldDoc{"b_final", "1", "b on the last row"}, s.b_final);
  v(FieldDoc{"final_e1", "1", "e1 on the last row"}, s.final_e1);
  v(FieldDoc{"ev_final", "1", "the volumetric strain on the last row (compression +)"}, s.ev_final);
  v(FieldDoc{"Z_final", "1", "the coordination number on the last row"}, s.Z_final);
  v(FieldDoc{"end_window", "", "means over the last rows (kEndWindowStrain of the end axis)"}, s.end_window);
}
inline void to_json(nlohmann::json& j, const SeriesSummary& s) { j = record_json(s); }

// `values`, when given, receives those of the summary's values a rate check compares.
SeriesSummary summarize_series(const std::vector<SeriesRow>& rows, int end_axis, ComparedValues* values = nullptr);

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

// A leg's last row (legs[].end).
struct LegEndRow {
  static constexpr bool kRecord = true;
  double step = 0, e1 = NAN, e2 = NAN, e3 = NAN, s11 = NAN, s22 = NAN, s33 = NAN, p = NAN, q = NAN, b = NAN, ev = NAN;
};
template <class V>
void visit_fields(const LegEndRow& r, V&& v) {
  v(FieldDoc{"step", "steps", "the row's step, counted from the test's start"}, r.step);
  v(FieldDoc{"e1", "1", "the strain of axis 1 (compression +)"}, r.e1);
  v(FieldDoc{"e2", "1", "the strain of axis 2"}, r.e2);
  v(FieldDoc{"e3", "1", "the strain of axis 3"}, r.e3);
  v(FieldDoc{"s11", "Pa", "the normal stress of axis 1 (compression +)"}, r.s11);
  v(FieldDoc{"s22", "Pa", "the normal stress of axis 2"}, r.s22);
  v(FieldDoc{"s33", "Pa", "the normal stress of axis 3"}, r.s33);
  v(FieldDoc{"p", "Pa", "the mean stress"}, r.p);
  v(FieldDoc{"q", "Pa", "the deviator stress"}, r.q);
  v(FieldDoc{"b", "1", "(s22 - s33)/(s11 - s33)"}, r.b);
  v(FieldDoc{"ev", "1", "the volumetric strain"}, r.ev);
}

// A leg's row of its largest s11/s33 (legs[].peak).
struct LegPeak {
  static constexpr bool kRecord = true;
  double ratio13 = NAN, e1 = NAN, b = NAN, b_principal = NAN, p = NAN, ev = NAN, sin_phi = NAN;
};
template <class V>
void visit_fields(const LegPeak& r, V&& v) {
  v(FieldDoc{"ratio13", "1", "the leg's largest s11/s33"}, r.ratio13);
  v(FieldDoc{"e1", "1", "e1 there"}, r.e1);
  v(FieldDoc{"b", "1", "b there"}, r.b);
  v(FieldDoc{"b_principal", "1", "b of the principal stresses there"}, r.b_principal);
  v(FieldDoc{"p", "Pa", "the mean stress there"}, r.p);
  v(FieldDoc{"ev", "1", "the volumetric strain there"}, r.ev);
  v(FieldDoc{"sin_phi", "1", "the mobilised friction there"}, r.sin_phi);
}

// The keys of a leg's control_errors (run/control_verdict.hpp to_json(ControlErrors)).
extern const std::array<FieldDoc, 9> kControlErrorKeys;

// One leg of the load program (legs[]).
struct LegSummary {
  static constexpr bool kRecord = true;
  std::size_t leg = 0;
  std::int64_t rows = 0;
  double servo_cap = 0.0;
  std::optional<LegEndRow> end;
  std::optional<LegPeak> peak;
  std::optional<nlohmann::json> control_errors;  // to_json(ControlErrors)
};
template <class V>
void visit_fields(const LegSummary& l, V&& v) {
  v(FieldDoc{"leg", "", "the leg's index in the load program (0-based)"}, l.leg);
  v(FieldDoc{"rows", "rows", "its rows in series.csv"}, l.rows);
  v(FieldDoc{"servo_cap", "1", "the servo's cap of strain per step on this leg, as the run used it"}, l.servo_cap);
  v(FieldDoc{"end", "", "its last row"}, l.end);
  v(FieldDoc{"peak", "", "its row of the largest s11/s33"}, l.peak);
  v(FieldDoc{"control_errors", "", "the worst errors of its controls (docs/physics.md, the control verdict)",
             kControlErrorKeys},
    l.control_errors);
}

// A control that failed (control_failures[]).
struct ControlFailureEntry {
  static constexpr bool kRecord = true;
  std::size_t leg = 0;
  std::string axis, kind;
  double error = NAN, tolerance = NAN, target = NAN, reached = NAN;
};
template <class V>
void visit_fields(const ControlFailureEntry& f, V&& v) {
  v(FieldDoc{"leg", "", "the leg (0-based)"}, f.leg);
  v(FieldDoc{"axis", "", "the component (x1 .. x23)"}, f.axis);
  v(FieldDoc{"kind", "", "the control's kind (stress, shear_stress, b, mean_stress, volume)"}, f.kind);
  v(FieldDoc{"error", "1", "its sustained error (relative, or absolute for b)"}, f.error);
  v(FieldDoc{"tolerance", "1", "the error it may keep"}, f.tolerance);
  v(FieldDoc{"target", "Pa or 1", "its target at the failure, in the error's quantity"}, f.target);
  v(FieldDoc{"reached", "Pa or 1", "what it reached there"}, f.reached);
}

// shear: a simple shear's (or a shear-driven test's) driven measure tau/sigma_n and its peak.
struct ShearRecord {
  static constexpr bool kRecord = true;
  std::string component, measure;
  double peak_tau_over_sigma_n = NAN, g_at_peak = NAN;
  bool peak_reached = false;
  double residual_tau_over_sigma_n = NAN, ev_at_peak = NAN, ev_final = NAN, g_final = NAN;
};
template <class V>
void visit_fields(const ShearRecord& s, V&& v) {
  v(FieldDoc{"component", "", "the driven shear component (x12, x13, x23)"}, s.component);
  v(FieldDoc{"measure", "", "the measure, |s_ij|/s_jj"}, s.measure);
  v(FieldDoc{"peak_tau_over_sigma_n", "1", "its largest value (the test's peak)"}, s.peak_tau_over_sigma_n);
  v(FieldDoc{"g_at_peak", "1", "the driven shear strain g_ij there"}, s.g_at_peak);
  v(FieldDoc{"peak_reached", "", "whether it fell by more than 1 % after its largest"}, s.peak_reached);
  v(FieldDoc{"residual_tau_over_sigma_n", "1", "its mean over the end window of g_ij"}, s.residual_tau_over_sigma_n);
  v(FieldDoc{"ev_at_peak", "1", "the volumetric strain at the peak (compression +; dilation -)"}, s.ev_at_peak);
  v(FieldDoc{"ev_final", "1", "the volumetric strain on the last row"}, s.ev_final);
  v(FieldDoc{"g_final", "1", "g_ij on the last row"}, s.g_final);
}

// extension: a test that drives its first axis in extension; its driven measure s33/s11 and its peak.
struct ExtensionRecord {
  static constexpr bool kRecord = true;
  std::string measure;
  double peak_ratio31 = NAN, e1_at_peak = NAN;
  bool peak_reached = false;
  double ev_at_peak = NAN, ev_final = NAN;
};
template <class V>
void visit_fields(const ExtensionRecord& s, V&& v) {
  v(FieldDoc{"measure", "", "the measure, s33/s11"}, s.measure);
  v(FieldDoc{"peak_ratio31", "1", "its largest value (the test's peak)"}, s.peak_ratio31);
  v(FieldDoc{"e1_at_peak", "1", "e1 there (extension -)"}, s.e1_at_peak);
  v(FieldDoc{"peak_reached", "", "whether it fell by more than 1 % after its largest"}, s.peak_reached);
  v(FieldDoc{"ev_at_peak", "1", "the volumetric strain at the peak"}, s.ev_at_peak);
  v(FieldDoc{"ev_final", "1", "the volumetric strain on the last row"}, s.ev_final);
}

// rotation: how a principal-axis rotation leg tracked its targets.
struct RotationRecord {
  static constexpr bool kRecord = true;
  std::string plane;
  double sigma1_error_max = NAN, sigma3_error_max = NAN, angle_error_max_deg = NAN, angle_turned_deg = 0.0,
         out_of_plane_shear_max = NAN;
};
template <class V>
void visit_fields(const RotationRecord& r, V&& v) {
  v(FieldDoc{"plane", "", "the plane the principal axes turn in (x1x2, x1x3, x2x3)"}, r.plane);
  v(FieldDoc{"sigma1_error_max", "1", "the largest |in-plane major principal stress - sigma1| / sigma1"},
    r.sigma1_error_max);
  v(FieldDoc{"sigma3_error_max", "1", "the largest |in-plane minor principal stress - sigma3| / sigma3"},
    r.sigma3_error_max);
  v(FieldDoc{"angle_error_max_deg", "deg", "the largest error of the principal direction against the leg's angle"},
    r.angle_error_max_deg);
  v(FieldDoc{"angle_turned_deg", "deg", "the angle the target turned through"}, r.angle_turned_deg);
  v(FieldDoc{"out_of_plane_shear_max", "1", "the largest other shear stress over the mean stress"},
    r.out_of_plane_shear_max);
}

// adaptive_rate: the rates an adaptive leg ran at.
struct AdaptiveRateRecord {
  static constexpr bool kRecord = true;
  double factor_min = NAN, factor_max = NAN, inertial_number_max = NAN;
  Nullable<std::int64_t> steps_at_deck_rate;
  double step_ratio = NAN;
};
template <class V>
void visit_fields(const AdaptiveRateRecord& a, V&& v) {
  v(FieldDoc{"factor_min", "1", "the smallest rate factor the rule chose (null: none chosen)"}, a.factor_min);
  v(FieldDoc{"factor_max", "1", "the largest rate factor the rule chose"}, a.factor_max);
  v(FieldDoc{"inertial_number_max", "1", "the largest inertial number of the rows"}, a.inertial_number_max);
  v(FieldDoc{"steps_at_deck_rate", "steps", "the steps the deck's rate would take (null: an end not at a strain)"},
    a.steps_at_deck_rate);
  v(FieldDoc{"step_ratio", "1", "steps_at_deck_rate over the steps run: the saving"}, a.step_ratio);
}

// What the test's kind adds to its summary: the driven measure's name and record.
struct DrivenMeasureSummary {
  std::string driven_measure;        // driven_measure_words
  std::optional<bool> peak_reached;  // the driven measure's (none for a test with no peak to reach)
  std::optional<ShearRecord> shear;
  std::optional<ExtensionRecord> extension;
  std::optional<RotationRecord> rotation;
};
DrivenMeasureSummary summarize_driven_measure(const TestDef& test, const std::vector<SeriesRow>& rows, double dt);

// A finished test's summary, summary.json's tests.<test> (to_json writes it, by its field table), and what the run
// reads of it, typed: nothing reads it back from JSON.
struct TestSummary {
  static constexpr bool kRecord = true;
  SeriesSummary series;  // the peak and end keys (their peak_reached is the written key)
  DrivenMeasureSummary driven;
  bool controlled = true;  // no control failed
  std::vector<ControlFailureEntry> control_failures;
  double servo_max_error = NAN, b_max_error = NAN, volume_max_error = NAN, control_error_over_tolerance = NAN;
  double inertial_number = NAN, imposed_inertial_number = NAN;
  std::vector<LegSummary> legs;
  std::int64_t steps = 0;
  double wall_s = 0.0;
  double particle_steps_per_s = 0.0;
  std::optional<AdaptiveRateRecord> adaptive_rate;

  // Not written (typed values the run reads):
  TestMeasure measure;       // driven_measure
  PeakJudgement peak;        // of the measure (followed on s11/s33 for a test with no peak to reach)
  bool peak_reached = true;  // the peak reached, or none to reach
  ComparedValues compared;   // what a rate check compares
};
template <class V>
void visit_fields(const TestSummary& t, V&& v) {
  visit_fields(t.series, v);
  v(FieldDoc{"driven_measure", "",
             "the measure the test drives to a peak (s11/s33, s33/s11, |s_ij|/s_jj) or "
             "\"principal-axis rotation\", \"none (stress-controlled)\" (docs/physics.md)"},
    t.driven.driven_measure);
  v(FieldDoc{"shear", "", "a shear-driven test's peak of tau/sigma_n (its peak keys)"}, t.driven.shear);
  v(FieldDoc{"extension", "", "an extension test's peak of s33/s11 (its peak keys)"}, t.driven.extension);
  v(FieldDoc{"rotation", "", "a principal-axis rotation's tracking of its targets"}, t.driven.rotation);
  v(FieldDoc{"controlled", "", "no control failed (docs/physics.md, the control verdict)"}, t.controlled);
  v(FieldDoc{"control_failures", "", "each control that failed"}, t.control_failures);
  v(FieldDoc{"servo_max_error", "1", "the worst single-step relative error of a stress-controlled axis"},
    t.servo_max_error);
  v(FieldDoc{"b_max_error", "1", "the worst single-step error of a b-controlled axis"}, t.b_max_error);
  v(FieldDoc{"volume_max_error", "1", "the worst single-step volumetric strain of a constant-volume test"},
    t.volume_max_error);
  v(FieldDoc{"control_error_over_tolerance", "1", "the largest sustained control error over its tolerance"},
    t.control_error_over_tolerance);
  v(FieldDoc{"inertial_number", "1", "the rows' mean inertial number (an adaptive rate: their largest)"},
    t.inertial_number);
  v(FieldDoc{"imposed_inertial_number", "1", "the imposed rates' planned inertial number (adaptive: largest)"},
    t.imposed_inertial_number);
  v(FieldDoc{"legs", "", "per leg of the load program"}, t.legs);
  v(FieldDoc{"steps", "steps", "the test's steps"}, t.steps);
  v(FieldDoc{"wall_s", "s", "its wall time, a resume's earlier time included"}, t.wall_s);
  v(FieldDoc{"particle_steps_per_s", "1/s", "particles x steps / wall_s"}, t.particle_steps_per_s);
  v(FieldDoc{"adaptive_rate", "", "an adaptive rate's record"}, t.adaptive_rate);
}
// summary.json's tests.<test> (the observers' results are added beside it by the run).
inline void to_json(nlohmann::json& j, const TestSummary& t) { j = record_json(t); }

// A test's summary from its rows as series.csv holds them (as_printed), so that a resumed run reports the same
// bytes. `warnings` receives what the health checks say about the finished test.
TestSummary summarize_test(const Deck& deck, const TestDef& test, const std::vector<SeriesRow>& rows,
                           const std::vector<ControlErrors>& errors, double wall_seconds, std::int64_t steps,
                           std::size_t particles, std::vector<std::string>& warnings);
TestSummary summarize_finished_test(const Deck& deck, const TestDef& test, const StageResult& stage,
                                    std::vector<std::string>& warnings);

// The prepared sample (summary.json's prepared): void ratio, coordination, stresses, cost, and the equilibrium
// criterion in words. A preparation from initial_state adds started_from (kStartedFromKeys) beside it.
struct PreparationSummary {
  static constexpr bool kRecord = true;
  double void_ratio = NAN, Z = NAN, Zm = NAN;
  std::int64_t rattlers = 0;
  double p = NAN, s11 = NAN, s22 = NAN, s33 = NAN, unbalanced_force = NAN;
  std::int64_t steps = 0;
  double wall_s = 0.0, particle_steps_per_s = 0.0;
  std::string equilibrium_criterion;
};
template <class V>
void visit_fields(const PreparationSummary& s, V&& v) {
  v(FieldDoc{"void_ratio", "1", "the prepared sample's void ratio"}, s.void_ratio);
  v(FieldDoc{"Z", "1", "its coordination number"}, s.Z);
  v(FieldDoc{"Zm", "1", "its mechanical coordination number (rattlers removed)"}, s.Zm);
  v(FieldDoc{"rattlers", "particles", "particles with fewer than the contacts that hold them"}, s.rattlers);
  v(FieldDoc{"p", "Pa", "the mean stress"}, s.p);
  v(FieldDoc{"s11", "Pa", "the normal stress of axis 1"}, s.s11);
  v(FieldDoc{"s22", "Pa", "the normal stress of axis 2"}, s.s22);
  v(FieldDoc{"s33", "Pa", "the normal stress of axis 3"}, s.s33);
  v(FieldDoc{"unbalanced_force", "1", "mean |net contact force| over the mean normal force"}, s.unbalanced_force);
  v(FieldDoc{"steps", "steps", "the preparation's steps"}, s.steps);
  v(FieldDoc{"wall_s", "s", "its wall time"}, s.wall_s);
  v(FieldDoc{"particle_steps_per_s", "1/s", "particles x steps / wall_s"}, s.particle_steps_per_s);
  v(FieldDoc{"equilibrium_criterion", "", "the equilibrium it stopped at, in words"}, s.equilibrium_criterion);
}
inline void to_json(nlohmann::json& j, const PreparationSummary& s) { j = record_json(s); }
PreparationSummary summarize_preparation(const Model& model, const State& state, const PrepareDef& prepare,
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
