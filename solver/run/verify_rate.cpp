#include "run/verify_rate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <boost/math/distributions/normal.hpp>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "core/plan.hpp"
#include "io/files.hpp"
#include "run/program.hpp"
#include "run/reference_floors.hpp"
#include "run/run_directory.hpp"
#include "run/runner.hpp"
#include "run/stage_output.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
Json number_or_null(double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); }

// The axis that drives a leg (its largest |strain per step|), or -1 when no axis is strain-driven.
int driving_axis(const Leg& leg, double time_step) {
  int axis = -1;
  double largest = 0.0;
  for (int k = 0; k < 3; ++k)
    if (leg.axes[k].strain_driven() && std::abs(leg.strain_per_step(k, time_step)) > largest)
      largest = std::abs(leg.strain_per_step(k, time_step)), axis = k;
  return axis;
}

double positive_number(const Json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key) || !j[key].is_number() || !(j[key].get<double>() > 0.0) || !std::isfinite(j[key].get<double>()))
    throw UsageError(where + "." + key + ": a positive seed-to-seed standard deviation is needed here");
  return j[key].get<double>();
}

// The std of an ensemble.json's statistic, e.g. tests.ttc.peak_ratio13.std.
double ensemble_std(const Json& tests, const std::string& test, const std::string& quantity, const std::string& file) {
  const std::string where = file + ": tests." + test + "." + quantity;
  if (!tests.contains(test) || !tests[test].contains(quantity))
    throw UsageError(where + ": missing (the ensemble has no such test or quantity; give --floors a file of this deck's "
                    "ensemble)");
  return positive_number(tests[test][quantity], "std", where);
}

}  // namespace

NoiseFloors noise_floors(const std::string& path, const std::string& test, int particles) {
  NoiseFloors f;
  if (path.empty()) {
    // The reference ensemble (tests/run/reference.json, built in): its test of this name, else the mean of its
    // tests; it has no Z after shearing, so the prepared sample's Z spread stands in for it.
    const Json reference = Json::parse(kReferenceEnsembleJson);
    const Json& values = reference["values"];
    const int reference_particles = Json::parse(kReferenceDeckJson)["sample"]["count"].get<int>();
    const auto std_of = [&](const std::string& quantity) {
      if (values.contains(test + "." + quantity)) return values[test + "." + quantity]["std"].get<double>();
      double sum = 0.0;
      int count = 0;
      for (const auto& [key, v] : values.items())
        if (key.size() > quantity.size() && key.compare(key.size() - quantity.size(), quantity.size(), quantity) == 0 &&
            key.rfind("paired.", 0) != 0)
          sum += v["std"].get<double>(), ++count;
      return sum / count;
    };
    const double scale = std::sqrt(static_cast<double>(reference_particles) / particles);
    f.ratio13 = std_of("peak_robust.ratio13") * scale;
    f.ev = std_of("end_window.ev") * scale;
    f.Z = values["prepared.Z"]["std"].get<double>() * scale;
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "default: the reference ensemble's seed-to-seed std (tests/run/reference.json, %d seeds of %d "
                  "spheres; Z: the prepared sample's) x sqrt(%d / %d)",
                  values["prepared.Z"]["n"].get<int>(), reference_particles, reference_particles, particles);
    f.source = buf;
    return f;
  }
  Json j;
  try {
    j = Json::parse(read_file(path));
  } catch (const Json::parse_error& e) {
    throw UsageError(path + ": not JSON (" + e.what() + ")");
  }
  if (j.contains("statistics") || (j.contains("tests") && j["tests"].contains(test) &&
                                   j["tests"][test].contains("peak_ratio13"))) {  // an ensemble.json
    const Json& tests = j["tests"];
    f.ratio13 = ensemble_std(tests, test, "peak_ratio13", path);
    f.ev = ensemble_std(tests, test, "ev_final", path);
    f.Z = ensemble_std(tests, test, "Z_final", path);
    f.source = path + ": the ensemble's seed-to-seed std of tests." + test + ".{peak_ratio13, ev_final, Z_final}";
    return f;
  }
  const bool per_test = j.contains("tests") && j["tests"].contains(test);
  const Json& stds = per_test ? j["tests"][test] : j;
  const std::string where = path + ": " + (per_test ? "tests." + test : std::string("(top level)"));
  f.ratio13 = positive_number(stds, "ratio13", where);
  f.ev = positive_number(stds, "ev", where);
  f.Z = positive_number(stds, "Z", where);
  f.source = path;
  return f;
}

void check_verify_window(const VerifyRateOptions& check, const TestDef& test) {
  double longest = 0.0;
  for (const Leg& leg : test.legs)
    if (leg.end.kind == LegEndKind::Strain) longest = std::max(longest, std::abs(leg.end.value));
  if (longest > 0.0 && check.window_strain > longest) {
    char buf[320];
    std::snprintf(buf, sizeof buf, "--verify-window %g: longer than test '%s', whose driving strain ends at %g: give "
                  "a window shorter than the test (the default is %g)", check.window_strain, test.name.c_str(),
                  longest, keys::verify_rate_window_strain.fallback);
    throw UsageError(buf);
  }
}

BranchPoints::BranchPoints(const TestDef& test, const Deck& deck, const VerifyRateOptions& options)
    : test_(test), dt_(deck.stage_time_step(test)), options_(options) {}

void BranchPoints::on_row(const State& state, const SeriesRow& row) {
  const std::size_t index = rows_++;
  const int leg = state.control.leg;
  const int axis = driving_axis(test_.legs[static_cast<std::size_t>(leg)], dt_);
  const double strain = axis >= 0 ? axis_strains(state)[axis] : kNaN;
  if (axis >= 0) {
    const double spacing = 0.25 * options_.window_strain;  // reached up to round-off, as the window
    if (ring_.empty() || ring_.back().leg != leg || std::abs(strain - ring_.back().strain) >= spacing * (1.0 - 1e-9))
      ring_.push_back({std::make_shared<const State>(state), leg, strain});
    // Behind the newest state at least a window back, nothing is needed again (nor states of earlier legs).
    while (ring_.size() > 1 && (ring_.front().leg != leg ||
                                (ring_[1].leg == leg && std::abs(strain - ring_[1].strain) >= window_reached())))
      ring_.erase(ring_.begin());
  }
  last_ = start_for(leg, axis, strain, index);
  if (row.ratio13 > best_ratio_) {  // the summary's peak: the first row of the largest s11/s33
    best_ratio_ = row.ratio13;
    peak_ = last_;
  }
}

void BranchPoints::resume(const State& state, const std::vector<SeriesRow>& rows) {
  for (const SeriesRow& row : rows) best_ratio_ = std::max(best_ratio_, row.ratio13);
  rows_ = rows.size();
  resumed_ = true;
  const std::string missing = "the test was resumed after the window began (the states kept before are lost with "
                              "the run that was stopped; --force runs it again whole)";
  peak_ = Start{};
  peak_.missing = missing;
  last_ = peak_;
  // The state it resumes from: a start for the points a window after it.
  const int leg = state.control.leg;
  const int axis = driving_axis(test_.legs[static_cast<std::size_t>(leg)], dt_);
  if (axis >= 0) ring_.push_back({std::make_shared<const State>(state), leg, axis_strains(state)[axis]});
}

BranchPoints::Start BranchPoints::start_for(int leg, int axis, double strain, std::size_t row) const {
  Start s;
  s.leg = leg;
  s.axis = axis;
  s.point_strain = strain;
  s.point_row = row;
  if (axis < 0) {
    s.missing = "no strain-driven axis drives the point's leg (no driving strain to branch in)";
    return s;
  }
  const Kept* chosen = nullptr;  // the newest a whole window back, else the oldest of the leg (a shorter window)
  for (const Kept& k : ring_)
    if (k.leg == leg && std::abs(strain - k.strain) >= window_reached()) chosen = &k;
  if (!chosen)
    for (const Kept& k : ring_)
      if (k.leg == leg && k.strain != strain) {
        chosen = &k;
        break;
      }
  if (chosen) s.state = chosen->state, s.from_strain = chosen->strain;
  else s.missing = resumed_ ? "no state before the point in its leg (the test was resumed after the window began: "
                              "--force runs it again whole)"
                            : "no state before the point in its leg (the point is the leg's first row)";
  return s;
}

BranchPoints::Start BranchPoints::end() const { return last_; }

namespace {

// The leg a branch drives: the test's leg at rate x factor (strain increments and rates of the strain-driven
// axes, shear axes included, a stress ramp's rate from its target where the branch starts), ending at the point's
// strain.
Leg branch_leg(const Leg& parent, const BranchPoints::Start& start, double factor, double leg_time) {
  Leg leg = parent;
  for (AxisControl& a : leg.axes) {  // (a shear axis driven by its strain slows down alike)
    if (a.strain_driven()) a.value *= factor;
    if (a.mode == AxisMode::StressRamp) a.value = a.stress_target(leg_time), a.rate *= factor;
  }
  leg.end = LegEnd{};
  leg.end.kind = LegEndKind::Strain;
  leg.end.axis = start.axis;
  leg.end.value = start.point_strain;
  return leg;
}

// A difference from chaos alone: the branch shares the test's state at its start, so by the window's end the
// two differ at most as two independent seeds do, with a std of sqrt(2) floors. Beyond tolerance + this
// margin (two-sided 95 %), a difference is the rate's and not chance's.
double chaos_margin() { return boost::math::quantile(boost::math::normal_distribution<double>(), 0.975) * std::sqrt(2.0); }

Json compare(double parent, double branch, double floor, double tolerance) {
  const double floors = (branch - parent) / floor;
  return {{"parent", number_or_null(parent)}, {"branch", number_or_null(branch)},
          {"difference", number_or_null(branch - parent)}, {"floor", floor}, {"floors", number_or_null(floors)},
          {"within_tolerance", std::isfinite(floors) && std::abs(floors) <= tolerance}};
}

// The window's end is compared as the means over its last kEndShare (rows of the point's leg whose driving
// strain lies within that much of the point, on the window's side), for both series alike: one row's Z or
// s11/s33 jumps as a few contacts open and close, the mean over a few rows in the same strain range does not.
constexpr double kEndShare = 0.25;
struct EndMeans {
  double ratio13 = 0.0, ev = 0.0, Z = 0.0;
  int rows = 0;
};
EndMeans end_means(const std::vector<SeriesRow>& rows, const BranchPoints::Start& start, double span) {
  const double direction = start.point_strain >= start.from_strain ? 1.0 : -1.0;
  // A row at the point or at the span's edge, up to round-off: the rows hold the strains as written, to 10
  // significant digits (a row at the point was missed when the slack scaled with the span alone).
  const double slack = 1e-9 * (span + std::abs(start.point_strain));
  EndMeans m;
  for (const SeriesRow& r : rows) {
    const double before = direction * (start.point_strain - r.strain(start.axis));  // strain before the point
    if (r.leg == static_cast<double>(start.leg) && before >= -slack && before <= span + slack)
      m.ratio13 += r.ratio13, m.ev += r.ev, m.Z += r.Z, ++m.rows;
  }
  // No row in the span: no mean (NaN), so the comparison is not made, never a comparison of two zeros.
  const double count = m.rows ? m.rows : NAN;
  m.ratio13 /= count, m.ev /= count, m.Z /= count;
  return m;
}

std::string fmt(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

// Why a comparison of the end means could not be made: the side without a row in the span, or a row's value
// that is not a number (an s11/s33 at zero stress).
std::string end_means_gap(const EndMeans& test, const EndMeans& branch, double span, std::int64_t test_interval,
                          std::int64_t branch_interval) {
  if (test.rows == 0 || branch.rows == 0)
    return "no row of the " + std::string(test.rows == 0 ? "test" : "branch") + " in the window's last " + fmt(span) +
           " of strain; rows every " + std::to_string(test.rows == 0 ? test_interval : branch_interval) +
           " steps: a longer --verify-window or a shorter output_interval gives it rows";
  return "a row's value in the window's last " + fmt(span) + " of strain is not a number";
}

// The verdict of one point from its comparisons: converged when every difference is within the tolerance;
// not converged when one is beyond what chaos alone makes of one pair of runs; otherwise unresolved. A
// quantity that could not be compared (`not_compared`: no difference in floors) leaves the point unresolved
// unless another is already beyond the margin: a check that was not made never counts as passed.
void add_verdict(Json& point, double tolerance, const std::string& not_compared_why) {
  const double margin = chaos_margin();
  double largest = -1.0;
  std::string which, not_compared;
  for (const auto& [quantity, c] : point["comparisons"].items()) {
    if (!c["floors"].is_number()) {
      not_compared += (not_compared.empty() ? "" : ", ") + quantity;
      continue;
    }
    const double d = std::abs(c["floors"].get<double>());
    if (d > largest) largest = d, which = quantity;
  }
  point["largest"] = {{"quantity", which}, {"floors", largest >= 0.0 ? Json(largest) : Json(nullptr)}};
  point["tolerance_floors"] = tolerance;
  point["chaos_margin_floors"] = margin;
  const std::string at = which + " differs by " + fmt(largest) + " floors";
  if (!not_compared.empty()) point["not_compared"] = not_compared + ": " + not_compared_why;
  if (largest > tolerance + margin) {
    point["verdict"] = "not converged";
    point["reason"] = at + ", beyond the tolerance " + fmt(tolerance) + " plus the " + fmt(margin) +
                      " floors by which chaos alone can part one pair of runs (95 %): the rate moves the answer";
  } else if (!not_compared.empty()) {
    point["verdict"] = "unresolved";
    point["reason"] = not_compared + " not compared (" + not_compared_why + ")" +
                      (which.empty() ? std::string() : "; the largest compared: " + at);
  } else if (largest <= tolerance) {
    point["verdict"] = "converged";
    point["reason"] = "every difference within " + fmt(tolerance) + " floor(s); the largest: " + at + " (margin " +
                      fmt(tolerance - largest) + " floors; one branch is one sample of chaotic runs)";
  } else {
    point["verdict"] = "unresolved";
    point["reason"] = at + ": over the tolerance " + fmt(tolerance) + " but within it plus the " + fmt(margin) +
                      " floors by which chaos alone can part one pair of runs (95 %); one branch cannot tell (an ensemble "
                      "of seeds at both rates can)";
  }
}

}  // namespace

std::optional<VerifyRateOptions> verify_rate_for(const VerifyRateOptions& command_line, const TestDef& test) {
  if (!command_line.enabled && !test.verify_rate) return std::nullopt;
  VerifyRateOptions o = command_line;
  o.enabled = true;
  if (test.verify_rate) {
    if (!o.at_given) o.at = test.verify_rate->at;
    if (!o.window_given) o.window_strain = test.verify_rate->window_strain;
    if (!o.factor_given) o.rate_factor = test.verify_rate->rate_factor;
  }
  return o;
}

Json verify_test_rate(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                      const VerifyRateOptions& given, const BranchPoints& points, const std::vector<SeriesRow>& rows,
                      bool peak_reached) {
  VerifyRateOptions o = given;
  if (deck.tolerance) o.tolerance = *deck.tolerance;  // a run asked for a tolerance is checked against it
  const NoiseFloors floors = noise_floors(o.floors_path, test.name, deck.sample.count);
  Json result = {{"rate_factor", o.rate_factor}, {"window_strain", o.window_strain}, {"tolerance_floors", o.tolerance},
                 {"floors", {{"ratio13", floors.ratio13}, {"ev", floors.ev}, {"Z", floors.Z}, {"source", floors.source}}},
                 {"points", Json::object()}};
  for (const std::string& name : o.at) {
    const BranchPoints::Start start = name == "peak" ? points.peak() : points.end();
    Json point = {{"point", name}};
    // A test whose s11/s33 is largest at its last row has no peak (summary.json peak_reached): nothing to check.
    const bool no_peak = name == "peak" && !peak_reached;
    if (no_peak || !start.state) {
      point["verdict"] = "not checked";
      point["reason"] = no_peak ? "no peak reached: s11/s33 is largest at the end of the test (summary.json peak_reached)"
                                : start.missing;
      result["points"][name] = point;
      continue;
    }
    const SeriesRow& at = rows.at(start.point_row);
    State state = *start.state;
    const Model model = make_model(deck, state.particles.radius, deck.stage_time_step(test));
    // The test's legs up to the point's, which goes on from where the branch starts at its new rate (the servo
    // keeps its memory; the series' leg column stays the test's).
    std::vector<Leg> legs(test.legs.begin(), test.legs.begin() + start.leg + 1);
    // An adaptive leg's branch runs at a fixed rate: rate_factor times the rate the test had where the branch starts.
    legs.back() = branch_leg(legs.back(), start, o.rate_factor * state.control.rate_factor,
                             static_cast<double>(state.control.leg_steps) * model.dt);
    legs.back().adaptive.reset();
    restart_leg(state);
    const std::int64_t from_step = state.control.stage_steps;
    const std::int64_t interval =
        std::max<std::int64_t>(1, std::llround(static_cast<double>(test.output_interval) / o.rate_factor));
    const std::string stage = test.name + "/verify/" + name;
    point["window"] = {{"axis", std::string(kAxisNames[start.axis])}, {"leg", start.leg},
                       {"from_strain", start.from_strain}, {"to_strain", start.point_strain},
                       {"strain", std::abs(start.point_strain - start.from_strain)}, {"from_step", from_step},
                       {"point_step", at.step}, {"output_interval", interval}};
    try {
      StageOutput out(run, deck, options, model, stage, interval, /*loading_test=*/true);
      out.set_branch();
      out.open(state, /*resumed=*/false);
      Program program{legs, test.stage_friction(), &test.equilibrium,
                      from_step + leg_steps(legs.back(), model.dt, start.from_strain)};
      program.adaptive_threads = !options.fixed_threads;
      program.kind = StageKind::Test;
      program.stage = stage;
      program.control_failure = ControlFailure::Warn;  // recorded with the branch, not a stop of the run
      std::vector<ControlErrors> errors;
      run_program(model, program, state, out, errors);
      out.finish(state);
      const std::vector<SeriesRow>& branch = out.rows();
      point["window"]["steps"] = state.control.stage_steps - from_step;
      point["window"]["branch_end_strain"] = axis_strains(state)[start.axis];
      const ControlErrors& e = errors.back();
      point["controlled"] = std::none_of(e.failed.begin(), e.failed.end(), [](bool f) { return f; });
      // By quantity: with --seeds, ensemble.json then holds each difference's mean and interval over the seeds
      // (e.g. verify_rate.points.peak.comparisons.Z.floors), the answer one branch cannot give.
      Json comparisons = Json::object();
      if (name == "peak") {
        double peak = -INFINITY;
        for (const SeriesRow& r : branch) peak = std::max(peak, r.ratio13);
        comparisons["peak_ratio13"] = compare(at.ratio13, peak, floors.ratio13, o.tolerance);
      }
      const double span = kEndShare * std::abs(start.point_strain - start.from_strain);
      const EndMeans p = end_means(rows, start, span), b = end_means(branch, start, span);
      point["window"]["end_means"] = {{"strain", span}, {"parent_rows", p.rows}, {"branch_rows", b.rows}};
      comparisons["ratio13"] = compare(p.ratio13, b.ratio13, floors.ratio13, o.tolerance);
      comparisons["ev"] = compare(p.ev, b.ev, floors.ev, o.tolerance);
      comparisons["Z"] = compare(p.Z, b.Z, floors.Z, o.tolerance);
      point["comparisons"] = comparisons;
      point["series"] = (fs::path(test.name) / "verify" / name / "series.csv").string();
      add_verdict(point, o.tolerance, end_means_gap(p, b, span, test.output_interval, interval));
    } catch (const RunError& e) {
      point["verdict"] = "branch failed";
      point["reason"] = e.what();
    }
    result["points"][name] = point;
  }
  return result;
}

}  // namespace celldem
