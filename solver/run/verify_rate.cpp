#include "run/verify_rate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <stdexcept>

#include <boost/math/distributions/students_t.hpp>

#include "core/model.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "io/files.hpp"
#include "measure/richardson.hpp"
#include "run/errors.hpp"
#include "run/program.hpp"
#include "run/reference_floors.hpp"
#include "run/run_directory.hpp"
#include "run/stage_runner.hpp"
#include "run/summary.hpp"
#include "step.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kConfidence = 0.95;  // of each one-sided test (TOST at 5 %)
// The k-th twin runs at (1 + k this) times the test's rate. A change of one coordinate by one ulp (a round-off twin)
// parts from the test too slowly: on a test of 1000 steps its rows, written to 10 digits, were the test's to the last
// digit (tests/run/test_verify_rate.py). A rate change parts the two runs from the first step, as the slower run's
// does, while its own effect on the answer is about 1e-3 of the rate's whole effect.
constexpr double kTwinRateChange = 1e-3;
// Twins whose values of a quantity stay within this many floors (their std) have not parted from the test: the
// chaos is then unknown.
constexpr double kTwinParted = 1e-3;

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


double floor_of(const NoiseFloors& f, const std::string& name) {
  return name == "ratio13" ? f.ratio13 : name == "ev" ? f.ev : f.Z;
}

double t_quantile(double p, double dof) {
  return boost::math::quantile(boost::math::students_t_distribution<double>(dof), p);
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
    f.Z_sheared = false;
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

std::vector<double> checked_rungs(std::vector<double> rungs) {
  if (rungs.size() < 2)
    throw std::invalid_argument(
        "at least two rungs slower than the test are needed (with the test, three rates fit "
        "the order of the rate's effect)");
  for (const double r : rungs)
    if (!(r >= kMinRung && r <= kMaxRung))
      throw std::invalid_argument(fmt3(r) + " is outside [" + fmt3(kMinRung) + ", " + fmt3(kMaxRung) +
                                  "] (a rung's rate over the test's)");
  std::sort(rungs.begin(), rungs.end(), std::greater<>());
  for (std::size_t i = 1; i < rungs.size(); ++i)
    if (rungs[i] == rungs[i - 1]) throw std::invalid_argument(fmt3(rungs[i]) + " is given twice");
  return rungs;
}

std::vector<double> parse_rungs(const std::string& text) {
  std::vector<double> rungs;
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t comma = std::min(text.find(',', at), text.size());
    const std::string item = text.substr(at, comma - at);
    std::size_t used = 0;
    double v = kNaN;
    try {
      v = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size())
      throw std::invalid_argument("'" + item + "' is not a number (expected rates over the test's, e.g. 0.5,0.25)");
    rungs.push_back(v);
    at = comma + 1;
  }
  return checked_rungs(std::move(rungs));
}

std::vector<double> rungs_of_factor(double factor) { return {factor, factor * factor}; }

std::vector<std::string> RateCheckCost::lines() const {
  std::vector<std::string> out;
  char buf[256];
  const auto time = [this](double particle_steps) {
    if (!(particle_steps_per_s > 0.0) || !(particle_steps > 0.0)) return std::string();
    char seconds[64];
    std::snprintf(seconds, sizeof seconds, ", about %.0f s", particle_steps / particle_steps_per_s);
    return std::string(seconds);
  };
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (steps[i] < 0) {
      out.push_back("  " + names[i] + ": steps known only by running (a leg that does not end on its driven strain)");
      continue;
    }
    std::snprintf(buf, sizeof buf, "  %s: %lld steps, %.3g particle-steps", names[i].c_str(),
                  static_cast<long long>(steps[i]), particle_steps[i]);
    out.push_back(std::string(buf) + time(particle_steps[i]));
  }
  std::snprintf(buf, sizeof buf, "  in all%s: %.3g particle-steps", known ? "" : " (the runs whose steps are known)",
                total_particle_steps);
  std::string total = std::string(buf) + time(total_particle_steps);
  if (particle_steps_per_s > 0.0) {
    std::snprintf(buf, sizeof buf, " at %.3g particle-steps/s", particle_steps_per_s);
    total += buf;
  }
  out.push_back(total);
  return out;
}

RateCheckCost rate_check_cost(const Deck& deck, const TestDef& test, const VerifyRateOptions& check,
                              double particle_steps_per_s) {
  RateCheckCost c;
  c.particle_steps_per_s = particle_steps_per_s;
  const auto add = [&](const std::string& name, double factor) {
    const std::int64_t steps = plan_test(deck, slowed_test(test, factor)).steps;
    c.names.push_back(name);
    c.steps.push_back(steps);
    const double ps = steps < 0 ? 0.0 : static_cast<double>(deck.sample.count) * static_cast<double>(steps);
    c.particle_steps.push_back(ps);
    c.total_particle_steps += ps;
    c.known = c.known && steps >= 0;
  };
  for (const double r : check.rungs) add("rung " + fmt3(r) + "x", r);
  for (int k = 1; k <= check.twins; ++k) add("twin " + fmt(1.0 + k * kTwinRateChange) + "x", 1.0 + k * kTwinRateChange);
  return c;
}

TestDef slowed_test(const TestDef& test, double factor) {
  TestDef t = test;
  for (Leg& leg : t.legs) {
    for (AxisControl& a : leg.axes) {  // (a shear axis driven by its strain slows down alike)
      if (a.strain_driven()) a.value *= factor;
      if (a.mode == AxisMode::StressRamp) a.rate *= factor;
    }
    if (leg.rotation) leg.rotation->rate *= factor;
    if (leg.end.kind == LegEndKind::Steps)
      leg.end.steps = std::max<std::int64_t>(1, std::llround(static_cast<double>(leg.end.steps) / factor));
    if (leg.end.max_steps > 0)
      leg.end.max_steps = std::max<std::int64_t>(1, std::llround(static_cast<double>(leg.end.max_steps) / factor));
  }
  t.output_interval = std::max<std::int64_t>(1, std::llround(static_cast<double>(test.output_interval) / factor));
  t.verify_rate.reset();
  t.probes.reset();
  t.snapshots = {};
  return t;
}

std::optional<VerifyRateOptions> verify_rate_for(const VerifyRateOptions& command_line, const TestDef& test) {
  if (!command_line.enabled && !test.verify_rate) return std::nullopt;
  // The check fits runs at the rungs' factors times the test's rate. An adaptive leg sets its own rate from
  // what it measures, so a rung's driven rate is not its factor times the test's over the path (it climbs
  // back) and the extrapolated error would be false: the pair is refused, not judged.
  if (std::any_of(test.legs.begin(), test.legs.end(), [](const Leg& leg) { return leg.adaptive.has_value(); }))
    throw UsageError("test '" + test.name + "': " +
                     (command_line.enabled ? std::string("--verify-rate") : std::string("tests[].verify_rate")) +
                     " with tests[].adaptive_rate: each rung adapts its own rate, so it does not run at its "
                     "factor times the test's and the ladder's fit would be false; check the test without "
                     "adaptive_rate");
  VerifyRateOptions o = command_line;
  o.enabled = true;
  if (test.verify_rate) {
    if (!o.rungs_given) o.rungs = test.verify_rate->rungs;
    if (!o.twins_given) o.twins = test.verify_rate->twins;
  }
  return o;
}

namespace {

// One run of the check: the test (slowed, or as it is for the twin) from `state`, into <test>/verify/<name>/; its
// summary, or its error.
struct CheckRun {
  TestSummary summary;
  std::string series;  // its series.csv, relative to the run folder
  std::string error;
};
CheckRun run_check(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& t,
                   const std::string& name, State state) {
  CheckRun r;
  const Model model = make_model(deck, state.particles.radius, deck.stage_time_step(t));
  const std::string stage = t.name + "/verify/" + name;
  try {
    evaluate_forces(model, t.stage_friction(), state);
    const StageResult result = run_stage({run, deck, options}, model,
                                         {.name = stage,
                                          .legs = t.legs,
                                          .friction = t.stage_friction(),
                                          .equilibrium = &t.equilibrium,
                                          .planned_steps = plan_test(deck, t).steps,
                                          .output_interval = t.output_interval,
                                          .branch = true,
                                          .adaptive_threads = !options.fixed_threads,
                                          // recorded with the run, not a stop of the test's run
                                          .control_failure = ControlFailure::Warn},
                                         std::move(state));
    std::vector<std::string> warnings;
    r.summary = summarize_finished_test(deck, t, result, warnings);
    r.series = (fs::path(t.name) / "verify" / name / "series.csv").string();
  } catch (const RunError& e) {
    r.error = e.what();
  }
  return r;
}

RateCheckRun run_record(const std::string& name, double factor, const CheckRun& r) {
  RateCheckRun out;
  out.name = name;
  out.factor = factor;
  out.error = r.error;
  if (!r.error.empty()) return out;
  out.series = r.series;
  out.steps = r.summary.steps;
  out.wall_s = r.summary.wall_s;
  out.controlled = r.summary.controlled;
  out.peak_reached = r.summary.peak_reached;
  out.inertial_number = number_or_null(r.summary.inertial_number);
  out.compared = r.summary.compared;
  return out;
}

double sample_sd(const std::vector<double>& v) {
  if (v.size() < 2) return kNaN;
  double mean = 0.0, ss = 0.0;
  for (const double x : v) mean += x / static_cast<double>(v.size());
  for (const double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / static_cast<double>(v.size() - 1));
}

// One quantity's values over the runs, or the reason it cannot be compared (a rung or the test without its peak,
// a run failed).
QuantityLadder ladder_values(const ComparedQuantity& q, const NoiseFloors& floors, const TestSummary& test,
                             const std::vector<RateCheckRun>& runs, int rung_count) {
  QuantityLadder l;
  l.path = q.path;
  l.floor_name = q.floor;
  l.floor = floor_of(floors, q.floor);
  l.test = test.compared.*q.value;
  if (q.peak && !test.peak_reached) l.reason = "no peak reached by the test";
  for (int i = 0; i < static_cast<int>(runs.size()); ++i) {
    const RateCheckRun& r = runs[static_cast<std::size_t>(i)];
    const bool rung = i < rung_count;
    if (!r.error.empty() || (q.peak && !r.peak_reached)) {
      if (rung && l.reason.empty()) l.reason = (r.error.empty() ? "no peak reached by " : "failed: ") + r.name;
      continue;  // a twin without the quantity leaves the chaos to the others
    }
    (rung ? l.rungs : l.twins).push_back(r.compared.*q.value);
  }
  if (l.reason.empty() && (!std::isfinite(l.test) ||
                           std::any_of(l.rungs.begin(), l.rungs.end(), [](double x) { return !std::isfinite(x); })))
    l.reason = "a value is not a number";
  return l;
}

// The fit of one quantity and its verdict, its chaos from the test and its twins (their sample std, dof = twins).
void judge_ladder(QuantityLadder& l, const std::vector<double>& rungs, double tolerance, int family) {
  std::vector<double> rates = {1.0}, values = {l.test};
  rates.insert(rates.end(), rungs.begin(), rungs.end());
  values.insert(values.end(), l.rungs.begin(), l.rungs.end());
  std::vector<double> same_rate = {l.test};
  same_rate.insert(same_rate.end(), l.twins.begin(), l.twins.end());
  l.chaos_sd = sample_sd(same_rate);
  l.chaos_dof = static_cast<int>(same_rate.size()) - 1;
  // twins that did not part from the test say nothing of the chaos
  const bool parted = std::isfinite(l.chaos_sd) && l.chaos_sd / l.floor >= kTwinParted;
  const double alpha = 1.0 - kConfidence;
  const LadderFit at95 = fit_ladder(rates, values, parted ? l.chaos_sd : 0.0, l.chaos_dof, alpha);
  const LadderFit at_family = fit_ladder(rates, values, parted ? l.chaos_sd : 0.0, l.chaos_dof, alpha / family);
  l.q0 = at95.fit.q0;
  l.order = at95.fit.order;
  l.order_lo = at95.order_lo;
  l.order_hi = at95.order_hi;
  l.order_at_bound = at95.fit.order_at_bound;
  l.error_floors = at95.fit.c / l.floor;
  l.lo_floors = at95.distance_lo / l.floor;
  l.hi_floors = at95.distance_hi / l.floor;
  l.family_lo_floors = at_family.distance_lo / l.floor;
  l.family_hi_floors = at_family.distance_hi / l.floor;
  l.linear_floors = (l.test - l.rungs.front()) / (1.0 - rungs.front()) / l.floor;
  l.verdict = ladder_verdict(l.lo_floors, l.hi_floors, l.family_lo_floors, l.family_hi_floors, tolerance);
  if (!parted) l.reason = l.twins.empty() ? "no twins: the chaos is unknown" : "the twins did not part from the test";
}

Json quantity_json(const QuantityLadder& l) {
  Json c = {{"test", number_or_null(l.test)}, {"floor", l.floor}, {"floor_of", l.floor_name}};
  c["rungs"] = Json::array();
  for (const double x : l.rungs) c["rungs"].push_back(number_or_null(x));
  c["twins"] = Json::array();
  for (const double x : l.twins) c["twins"].push_back(number_or_null(x));
  if (l.verdict == "not compared") {
    c["verdict"] = l.verdict;
    c["reason"] = l.reason;
    return c;
  }
  c["chaos_sd"] = number_or_null(l.chaos_sd);
  c["chaos_dof"] = l.chaos_dof;
  c["chaos_sd_floors"] = number_or_null(l.chaos_sd / l.floor);
  c["quasi_static"] = number_or_null(l.q0);
  c["order"] = l.order;
  c["order_interval90"] = {number_or_null(l.order_lo), number_or_null(l.order_hi)};
  c["order_at_bound"] = l.order_at_bound;
  c["error_floors"] = number_or_null(l.error_floors);
  c["bounds95_floors"] = {number_or_null(l.lo_floors), number_or_null(l.hi_floors)};
  c["family_bounds_floors"] = {number_or_null(l.family_lo_floors), number_or_null(l.family_hi_floors)};
  c["linear_error_floors"] = number_or_null(l.linear_floors);
  c["verdict"] = l.verdict;
  if (!l.reason.empty()) c["reason"] = l.reason;
  return c;
}

Json run_json(const RateCheckRun& r) {
  if (!r.error.empty()) return {{"factor", r.factor}, {"failed", r.error}};
  return {{"factor", r.factor},
          {"series", r.series},
          {"steps", r.steps},
          {"wall_s", r.wall_s},
          {"controlled", r.controlled},
          {"peak_reached", r.peak_reached},
          {"inertial_number", r.inertial_number}};
}

// The test's verdict from its quantities'.
void overall_verdict(RateCheckResult& r) {
  std::string not_converged, unresolved, not_compared;
  const auto add = [](std::string& list, const std::string& item) { list += (list.empty() ? "" : ", ") + item; };
  for (const QuantityLadder& l : r.quantities) {
    if (l.verdict == "not compared") add(not_compared, l.path);
    if (l.verdict == "unresolved") add(unresolved, l.path + (l.reason.empty() ? "" : " (" + l.reason + ")"));
    if (l.verdict == "not converged") add(not_converged, l.path + " " + fmt3(l.error_floors));
    if (l.verdict != "not compared" && std::abs(l.error_floors) > r.largest)
      r.largest = std::abs(l.error_floors), r.largest_quantity = l.path;
  }
  const std::string rule =
      "the distance from I -> 0 by the ladder's fit, its one-sided 95 % bounds against T = " + fmt3(r.tolerance) +
      " floors; not converged at 0.05 / " + std::to_string(r.family) + " per quantity (Bonferroni over the " +
      std::to_string(r.family) + " compared)";
  if (!not_converged.empty()) {
    r.verdict = "not converged";
    r.reason = "beyond the tolerance: " + not_converged + " floors (" + rule + ")";
  } else if (!unresolved.empty() || !not_compared.empty() || r.family == 0) {
    r.verdict = "unresolved";
    r.reason =
        (unresolved.empty() ? std::string() : "not resolved: " + unresolved) +
        (not_compared.empty() ? "" : std::string(unresolved.empty() ? "" : "; ") + "not compared: " + not_compared) +
        " (" + rule + "); seeds can tell more (ensemble.json verify_rate)";
  } else {
    r.verdict = "converged";
    r.reason = "every quantity within the tolerance at 95 %: the largest distance " + r.largest_quantity + " " +
               fmt3(r.largest) + " floors (" + rule + ")";
  }
}

}  // namespace

std::string ladder_verdict(double lo, double hi, double family_lo, double family_hi, double tolerance) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) return "unresolved";
  if (lo > -tolerance && hi < tolerance) return "converged";
  if (family_lo > tolerance || family_hi < -tolerance) return "not converged";
  return "unresolved";
}

Json RateCheckResult::to_json() const {
  Json j = {{"rungs", rungs},
            {"twins", twins},
            {"tolerance_floors", tolerance},
            {"confidence", kConfidence},
            {"window_strain", kRateCheckWindow},
            {"extrapolation",
             "per quantity Q(r) = Q0 + C r^p fitted over the test (r = 1) and the rungs (Richardson "
             "extrapolation with the order p fitted within [" +
                 fmt3(kMinOrder) + ", " + fmt3(kMaxOrder) +
                 "]: exact with three rates, least squares with more); error = C / floor, the test's "
                 "distance from the quasi-static answer Q0 (I -> 0)"},
            {"chaos",
             {{"rule",
               "one run's chaos per quantity: the sample std of the test and its twins (at 1.001, 1.002 "
               "... times the rate; dof = twins), propagated through the fit by 4000 refits of the "
               "values plus normal deviates of that std (itself drawn from its scaled chi-square); "
               "the bounds are the refits' quantiles. No twins: unknown, and a single run is "
               "unresolved"}}},
            {"family",
             {{"quantities", family},
              {"rule",
               "converged: every compared quantity's one-sided 95 % bounds inside (-T, T) (an "
               "intersection-union test, no adjustment); not converged: a quantity's bound at "
               "0.05 / m beyond T (Bonferroni over the m compared: at most 5 % false flags per "
               "test)"}}},
            {"floors",
             {{"ratio13", floors.ratio13},
              {"ev", floors.ev},
              {"Z", floors.Z},
              {"Z_sheared", floors.Z_sheared},
              {"source", floors.source}}}};
  Json cost_runs = Json::array();
  for (std::size_t i = 0; i < cost.names.size(); ++i)
    cost_runs.push_back({{"run", cost.names[i]}, {"steps", cost.steps[i]}, {"particle_steps", cost.particle_steps[i]}});
  j["cost"] = {
      {"runs", cost_runs},
      {"particle_steps", cost.total_particle_steps},
      {"estimated_s", cost.particle_steps_per_s > 0 ? cost.total_particle_steps / cost.particle_steps_per_s : 0.0}};
  j["runs"] = Json::object();
  for (const RateCheckRun& r : runs) j["runs"][r.name] = run_json(r);
  j["comparisons"] = Json::object();
  for (const QuantityLadder& l : quantities) j["comparisons"][l.path] = quantity_json(l);
  j["largest"] = {{"quantity", largest_quantity}, {"error_floors", largest >= 0 ? Json(largest) : Json(nullptr)}};
  j["verdict"] = verdict;
  j["reason"] = reason;
  return j;
}

RateCheckResult verify_test_rate(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                                 const VerifyRateOptions& given, const State& start, const TestSummary& summary) {
  VerifyRateOptions o = given;
  if (deck.tolerance) o.tolerance = *deck.tolerance;  // a run asked for a tolerance is checked against it
  RateCheckResult r;
  r.rungs = o.rungs;
  r.twins = o.twins;
  r.tolerance = o.tolerance;
  r.floors = noise_floors(o.floors_path, test.name, deck.sample.count);
  r.cost = rate_check_cost(deck, test, o, summary.particle_steps_per_s);
  for (std::size_t i = 0; i < o.rungs.size(); ++i) {
    const std::string name = "rung-" + std::to_string(i + 1);
    r.runs.push_back(
        run_record(name, o.rungs[i], run_check(run, deck, options, slowed_test(test, o.rungs[i]), name, start)));
  }
  for (int k = 1; k <= o.twins; ++k) {
    const std::string name = "twin-" + std::to_string(k);
    const double factor = 1.0 + k * kTwinRateChange;
    r.runs.push_back(run_record(name, factor, run_check(run, deck, options, slowed_test(test, factor), name, start)));
  }
  const int rung_count = static_cast<int>(o.rungs.size());
  for (const ComparedQuantity& q : kRateCheckQuantities)
    r.quantities.push_back(ladder_values(q, r.floors, summary, r.runs, rung_count));
  for (const QuantityLadder& l : r.quantities) r.family += l.reason.empty() ? 1 : 0;
  for (QuantityLadder& l : r.quantities) {
    if (!l.reason.empty()) {
      l.verdict = "not compared";
      continue;
    }
    judge_ladder(l, o.rungs, o.tolerance, r.family);
  }
  overall_verdict(r);
  return r;
}

Json rate_check_across_seeds(const std::vector<std::uint64_t>& seeds, const std::vector<Json>& summaries) {
  Json out = Json::object();
  std::map<std::string, std::map<std::string, std::vector<double>>> errors;  // test -> quantity -> per seed
  std::map<std::string, std::vector<std::uint64_t>> checked;
  std::map<std::string, double> tolerance;
  for (std::size_t k = 0; k < summaries.size(); ++k) {
    const Json tests = summaries[k].value("tests", Json::object());
    for (const auto& [name, t] : tests.items()) {
      if (!t.contains("verify_rate") || !t["verify_rate"].contains("comparisons")) continue;
      checked[name].push_back(seeds[k]);
      tolerance[name] = t["verify_rate"].value("tolerance_floors", 1.0);
      for (const auto& [q, c] : t["verify_rate"]["comparisons"].items())
        if (c.contains("error_floors") && c["error_floors"].is_number()) errors[name][q].push_back(c["error_floors"]);
    }
  }
  for (const auto& [name, by_quantity] : errors) {
    const double T = tolerance[name];
    Json test = {{"seeds", checked[name]}, {"tolerance_floors", T}, {"confidence", kConfidence},
                 {"rule", "TOST on the seeds' errors in floors: the mean's one-sided 95 % bounds (Student's t, n - 1) "
                          "both inside (-T, T): converged; both beyond T on one side: not converged; else unresolved"},
                 {"quantities", Json::object()}};
    bool any_not = false, all_converged = true;
    for (const auto& [q, v] : by_quantity) {
      const std::size_t n = v.size();
      double mean = 0.0, var = 0.0;
      for (double x : v) mean += x / static_cast<double>(n);
      for (double x : v) var += (x - mean) * (x - mean);
      Json r = {{"n", n}, {"mean", mean}, {"values", v}};
      std::string verdict = "unresolved";
      if (n >= 2) {
        const double sd = std::sqrt(var / static_cast<double>(n - 1)), se = sd / std::sqrt(static_cast<double>(n));
        const double c = t_quantile(kConfidence, static_cast<double>(n - 1));
        const double lo = mean - c * se, hi = mean + c * se;
        r["std"] = sd, r["bounds95"] = {lo, hi};
        verdict = lo > -T && hi < T ? "converged" : (lo > T || hi < -T) ? "not converged" : "unresolved";
      }
      r["verdict"] = verdict;
      any_not = any_not || verdict == "not converged";
      all_converged = all_converged && verdict == "converged";
      test["quantities"][q] = r;
    }
    test["verdict"] = any_not ? "not converged" : all_converged ? "converged" : "unresolved";
    out[name] = test;
  }
  return out;
}

}  // namespace celldem
