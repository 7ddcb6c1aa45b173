#include "run/verify_rate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include <boost/math/distributions/normal.hpp>
#include <boost/math/distributions/students_t.hpp>

#include "core/model.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "io/files.hpp"
#include "run/program.hpp"
#include "run/reference_floors.hpp"
#include "run/run_directory.hpp"
#include "run/errors.hpp"
#include "run/stage_runner.hpp"
#include "run/summary.hpp"
#include "step.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kConfidence = 0.95;  // of each one-sided test (TOST at 5 %)
// A single run's chaos has two 95 % half-widths (its twin's, its bound's); the smaller of the two, each taken at
// 97.5 %, holds at 95 % (Bonferroni).
constexpr double kSideConfidence = 0.975;
// The twin runs at (1 + this) times the test's rate. A change of one coordinate by one ulp (a round-off twin) parts
// from the test too slowly: on a test of 1000 steps its rows, written to 10 digits, were the test's to the last
// digit (tests/run/test_verify_rate.py). A rate change parts the two runs from the first step, as the slower run's
// does, while its own effect on the answer is 1e-3 / (1 - factor) of the one measured (2e-3 at half the rate).
constexpr double kTwinRateChange = 1e-3;
// A twin whose compared quantities all stay within this many floors of the test's has not parted from it: the
// chaos is then unknown and taken at its bound.
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

double normal_quantile(double p) { return boost::math::quantile(boost::math::normal_distribution<double>(), p); }
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

PairChaos pair_chaos(double twin_floors, bool twin_parted) {
  PairChaos c;
  c.bound = normal_quantile(kSideConfidence) * std::sqrt(2.0);
  if (twin_parted && std::isfinite(twin_floors)) {
    c.twin = t_quantile(kSideConfidence, 1.0) * std::abs(twin_floors);
    c.half_width = std::min(c.twin, c.bound);
    c.from = c.twin < c.bound ? "twin" : "bound";
  } else {
    c.twin = kNaN;
    c.half_width = c.bound;
    c.from = "bound";
  }
  return c;
}

std::string rate_verdict(double d, double half_width, double tolerance) {
  if (!std::isfinite(d)) return "not compared";
  if (std::abs(d) + half_width <= tolerance) return "converged";
  if (std::abs(d) - half_width > tolerance) return "not converged";
  return "unresolved";
}

std::string RateCheckCost::words() const {
  char buf[320];
  if (slow_steps < 0)
    return "the test again at a slower rate" + std::string(twin_steps != 0 ? " and a twin" : "") +
           ": steps known only by running (a leg that does not end on its driven strain)";
  std::snprintf(buf, sizeof buf, "%lld steps at the slower rate%s%s: %.3g particle-steps", static_cast<long long>(slow_steps),
                twin_steps > 0 ? " and " : "", twin_steps > 0 ? (std::to_string(twin_steps) + " of the twin").c_str() : "",
                particle_steps);
  std::string s = buf;
  if (seconds > 0.0) {
    std::snprintf(buf, sizeof buf, ", about %.0f s at this test's speed", seconds);
    s += buf;
  }
  return s;
}

RateCheckCost rate_check_cost(const Deck& deck, const TestDef& test, const VerifyRateOptions& check,
                              double particle_steps_per_s) {
  RateCheckCost c;
  const std::int64_t test_steps = plan_test(deck, test).steps;
  c.slow_steps = plan_test(deck, slowed_test(test, check.rate_factor)).steps;
  c.twin_steps = check.twin ? test_steps : 0;
  if (c.slow_steps < 0 || test_steps < 0) {
    c.slow_steps = -1;
    return c;
  }
  c.particle_steps = static_cast<double>(deck.sample.count) * static_cast<double>(c.slow_steps + c.twin_steps);
  c.seconds = particle_steps_per_s > 0.0 ? c.particle_steps / particle_steps_per_s : 0.0;
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
  // The check extrapolates from a run at rate_factor times the test's rate. An adaptive leg sets its own rate from
  // what it measures, so the slower run's driven rate is not rate_factor times the test's over the path (it climbs
  // back) and the extrapolated error would be false: the pair is refused, not judged.
  if (std::any_of(test.legs.begin(), test.legs.end(), [](const Leg& leg) { return leg.adaptive.has_value(); }))
    throw UsageError("test '" + test.name + "': " +
                     (command_line.enabled ? std::string("--verify-rate") : std::string("tests[].verify_rate")) +
                     " with tests[].adaptive_rate: the slower run adapts its own rate, so it does not run at the "
                     "rate factor times the test's and the check's extrapolation would be false; check the test "
                     "without adaptive_rate");
  VerifyRateOptions o = command_line;
  o.enabled = true;
  if (test.verify_rate) {
    if (!o.factor_given) o.rate_factor = test.verify_rate->rate_factor;
    if (!o.twin_given) o.twin = test.verify_rate->twin;
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

Json run_record(const CheckRun& r) {
  if (!r.error.empty()) return {{"failed", r.error}};
  return {{"series", r.series}, {"steps", r.summary.json["steps"]}, {"wall_s", r.summary.wall_s},
          {"controlled", r.summary.controlled}, {"peak_reached", r.summary.peak_reached},
          {"inertial_number", r.summary.json["inertial_number"]}};
}

}  // namespace

Json verify_test_rate(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                      const VerifyRateOptions& given, const State& start, const TestSummary& summary) {
  VerifyRateOptions o = given;
  if (deck.tolerance) o.tolerance = *deck.tolerance;  // a run asked for a tolerance is checked against it
  const NoiseFloors floors = noise_floors(o.floors_path, test.name, deck.sample.count);
  const double speed = summary.particle_steps_per_s;
  const RateCheckCost cost = rate_check_cost(deck, test, o, speed);
  // The effect of the rate on the test: d = test - slower, and the test's own error extrapolated to the
  // quasi-static limit at first order in the rate, d / (1 - f).
  const double extrapolate = 1.0 / (1.0 - o.rate_factor);
  Json result = {{"rate_factor", o.rate_factor},
                 {"tolerance_floors", o.tolerance},
                 {"confidence", kConfidence},
                 {"extrapolation", "error = (test - slower) / (1 - rate_factor): the test's distance from the "
                                   "quasi-static limit if the rate's effect is linear in the rate"},
                 {"floors", {{"ratio13", floors.ratio13}, {"ev", floors.ev}, {"Z", floors.Z}, {"source", floors.source}}},
                 {"cost", {{"slow_steps", cost.slow_steps}, {"twin_steps", cost.twin_steps},
                           {"particle_steps", cost.particle_steps}, {"estimated_s", cost.seconds}}}};
  const CheckRun slow = run_check(run, deck, options, slowed_test(test, o.rate_factor), "slow", start);
  result["runs"]["slow"] = run_record(slow);
  CheckRun twin;
  if (o.twin) {
    twin = run_check(run, deck, options, slowed_test(test, 1.0 + kTwinRateChange), "twin", start);
    result["runs"]["twin"] = run_record(twin);
  }
  if (!slow.error.empty()) {
    result["verdict"] = "run failed";
    result["reason"] = "the slower run failed: " + slow.error;
    return result;
  }
  const bool test_peak = summary.peak_reached, slow_peak = slow.summary.peak_reached;
  const bool twin_ok = o.twin && twin.error.empty();
  const bool twin_peak = twin_ok && twin.summary.peak_reached;
  // Each quantity's test - twin in floors (NaN where the twin says nothing of it: no twin, or a peak not reached by
  // both). The twin parted from the test when these are not all within kTwinParted floors.
  std::map<std::string, double> twin_floors;
  double twin_sum = 0.0;
  int twin_n = 0;
  for (const ComparedQuantity& q : kRateCheckQuantities) {
    const bool compared = twin_ok && !(q.peak && !(test_peak && twin_peak));
    const double t = compared ? (summary.compared.*q.value - twin.summary.compared.*q.value) / floor_of(floors, q.floor)
                              : kNaN;
    twin_floors[q.path] = t;
    if (std::isfinite(t)) twin_sum += t * t, ++twin_n;
  }
  const bool twin_parted = twin_n > 0 && std::sqrt(twin_sum / twin_n) >= kTwinParted;
  result["chaos"] = {
      {"rule", "per quantity, the 95 % half-width of one pair's chaos in floors: the smaller of t(0.975, 1) |twin "
               "difference| (the twin is one sample of the chaos: Student's t with 1 degree of freedom) and z(0.975) "
               "sqrt 2 (the bound: two runs from one prepared sample differ by chaos at most as two seeds do), each at "
               "97.5 % so the smaller holds at 95 %; times 1 / (1 - rate_factor) as the error is"},
      {"twin_quantile", t_quantile(kSideConfidence, 1.0)},
      {"bound_half_width_floors", normal_quantile(kSideConfidence) * std::sqrt(2.0)},
      {"twin_parted", twin_parted}};
  if (o.twin && !twin.error.empty()) result["chaos"]["twin_failed"] = twin.error;
  if (twin_ok && !twin_parted)
    result["chaos"]["note"] = "the twin did not part from the test (its differences within " + fmt3(kTwinParted) +
                              " floors): the bound alone";
  Json comparisons = Json::object();
  std::string worst_verdict, largest_quantity, not_compared;
  double largest = -1.0;
  bool any_unresolved = false, any_not_converged = false;
  for (const ComparedQuantity& q : kRateCheckQuantities) {
    const double floor = floor_of(floors, q.floor);
    const double a = summary.compared.*q.value, b = slow.summary.compared.*q.value;
    Json c = {{"test", number_or_null(a)}, {"slow", number_or_null(b)}, {"floor", floor}};
    if (twin_ok && !(q.peak && !(test_peak && twin_peak))) {  // the differences pair_chaos is given
      c["twin"] = number_or_null(twin.summary.compared.*q.value);
      c["twin_floors"] = number_or_null(twin_floors[q.path]);
    }
    if (q.peak && !(test_peak && slow_peak)) {
      c["verdict"] = "not compared";
      c["reason"] = std::string("no peak reached by the ") + (test_peak ? "slower run" : "test");
      not_compared += std::string(not_compared.empty() ? "" : ", ") + q.path;
      comparisons[q.path] = c;
      continue;
    }
    const double d = (a - b) / floor, e = d * extrapolate;
    c["difference"] = number_or_null(a - b);
    c["floors"] = number_or_null(d);
    c["error_floors"] = number_or_null(e);
    const PairChaos chaos = pair_chaos(twin_floors[q.path], twin_parted);
    const double half_width = chaos.half_width * extrapolate;
    c["chaos_half_width_floors"] = half_width;
    c["chaos_from"] = chaos.from;
    const std::string v = rate_verdict(e, half_width, o.tolerance);
    c["verdict"] = v;
    if (v == "not compared") not_compared += std::string(not_compared.empty() ? "" : ", ") + q.path;
    any_unresolved = any_unresolved || v == "unresolved";
    any_not_converged = any_not_converged || v == "not converged";
    if (std::isfinite(e) && std::abs(e) > largest) largest = std::abs(e), largest_quantity = q.path;
    comparisons[q.path] = c;
  }
  result["comparisons"] = comparisons;
  result["largest"] = {{"quantity", largest_quantity}, {"error_floors", largest >= 0 ? Json(largest) : Json(nullptr)}};
  if (!not_compared.empty()) result["not_compared"] = not_compared;
  const std::string rule = "|error| -+ the chaos's 95 % half-width against T = " + fmt3(o.tolerance) +
                           " floors (comparisons.<quantity>.chaos_half_width_floors)";
  if (any_not_converged) {
    std::string which;
    for (const auto& [q, c] : comparisons.items())
      if (c["verdict"] == "not converged") which += (which.empty() ? "" : ", ") + q + " " + fmt3(c["error_floors"].get<double>());
    result["verdict"] = "not converged";
    result["reason"] = "the rate moves the answer beyond the tolerance at 95 %: " + which + " floors (" + rule + ")";
  } else if (any_unresolved || !not_compared.empty()) {
    result["verdict"] = "unresolved";
    result["reason"] = (largest_quantity.empty() ? std::string("nothing compared")
                                                 : "the largest error " + largest_quantity + " " + fmt3(largest) + " floors") +
                       (not_compared.empty() ? "" : "; not compared: " + not_compared) +
                       ": one pair cannot tell it from the tolerance at 95 % (" + rule +
                       "); seeds at both rates can (ensemble.json verify_rate)";
  } else {
    result["verdict"] = "converged";
    result["reason"] = "every error within the tolerance at 95 %: the largest " + largest_quantity + " " + fmt3(largest) +
                       " floors (" + rule + ")";
  }
  return result;
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
