#include "run/summary.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "measure/micro.hpp"
#include "measure/quasi_static.hpp"
#include "cell/control.hpp"
#include "run/health.hpp"
#include "run/preflight.hpp"
#include "run/sample.hpp"

namespace celldem {
using Json = nlohmann::json;

// The keys of each component's entry of a leg's control_errors.axes.
const std::array<FieldDoc, 13> kControlAxisKeys = {
    FieldDoc{"name", "", "the component (x1 .. x23)"},
    FieldDoc{"kind", "", "its control (stress, shear_stress, b, mean_stress, volume, strain, held)"},
    FieldDoc{"error", "1", "its worst single-step error"},
    FieldDoc{"sustained", "1", "its worst sustained error (the verdict's)"},
    FieldDoc{"average", "1", "the running average of its error at the leg's end"},
    FieldDoc{"saturated_steps", "steps", "steps its servo sat at its cap"},
    FieldDoc{"over_steps", "steps", "steps its sustained error was over its tolerance"},
    FieldDoc{"over_saturated", "steps", "of those, the steps at the cap"},
    FieldDoc{"failed", "", "whether it failed"},
    FieldDoc{"target_at_failure", "Pa or 1", "its target when it failed"},
    FieldDoc{"reached_at_failure", "Pa or 1", "what it reached then"},
    FieldDoc{"last_target", "Pa or 1", "its target at the leg's end"},
    FieldDoc{"last_reached", "Pa or 1", "what it reached there"}};

const std::array<FieldDoc, 9> kControlErrorKeys = {
    FieldDoc{"stress", "1", "the worst relative error of a stress-controlled axis"},
    FieldDoc{"shear_stress", "1", "the worst error of a shear stress, over the mean stress"},
    FieldDoc{"b", "1", "the worst error of a b-controlled axis's b"},
    FieldDoc{"mean_stress", "1", "the worst relative error of a controlled mean stress"},
    FieldDoc{"volume", "1", "the worst volumetric strain of a constant-volume leg"},
    FieldDoc{"steps", "steps", "the steps the errors were taken over"},
    FieldDoc{"span_weight", "1", "the sustained error's running weight (its memory)"},
    FieldDoc{"span_decay", "1", "its per-step decay"},
    FieldDoc{"axes", "",
             "per component x1 .. x23: name, kind, error, sustained, average, saturated_steps, over_steps, "
             "over_saturated, failed, target_at_failure, reached_at_failure, last_target, last_reached",
             kControlAxisKeys}};

namespace {

// plateau_end: the last row of the smoothed peak's plateau.
RobustPeak robust_peak(const std::vector<SeriesRow>& rows, std::size_t* plateau_end = nullptr) {
  const std::size_t n = rows.size();
  std::vector<double> smooth(n, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t k = 0; k < n; ++k) {
    double sum = 0.0;
    int count = 0;
    for (std::size_t j = k; j < n && std::abs(rows[j].e1 - rows[k].e1) <= 0.5 * kPeakSmoothing; ++j)
      if (std::isfinite(rows[j].ratio13)) sum += rows[j].ratio13, ++count;
    for (std::size_t j = k; j-- > 0 && std::abs(rows[j].e1 - rows[k].e1) <= 0.5 * kPeakSmoothing;)
      if (std::isfinite(rows[j].ratio13)) sum += rows[j].ratio13, ++count;
    if (count) smooth[k] = sum / count;
  }
  std::size_t peak = 0;
  for (std::size_t k = 0; k < n; ++k)
    if (smooth[k] > smooth[peak] || !std::isfinite(smooth[peak])) peak = k;
  std::size_t lo = peak, hi = peak;
  while (lo > 0 && smooth[lo - 1] >= (1.0 - kPeakPlateau) * smooth[peak]) --lo;
  while (hi + 1 < n && smooth[hi + 1] >= (1.0 - kPeakPlateau) * smooth[peak]) ++hi;
  if (plateau_end) *plateau_end = hi;
  auto mean_std = [&](double SeriesRow::*field) {
    double sum = 0.0, sq = 0.0;
    int count = 0;
    for (std::size_t k = lo; k <= hi; ++k)
      if (std::isfinite(rows[k].*field)) sum += rows[k].*field, sq += rows[k].*field * rows[k].*field, ++count;
    const double mean = count ? sum / count : std::numeric_limits<double>::quiet_NaN();
    const double var = count > 1 ? (sq - count * mean * mean) / (count - 1) : 0.0;
    return std::make_pair(mean, std::sqrt(std::max(0.0, var)));
  };
  RobustPeak r;
  r.ratio13 = smooth[peak];
  r.e1 = rows[peak].e1;
  r.plateau_e1 = {std::min(rows[lo].e1, rows[hi].e1), std::max(rows[lo].e1, rows[hi].e1)};
  r.plateau_rows = hi - lo + 1;
  std::tie(r.b_mean, r.b_std) = mean_std(&SeriesRow::b);
  std::tie(r.b_principal_mean, r.b_principal_std) = mean_std(&SeriesRow::b_principal);
  return r;
}

std::vector<LegSummary> summarize_legs(const Deck& deck, const TestDef& test, const std::vector<SeriesRow>& rows,
                                       const std::vector<ControlErrors>& errors) {
  std::vector<LegSummary> legs;
  for (std::size_t k = 0; k < test.legs.size(); ++k) {
    const SeriesRow* peak = nullptr;
    const SeriesRow* end = nullptr;  // the leg's last row: its end (run_program writes it)
    std::int64_t count = 0;
    for (const SeriesRow& r : rows)
      if (r.leg == static_cast<double>(k)) {
        ++count;
        if (!peak || r.ratio13 > peak->ratio13) peak = &r;
        if (!end || r.step > end->step) end = &r;
      }
    // The servo's cap on this leg as the run used it (the deck's, or the default that follows the leg's rate).
    LegSummary leg;
    leg.leg = k;
    leg.rows = count;
    leg.servo_cap = servo_cap(deck.servo, test.legs[k], deck.stage_time_step(test));
    if (end)
      leg.end = LegEndRow{end->step, end->e1, end->e2, end->e3, end->s11, end->s22,
                          end->s33,  end->p,  end->q,  end->b,  end->ev};
    if (peak) leg.peak = LegPeak{peak->ratio13, peak->e1, peak->b, peak->b_principal, peak->p, peak->ev, peak->sin_phi};
    if (k < errors.size()) leg.control_errors = to_json(errors[k]);
    legs.push_back(std::move(leg));
  }
  return legs;
}

PeakState peak_state_of(const SeriesRow& r) {
  return {r.sigma1, r.sigma2, r.sigma3, r.p, r.q, r.sin_phi, r.b, r.b_principal, r.lode_angle, r.ev};
}

}  // namespace

PeakJudgement judge_peak(const TestMeasure& measure, const std::vector<SeriesRow>& rows) {
  PeakJudgement j;
  j.row = peak_row(measure, rows);
  j.value = driven_value(measure, rows[j.row]);
  j.strain = driven_strain(measure, rows[j.row]);
  const std::string name = measure_name(measure), strain = strain_name(measure);
  char buf[640];
  const bool at_last_row = j.row + 1 >= rows.size();
  std::string last_row;  // the raw measure's largest on the last row: no peak whatever else says
  if (at_last_row) {
    std::snprintf(buf, sizeof buf, "%s is largest (%.4f) at the last row, %s %.4f", name.c_str(), j.value,
                  strain.c_str(), j.strain);
    last_row = buf;
  }
  if (at_last_row && (measure.kind == TestMeasure::Kind::Extension || measure.kind == TestMeasure::Kind::Shear)) {
    j.evidence = last_row;
    return j;
  }
  if (measure.kind == TestMeasure::Kind::Extension || measure.kind == TestMeasure::Kind::Shear) {
    double lowest = j.value;
    for (std::size_t r = j.row + 1; r < rows.size(); ++r) lowest = std::min(lowest, driven_value(measure, rows[r]));
    j.reached = false;
    for (std::size_t r = j.row + 1; r < rows.size(); ++r)
      j.reached |= driven_value(measure, rows[r]) < (1.0 - kPeakPlateau) * j.value;
    std::snprintf(buf, sizeof buf, "%s falls after its largest %.4f (at %s %.4f) to as low as %.4f: %s than the %g %% a "
                  "peak needs", name.c_str(), j.value, strain.c_str(), j.strain, lowest,
                  j.reached ? "more" : "no more", 100.0 * kPeakPlateau);
    j.evidence = buf;
    return j;
  }
  std::size_t plateau_end = 0;
  const RobustPeak robust = robust_peak(rows, &plateau_end);
  j.reached = !at_last_row && plateau_end + 1 < rows.size();
  std::snprintf(buf, sizeof buf,
                "%s%ss11/s33 smoothed over %g %% of e1 peaks at %.4f, and stays within %g %% of it over "
                "e1 %.4f to %.4f, %s",
                last_row.c_str(), at_last_row ? "; " : "", 100.0 * kPeakSmoothing, robust.ratio13, 100.0 * kPeakPlateau,
                robust.plateau_e1[0], robust.plateau_e1[1],
                plateau_end + 1 < rows.size() ? "ending before the test's last row" : "to the test's last row");
  j.evidence = buf;
  return j;
}

SeriesSummary summarize_series(const std::vector<SeriesRow>& rows, int end_axis, ComparedValues* values) {
  // The peak of s11/s33 (its first row, judge_peak): the test's measure when it drives the first axis in compression;
  // summarize_test moves the peak keys to another driven measure's row.
  const PeakJudgement judged = judge_peak(TestMeasure{}, rows);
  const SeriesRow& at_peak = rows[judged.row];
  const SeriesRow& last = rows.back();

  // The plateau around the peak: the peak row is one row of a noisy plateau, its range is what is sure.
  double lo = at_peak.e1, hi = at_peak.e1;
  for (const SeriesRow& r : rows)
    if (r.ratio13 >= (1.0 - kPeakPlateau) * at_peak.ratio13) lo = std::min(lo, r.e1), hi = std::max(hi, r.e1);

  double ev_end = 0.0, z_end = 0.0;
  int in_window = 0;
  const double end_strain = last.strain(end_axis);
  for (const SeriesRow& r : rows)
    if (std::abs(r.strain(end_axis) - end_strain) <= kEndWindowStrain) ev_end += r.ev, z_end += r.Z, ++in_window;
  double ev_span = 0.0, z_span = 0.0;
  int in_span = 0;
  for (const SeriesRow& r : rows)
    if (std::abs(r.strain(end_axis) - end_strain) <= kRateCheckWindow) ev_span += r.ev, z_span += r.Z, ++in_span;

  SeriesSummary s;
  s.peak_ratio13 = at_peak.ratio13;
  s.peak_reached = judged.reached;
  s.e1_at_peak = at_peak.e1;
  s.e1_peak_range.value = {lo, hi};
  s.e1_at_peak_centre = 0.5 * (lo + hi);
  s.b_at_peak = at_peak.b;
  s.b_principal_at_peak = at_peak.b_principal;
  s.ratio_principal_at_peak = at_peak.ratio_principal;
  s.peak_robust.value = robust_peak(rows);
  s.peak_state = peak_state_of(at_peak);
  s.b_final = last.b;
  s.final_e1 = last.e1;
  s.ev_final = last.ev;
  s.Z_final = last.Z;
  s.end_window = {kEndWindowStrain, ev_end / in_window, z_end / in_window};
  if (values) {  // (as summary.json holds them: null, not a number, is NaN)
    const auto finite = [](double x) { return std::isfinite(x) ? x : std::numeric_limits<double>::quiet_NaN(); };
    *values = {finite(s.peak_ratio13),  finite(s.peak_robust.value->ratio13), finite(s.end_window.ev),
               finite(s.end_window.Z), finite(ev_span / in_span),                   finite(z_span / in_span)};
  }
  return s;
}

namespace {

// A shear-driven test's measure, tau/sigma_n = |s_ij| / s_jj of its driven component k (the shear stress over
// the normal stress of the axis the shear acts on: s_jj for g_ij with i < j): its peak (its first largest row,
// judge_peak), g at the peak and whether a peak was reached (it falls by more than kPeakPlateau after it), the
// residual ratio over the end window of g_ij, and the volumetric strain (dilation, compression +) at the peak
// and at the end.
ShearRecord summarize_shear(const std::vector<SeriesRow>& rows, int k) {
  const TestMeasure measure{TestMeasure::Kind::Shear, k};
  const auto ratio = [&](const SeriesRow& r) { return driven_value(measure, r); };
  const PeakJudgement judged = judge_peak(measure, rows);
  const std::size_t peak = judged.row;
  const double g_end = rows.back().strain(k);
  double residual = 0.0;
  int in_window = 0;
  for (const SeriesRow& r : rows)
    if (std::abs(r.strain(k) - g_end) <= kEndWindowStrain) residual += ratio(r), ++in_window;
  return {.component = component_name(k),
          .measure = measure_name(measure),
          .peak_tau_over_sigma_n = ratio(rows[peak]),
          .g_at_peak = rows[peak].strain(k),
          .peak_reached = judged.reached,
          .residual_tau_over_sigma_n = in_window ? residual / in_window : NAN,
          .ev_at_peak = rows[peak].ev,
          .ev_final = rows.back().ev,
          .g_final = g_end};
}

// An extension test's measure s33/s11: its peak (judge_peak), e1 there, whether it was reached, the volumetric
// strain at the peak and at the end.
ExtensionRecord summarize_extension(const TestMeasure& measure, const std::vector<SeriesRow>& rows) {
  const PeakJudgement judged = judge_peak(measure, rows);
  return {.measure = measure_name(measure),
          .peak_ratio31 = judged.value,
          .e1_at_peak = rows[judged.row].e1,
          .peak_reached = judged.reached,
          .ev_at_peak = rows[judged.row].ev,
          .ev_final = rows.back().ev};
}

// A principal-axis rotation leg's tracking over its rows: the in-plane principal values m +- r of s_ii, s_jj,
// s_ij against sigma1 and sigma3, and their direction (theta = atan2(2 s_ij, s_ii - s_jj) / 2) against the
// leg's angle at each row's time.
RotationRecord summarize_rotation(const TestDef& test, const std::vector<SeriesRow>& rows, double dt) {
  const std::size_t leg = test.legs.size() - 1;
  const PrincipalRotation& rot = *test.legs[leg].rotation;
  const auto [i, j] = kShearAxisEntries[static_cast<std::size_t>(rot.plane)];
  double start = 0.0;  // the leg's start time: the previous leg's end row
  for (const SeriesRow& r : rows)
    if (r.leg < static_cast<double>(leg)) start = std::max(start, r.time);
  double s1_err = NAN, s3_err = NAN, angle_err = NAN, turned = 0.0, out_of_plane = NAN;
  const auto worst = [](double& to, double x) { to = std::isfinite(to) ? std::max(to, x) : x; };
  for (const SeriesRow& r : rows) {
    if (r.leg != static_cast<double>(leg) || r.time <= start) continue;
    const double t = r.time - start;
    const double sii = r.stress(i), sjj = r.stress(j), sij = r.stress(3 + rot.plane);
    const double m = 0.5 * (sii + sjj), rad = std::hypot(0.5 * (sii - sjj), sij);
    worst(s1_err, std::abs(m + rad - rot.sigma1) / rot.sigma1);
    worst(s3_err, std::abs(m - rad - rot.sigma3) / rot.sigma3);
    if (rot.sigma1 > rot.sigma3) {  // (equal principal values have no direction)
      double d = 0.5 * std::atan2(2.0 * sij, sii - sjj) - rot.angle(t, dt);
      d = std::remainder(d, M_PI);  // a direction: defined modulo 180 degrees
      worst(angle_err, std::abs(d) * 180.0 / M_PI);
    }
    double shear_out = 0.0;  // the other two shear stresses, over the mean stress
    for (int a = 0; a < 3; ++a)
      if (a != rot.plane) shear_out = std::max(shear_out, std::abs(r.stress(3 + a)) / r.p);
    worst(out_of_plane, shear_out);
    turned = (rot.angle(t, dt) - rot.from) * 180.0 / M_PI;
  }
  return {.plane = std::string(kPlaneNames[static_cast<std::size_t>(rot.plane)]),
          .sigma1_error_max = s1_err,
          .sigma3_error_max = s3_err,
          .angle_error_max_deg = angle_err,
          .angle_turned_deg = turned,
          .out_of_plane_shear_max = out_of_plane};
}

}  // namespace

DrivenMeasureSummary summarize_driven_measure(const TestDef& test, const std::vector<SeriesRow>& rows, double dt) {
  const TestMeasure m = driven_measure(test);
  DrivenMeasureSummary d;
  d.driven_measure = driven_measure_words(m);
  switch (m.kind) {
    case TestMeasure::Kind::Shear:
      d.shear = summarize_shear(rows, m.component);
      d.peak_reached = d.shear->peak_reached;
      break;
    case TestMeasure::Kind::Extension:
      d.extension = summarize_extension(m, rows);
      d.peak_reached = d.extension->peak_reached;
      break;
    case TestMeasure::Kind::Rotation:  // no peak to reach: the tracking of the rotation is the result
      d.rotation = summarize_rotation(test, rows, dt);
      break;
    case TestMeasure::Kind::Axial: d.peak_reached = judge_peak(m, rows).reached; break;
    case TestMeasure::Kind::Stress: break;  // no peak to reach
  }
  return d;
}

namespace {

// The control errors' part of a test's summary: failures, worst errors; the health checks' warnings.
void summarize_controls(const std::vector<ControlErrors>& errors, TestSummary& t) {
  const ControlErrorMaxima worst = control_error_maxima(errors);
  for (const ControlFailureRecord& f : control_failures(errors))
    t.control_failures.push_back(
        {f.leg, component_name(f.component), f.kind, f.error, f.tolerance, f.target, f.reached});
  t.controlled = t.control_failures.empty();
  t.servo_max_error = worst.servo;
  t.b_max_error = worst.b;
  t.volume_max_error = worst.volume;
  t.control_error_over_tolerance = worst.over_tolerance;
}

// A test that drives another measure than s11/s33 (shear, extension): the summary's s11/s33 peak keys are null and
// its "at peak" keys are on the driven measure's peak row; its own record carries the peak. The rate check compares
// the driven measure's peak as peak_ratio13 (no robust peak is defined for it).
void place_peak_on_driven_measure(const std::vector<SeriesRow>& rows, TestSummary& t) {
  if (t.measure.kind != TestMeasure::Kind::Shear && t.measure.kind != TestMeasure::Kind::Extension) return;
  SeriesSummary& s = t.series;
  const SeriesRow& at = rows[t.peak.row];
  s.peak_ratio13 = NAN;
  s.e1_peak_range.value.reset();
  s.e1_at_peak_centre = NAN;
  s.peak_robust.value.reset();
  s.e1_at_peak = at.e1;
  s.b_at_peak = at.b;
  s.b_principal_at_peak = at.b_principal;
  s.ratio_principal_at_peak = at.ratio_principal;
  s.peak_state = peak_state_of(at);
  t.compared.peak_ratio13 = std::isfinite(t.peak.value) ? t.peak.value : NAN;
  t.compared.peak_robust_ratio13 = NAN;
}

}  // namespace

TestSummary summarize_test(const Deck& deck, const TestDef& test, const std::vector<SeriesRow>& rows,
                           const std::vector<ControlErrors>& errors, double wall, std::int64_t steps,
                           std::size_t particles, std::vector<std::string>& warnings) {
  TestSummary t;
  double mean_p = 0.0;
  for (const SeriesRow& r : rows) mean_p += r.p / rows.size();
  // The inertial number: the rows' own (the cell's actual rate, series `inertial_number`), their mean over the
  // rows after the start; the imposed rates' planned figure beside it (series `imposed_inertial_number`).
  double imposed = inertial_number(loading_rate(deck, test), mean_diameter(deck.sample), deck.sample.density, mean_p);
  double inertia = 0.0;
  std::size_t measured = 0;
  for (std::size_t k = 1; k < rows.size(); ++k)
    if (std::isfinite(rows[k].inertial_number)) inertia += rows[k].inertial_number, ++measured;
  inertia = measured ? inertia / static_cast<double>(measured) : imposed;
  // An adaptive rate: the rates it ran at, from the series (the rows' factors and inertial numbers), against the
  // steps the deck's rate would take.
  const bool adaptive =
      std::any_of(test.legs.begin(), test.legs.end(), [](const Leg& leg) { return leg.adaptive.has_value(); });
  if (adaptive && rows.size() > 1) {
    double low = std::numeric_limits<double>::quiet_NaN(), high = low, fastest = 0.0;  // (NaN: null, no row chose one)
    double fastest_imposed = 0.0;
    for (std::size_t k = 1; k < rows.size(); ++k) {
      fastest = std::max(fastest, rows[k].inertial_number);
      fastest_imposed = std::max(fastest_imposed, rows[k].imposed_inertial_number);
      // (a leg's end row ran the step cut to land on its end strain: not a factor the rule chose)
      if (k + 1 < rows.size() && rows[k + 1].leg == rows[k].leg)
        low = std::fmin(low, rows[k].rate_factor), high = std::fmax(high, rows[k].rate_factor);
    }
    inertia = fastest;
    imposed = fastest_imposed;
    std::int64_t at_deck_rate = 0;
    for (const std::int64_t n : program_leg_steps(test.legs, deck.stage_time_step(test)))
      at_deck_rate = n < 0 || at_deck_rate < 0 ? -1 : at_deck_rate + n;
    AdaptiveRateRecord a;
    a.factor_min = low, a.factor_max = high, a.inertial_number_max = fastest;
    if (at_deck_rate >= 0) a.steps_at_deck_rate.value = at_deck_rate;
    if (at_deck_rate > 0 && steps > 0) a.step_ratio = static_cast<double>(at_deck_rate) / steps;
    t.adaptive_rate = a;
  }
  for (const std::string& w : test_warnings(test, inertia)) warnings.push_back(w);
  for (const std::string& w : control_warnings(test.name, errors)) warnings.push_back(w);

  const int end_axis = test.legs.back().end.kind == LegEndKind::Strain ? test.legs.back().end.axis : 0;
  t.series = summarize_series(rows, end_axis, &t.compared);
  t.driven = summarize_driven_measure(test, rows, deck.stage_time_step(test));
  // A rotation or a stress-controlled test drives no measure to a peak: not "no peak reached".
  t.series.peak_reached = t.driven.peak_reached;
  t.measure = driven_measure(test);
  t.peak = judge_peak(t.measure, rows);
  t.peak_reached = !t.measure.has_peak() || t.peak.reached;
  place_peak_on_driven_measure(rows, t);
  summarize_controls(errors, t);
  t.inertial_number = inertia;
  t.imposed_inertial_number = imposed;
  t.legs = summarize_legs(deck, test, rows, errors);
  t.steps = steps;
  t.wall_s = wall;
  t.particle_steps_per_s = wall > 0 ? static_cast<double>(particles) * steps / wall : 0.0;
  return t;
}

TestSummary summarize_finished_test(const Deck& deck, const TestDef& test, const StageResult& stage,
                                    std::vector<std::string>& warnings) {
  return summarize_test(deck, test, stage.rows, stage.control_errors, stage.elapsed, stage.state.control.stage_steps,
                        stage.state.particles.size(), warnings);
}

PreparationSummary summarize_preparation(const Model& model, const State& state, const PrepareDef& prep, double wall) {
  const ContactMeasures contacts = measure_contacts(model, state);
  const Coordination& z = contacts.coordination;
  const EquilibriumDef& eq = prep.equilibrium;
  const std::int64_t steps = state.control.stage_steps;
  return {.void_ratio = void_ratio(model, state),
          .Z = z.z,
          .Zm = z.z_mechanical,
          .rattlers = z.rattlers,
          .p = state.mean_stress(),
          .s11 = state.stress[0],
          .s22 = state.stress[1],
          .s33 = state.stress[2],
          .unbalanced_force = contacts.unbalanced_force,
          .steps = steps,
          .wall_s = wall,
          .particle_steps_per_s = wall > 0 ? static_cast<double>(state.particles.size()) * steps / wall : 0.0,
          .equilibrium_criterion =
              "every " + std::to_string(eq.check_interval) + " servo steps after at least " +
              std::to_string(eq.min_steps) + ": |p - target|/target <= " + std::to_string(eq.pressure_tolerance) +
              ", each |s_kk - target|/target <= " + std::to_string(eq.stress_tolerance) +
              ", mean |net contact force| / mean normal force <= " + std::to_string(eq.unbalanced_force_ratio)};
}

Json run_settings(const Deck& deck, int threads) {
  const ContactDef& c = deck.contact;
  const ContactStiffness k = reference_stiffness(c, deck.sample);
  Json law = {{"normal", name_of(c.normal, kNormalModelNames)},
              {"tangential", name_of(c.tangential, kTangentialModelNames)},
              {"rolling", name_of(c.rolling, kRollingModelNames)},
              {"twisting", name_of(c.twisting, kTwistingModelNames)},
              {"reference_normal_stiffness", k.normal},
              {"reference_tangential_stiffness", k.tangential}};
  // Every other number the deck's choices use (the key table's rule, key_used); kn and kt are there as the
  // reference stiffnesses.
  for (const ContactParameter& parameter : kContactParameters)
    if (parameter.field != &ContactDef::kn && parameter.field != &ContactDef::kt &&
        key_used(*parameter.key, c.selection()))
      law[std::string(parameter.key->name())] = c.*parameter.field;
  Json settings = {{"deck", deck.source},
          {"particles", deck.sample.count},
          {"diameters_m", deck.sample.diameters},
          {"mean_diameter_m", mean_diameter(deck.sample)},
          {"density", deck.sample.density},
          {"seed", deck.sample.seed},
          {"time_step", deck.time_step},
          {"kn", deck.contact.kn},
          {"kt", deck.contact.kt},
          {"contact_law", law},
          {"tangential_rotation", name_of(deck.contact.rotation, kTangentialRotationNames)},
          {"moment_arm", name_of(deck.contact.moment_arm, kMomentArmNames)},
          {"kinematics", name_of(deck.kinematics, kKinematicsNames)},
          {"damping_translational", deck.damping.translational},
          {"damping_rotational", deck.damping.rotational},
          {"servo_gain", deck.servo.gain},
          {"servo_integral_gain", deck.servo.integral_gain},
          // null unless the deck gives it: each leg's cap then follows its rate (legs[].servo_cap in each test)
          {"servo_max_strain_increment", deck.servo.max_strain_increment_given
                                             ? Json(deck.servo.max_strain_increment)
                                             : Json(nullptr)},
          {"threads", threads}};
  // The stages that run with their own time step (prepare.time_step, tests[].time_step), each stage's [s].
  Json stage_steps = Json::object();
  if (deck.prepare && deck.prepare->time_step) stage_steps["prepare"] = *deck.prepare->time_step;
  for (const TestDef& t : deck.tests)
    if (t.time_step) stage_steps[t.name] = *t.time_step;
  if (!stage_steps.empty()) settings["stage_time_steps"] = stage_steps;
  // A deck rewritten by --tolerance: the tolerance and each stage's resolved settings beside the deck's
  // (io/tolerance); resolved_deck.json in the run directory is the deck that ran.
  if (deck.tolerance) {
    settings["tolerance"] = *deck.tolerance;
    settings["resolved"] = Json::parse(deck.tolerance_settings);
  }
  return settings;
}

Json grading_json(const GradingDef& grading, const std::vector<double>& diameters) {
  const std::vector<double> realised = realised_passing(grading, diameters);
  double worst = 0.0;
  for (std::size_t k = 0; k < realised.size(); ++k) worst = std::max(worst, std::abs(realised[k] - grading.passing[k]));
  return {{"by", name_of(grading.by, kGradingBasisNames)},
          {"sizes_m", grading.sizes},
          {"asked_percent", grading.passing},
          {"realised_percent", realised},
          {"largest_deviation_percent", worst},
          {"spheres", diameters.size()}};
}

std::vector<double> run_sample_diameters(const Deck& deck) {
  if (!deck.initial_state) return graded_sample_diameters(deck.sample);
  const State state = load_initial_state(deck);
  std::vector<double> d(state.particles.size());
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = 2.0 * state.particles.radius[i];
  return d;
}

}  // namespace celldem
