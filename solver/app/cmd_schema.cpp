// celldem schema: the deck's keys and the series' columns, from the tables the code itself uses.
// celldem plan: what a deck implies before it runs (steps, rows, particle properties), for people and tools.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "io/deck_reader.hpp"
#include "io/schema_print.hpp"
#include "io/state_file.hpp"
#include "io/tolerance.hpp"
#include "measure/network_stiffness.hpp"
#include "measure/quasi_static.hpp"
#include "measure/series.hpp"
#include "neighbor/neighbor_list.hpp"
#include "run/health.hpp"
#include "run/preflight.hpp"
#include "run/probes.hpp"
#include "run/sample.hpp"
#include "run/summary.hpp"
#include "run/summary_schema.hpp"
#include "run/time_step_check.hpp"

namespace celldem::app {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {
// A stress probe plane's unit basis {"u1": [3], "u2": [3]} (run/probes.hpp plane_basis).
Json plane_basis_json(ProbePlane plane) {
  const auto [u1, u2] = plane_basis(plane);
  return {{"u1", u1}, {"u2", u2}};
}

// The solver's limits and conventions that the Python tools also judge runs by or draw with: read from here, never
// typed again there.
Json constants_json() {
  return {{"probe_planes",
           {{"value",
             {{std::string(name_of(ProbePlane::Rendulic, kProbePlaneNames)), plane_basis_json(ProbePlane::Rendulic)},
              {std::string(name_of(ProbePlane::Deviatoric, kProbePlaneNames)),
               plane_basis_json(ProbePlane::Deviatoric)}}},
            {"meaning",
             "each stress probe plane's unit basis u1, u2 (normal stresses 11, 22, 33): a direction at angle a is "
             "cos a u1 + sin a u2; a strain increment's coordinates in the plane are its projections on them"}}},
          {"quasi_static_inertial_number",
           {{"value", kQuasiStaticInertia},
            {"meaning",
             "a loading stage is quasi-static while its inertial number stays below this (a warning above)"}}},
          {"servo_tolerance",
           {{"value", kServoTolerance},
            {"meaning", "the largest relative error |s - target| / target a stress-controlled axis may keep "
                        "(summary.json servo_max_error; a maximum, not a standard deviation)"}}},
          {"b_tolerance", {{"value", kBTolerance}, {"meaning", "the largest error of a b-controlled axis's b"}}},
          {"mean_stress_tolerance",
           {{"value", kMeanStressTolerance}, {"meaning", "the largest relative error of a controlled mean stress"}}}};
}
// summary.json's keys (run/summary_schema.hpp), as JSON [{key, type, unit, meaning}] or a Markdown table.
std::string summary_schema_json() {
  Json out = Json::array();
  for (const SchemaEntry& e : summary_schema())
    out.push_back({{"key", e.path}, {"type", e.type}, {"unit", e.unit}, {"meaning", e.doc}});
  return out.dump(1) + "\n";
}

std::string summary_schema_markdown() {
  std::string text = "| key | type | unit | meaning |\n| --- | --- | --- | --- |\n";
  const auto cell = [](const std::string& s) {  // a | of the text ends no cell
    std::string out;
    for (const char c : s) {
      if (c == '|') out += '\\';
      out += c;
    }
    return out;
  };
  for (const SchemaEntry& e : summary_schema())
    text += "| `" + e.path + "` | " + cell(e.type) + " | " + e.unit + " | " + cell(e.doc) + " |\n";
  return text;
}
}  // namespace

Command add_schema_command(CLI::App& app) {
  struct Args {
    bool markdown = false, json = false, series = false, constants = false, summary = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("schema", "Print the deck keys (type, unit, default, range, meaning) or the "
                                               "series columns");
  cmd->add_flag("--series", a->series, "The series.csv columns instead of the deck keys");
  cmd->add_flag("--summary", a->summary, "The summary.json keys (path, type, unit, meaning) instead of the deck keys")
      ->excludes("--series");
  cmd->add_flag("--markdown", a->markdown, "A Markdown table (default)");
  cmd->add_flag("--json", a->json, "JSON");
  cmd->add_flag("--constants", a->constants,
                "The physical limits the solver checks runs against and the probe planes' bases, as JSON (for tools)");
  return [cmd, a]() -> int {
    if (!cmd->parsed()) return -1;
    if (a->markdown && a->json) throw CLI::ValidationError("--markdown and --json exclude each other");
    if (a->constants) {
      if (a->series || a->markdown) throw CLI::ValidationError("--constants excludes --series and --markdown");
      std::fputs((constants_json().dump(1) + "\n").c_str(), stdout);
      return 0;
    }
    const std::string text = a->summary  ? (a->json ? summary_schema_json() : summary_schema_markdown())
                             : a->series ? (a->json ? series_columns_json() : series_columns_markdown())
                                         : (a->json ? deck_schema_json() : deck_schema_markdown());
    std::fputs(text.c_str(), stdout);
    return 0;
  };
}

namespace {

Json axis_json(const AxisControl& a) {
  switch (a.mode) {
    case AxisMode::StrainIncrement: return {{"strain_increment", a.value}};
    case AxisMode::StrainRate: return {{"strain_rate", a.value}};
    case AxisMode::Stress: return {{"stress", a.value}};
    case AxisMode::B: return {{"b", a.value}};
    case AxisMode::MeanStress: return {{"mean_stress", a.value}};
    case AxisMode::ConstantVolume: return {{"constant_volume", true}};
    case AxisMode::StressRamp: return {{"stress_ramp", {{"from", a.value}, {"rate", a.rate}}}};
    case AxisMode::Held: return "held";
  }
  return nullptr;
}

Json end_json(const LegEnd& e) {
  Json j;
  switch (e.kind) {
    case LegEndKind::Strain: j = {{"axis", kComponentNames[static_cast<std::size_t>(e.axis)]}, {"strain", e.value}}; break;
    case LegEndKind::Ratio: j = {{"ratio", e.value}}; break;
    case LegEndKind::Stress: j = {{"axis", kAxisNames[e.axis]}, {"stress", e.value}}; break;
    case LegEndKind::Steps: j = {{"steps", e.steps}}; break;
    case LegEndKind::SolidFraction: j = {{"solid_fraction", e.value}}; break;
    case LegEndKind::Equilibrium: j = {{"equilibrium", true}}; break;
  }
  if (e.max_steps > 0) j["max_steps"] = e.max_steps;
  return j;
}

// A leg's end in words, from end_json.
std::string describe_end(const Json& end) {
  char buf[128];
  const auto num = [&](const char* key) { return end[key].get<double>(); };
  if (end.contains("strain"))
    std::snprintf(buf, sizeof buf, "ends at %s strain %.4g", end["axis"].get<std::string>().c_str(), num("strain"));
  else if (end.contains("stress"))
    std::snprintf(buf, sizeof buf, "ends at %s stress %.4g Pa", end["axis"].get<std::string>().c_str(), num("stress"));
  else if (end.contains("ratio")) std::snprintf(buf, sizeof buf, "ends at s11/s33 %.4g", num("ratio"));
  else if (end.contains("steps"))
    std::snprintf(buf, sizeof buf, "ends after %lld steps", static_cast<long long>(end["steps"].get<std::int64_t>()));
  else if (end.contains("solid_fraction")) std::snprintf(buf, sizeof buf, "ends at solid fraction %.4g", num("solid_fraction"));
  else std::snprintf(buf, sizeof buf, "ends in equilibrium");
  std::string text = buf;
  if (end.contains("max_steps")) text += " (max_steps " + std::to_string(end["max_steps"].get<std::int64_t>()) + ")";
  return text;
}

Json axes_json(const Leg& leg) {
  Json axes;
  for (int k = 0; k < kComponents; ++k)  // (a shear axis the leg does not name is held: left out)
    if (leg.axes[k].mode != AxisMode::Held) axes[std::string(kComponentNames[k])] = axis_json(leg.axes[k]);
  return axes;
}

Json known(std::int64_t n) { return n >= 0 ? Json(n) : Json(nullptr); }

// A program's legs as core/plan's plan_legs gives them, for a test and the preparation alike.
Json legs_json(const std::vector<Leg>& legs, const std::vector<LegPlan>& plans) {
  Json out = Json::array();
  for (std::size_t k = 0; k < legs.size(); ++k) {
    const LegPlan& p = plans[k];
    // What the servo can follow: the leg's driving strain per step against its cap (check refuses a ratio
    // below kMinServoCapRatio in a leg with servo axes).
    const double d = p.driving_increment, cap = p.servo_cap;
    out.push_back({{"axes", axes_json(legs[k])}, {"end", end_json(legs[k].end)},
                   {"steps", {{"low", p.steps.low}, {"high", known(p.steps.high)}}}, {"rows", known(p.rows)},
                   {"driving_increment", d}, {"driving_rate", p.driving_rate}, {"servo_cap", cap}, {"servo", p.servo},
                   {"cap_ratio", d > 0.0 ? Json(cap / d) : Json(nullptr)}});
    if (const std::optional<AdaptiveRate>& a = legs[k].adaptive)
      out.back()["adaptive_rate"] = {{"min_factor", a->min_factor}, {"max_factor", a->max_factor},
                                     {"unbalanced_force_ratio", a->unbalanced_force_ratio},
                                     {"kinetic_to_elastic", a->kinetic_to_elastic},
                                     {"inertial_number", a->inertial_number}, {"check_interval", a->check_interval}};
  }
  return out;
}

// The mean contact at the deck's confining stress (null when the deck names no stress): core/plan's definitions.
Json mean_contact_json(const Deck& deck) {
  const ContactDef& c = deck.contact;
  const std::optional<MeanContact> m = mean_contact(deck);
  if (!m) return nullptr;
  return {
      {"confining_stress", m->confining_stress},
      {"z_phi", kMeanContactZPhi},
      {"mean_diameter", m->mean_diameter},
      {"effective_radius", m->effective_radius},
      {"force", m->force},
      {"overlap", m->overlap},
      {"secant_normal_stiffness", m->secant_normal_stiffness},
      {"contact_radius", m->contact_radius},
      {"mindlin_tangential_stiffness", has_material_moduli(c) ? Json(m->mindlin_tangential_stiffness) : Json(nullptr)},
      {"units",
       {{"confining_stress", "Pa"},
        {"mean_diameter", "m"},
        {"effective_radius", "m"},
        {"force", "N"},
        {"overlap", "m"},
        {"secant_normal_stiffness", "N/m"},
        {"contact_radius", "m"},
        {"mindlin_tangential_stiffness", "N/m"}}},
      {"definitions",
       {{"confining_stress",
         "p: the deck's largest stress (preparation target, stress and mean_stress axes, "
         "stress ends)"},
        {"force",
         "F = pi d^2 p / (Z phi): p = Z N <f l> / (6 V) (N_c = Z N / 2 contacts) with l = d, "
         "N = phi V / (pi d^3 / 6)"},
        {"effective_radius", "R* = d / 4 (two spheres of the mean diameter d)"},
        {"overlap", "delta under F by the normal law: F / kn, or hertz (3 F / (4 E* sqrt(R*)))^(2/3)"},
        {"secant_normal_stiffness", "F / delta"},
        {"contact_radius", "a = sqrt(R* delta)"},
        {"mindlin_tangential_stiffness", "8 G* a"}}}};
}

// One test's entry of `plan --json`: its steps, legs, rows, inertial number, time step, probes and equilibrium.
Json test_plan_json(const Deck& deck, const TestDef& t, double dt_crit) {
  const TestPlan p = plan_test(deck, t);
  const Leg& first = t.legs.front();
  const double stress = first_leg_stress(t);
  const Json inertia =
      std::isnan(stress)
          ? Json(nullptr)
          : Json(inertial_number(loading_rate(deck, t), mean_diameter(deck.sample), deck.sample.density, stress));
  Json legs = legs_json(t.legs, p.legs);
  for (std::size_t k = 0; k < t.legs.size(); ++k) {
    // Only for the new kinds of leg, so that every other deck's plan stays as it was.
    const Leg& leg = t.legs[k];
    if (const std::int64_t n = ramp_target_steps(leg, deck.stage_time_step(t)); n >= 0)
      legs[k]["ramp_target_steps"] = n;
    if (leg.end.kind == LegEndKind::Equilibrium)  // the leg's own end.max_steps, else the criterion's
      legs[k]["equilibrium_max_steps"] = leg.end.max_steps > 0 ? leg.end.max_steps : t.equilibrium.max_steps;
  }
  const bool holds =
      std::any_of(t.legs.begin(), t.legs.end(), [](const Leg& leg) { return leg.end.kind == LegEndKind::Equilibrium; });
  Json out = {{"name", t.name},
              {"friction", t.friction},
              {"steps", known(p.steps)},
              {"end_axis", kAxisNames[first.end.axis]},
              {"end_strain", first.end.value},
              {"strain_per_step", p.strain_per_step},
              {"strain_rate", p.strain_rate},
              {"output_interval", t.output_interval},
              {"rows", known(p.rows)},
              {"axes", axes_json(first)},
              {"legs", legs},
              {"inertial_number", inertia},
              {"time_step", deck.stage_time_step(t)},
              {"time_step_ratio", deck.stage_time_step(t) / dt_crit}};
  if (t.probes) {
    const ProbePlan probes = plan_probes(t);
    const std::int64_t first = probe_number_offset(deck, t) + 1;  // --probes numbers, one numbering over the deck
    out["probes"] = {{"points", probes.points},
                     {"probes_per_point", probes.probes_per_point},
                     {"steps_per_probe", probes.steps_per_probe},
                     {"check_probes_per_point", probes.check_probes_per_point},
                     {"rest_steps_per_point", probes.rest_steps_per_point},
                     {"steps", probes.steps()},
                     {"numbers", {first, first + probes.points * (probes.probes_per_point - 1) - 1}}};
  }
  if (holds) {
    const EquilibriumDef& e = t.equilibrium;
    out["equilibrium"] = {{"pressure_tolerance", e.pressure_tolerance},
                          {"stress_tolerance", e.stress_tolerance},
                          {"unbalanced_force_ratio", e.unbalanced_force_ratio},
                          {"min_steps", e.min_steps},
                          {"check_interval", e.check_interval},
                          {"max_steps", e.max_steps}};
  }
  return out;
}

Json plan_json(const Deck& deck) {
  Json types = Json::array();
  std::vector<double> seen;
  // A grading's spheres take every size between its sieves: the bodies at the sieve sizes bound them.
  for (double d : deck.sample.grading ? deck.sample.grading->sizes : deck.sample.diameters) {
    if (std::find(seen.begin(), seen.end(), d) != seen.end()) continue;
    seen.push_back(d);
    const BodyProperties b = body_properties(0.5 * d, deck.sample.density, deck.damping, reference_stiffness(deck.contact, deck.sample));
    types.push_back({{"diameter", d}, {"mass", b.mass}, {"inertia", b.inertia},
                     {"translational_drag", b.translational_drag}, {"rotational_drag", b.rotational_drag}});
  }
  const CriticalTimeStep limits = critical_time_steps(deck.sample, deck.contact);
  const double dt_crit = limits.value();
  Json modes = Json::object();
  for (const ModeLimit& m : limits.modes)
    modes[m.name] = {{"stiffness_name", m.stiffness_name}, {"stiffness", m.stiffness}, {"omega", m.omega},
                     {"time_step", std::isfinite(m.time_step) ? Json(m.time_step) : Json(nullptr)}};
  Json bounds = Json::array();
  for (const TimeStepBound& b : kTimeStepBounds)
    bounds.push_back({{"name", b.name}, {"action", b.refuse ? "refuse" : "warn"}, {"when", b.above ? "above" : "below"},
                      {"fraction", b.fraction}, {"of", b.of_normal_mode ? "normal_time_step" : "critical_time_step"},
                      {"time_step", b.fraction * bound_base(b, limits)}, {"why", b.why}});
  Json out = {{"deck", deck.source},
              {"time_step", deck.time_step},
              {"critical_time_step", dt_crit},
              {"time_step_ratio", deck.time_step / dt_crit},
              {"limiting_mode", limits.limiting().name},
              {"time_step_limits", modes},
              {"normal_time_step", limits.modes[0].time_step},
              {"time_step_bounds", bounds},
              {"skin", skin_length(deck)},
              {"sample", {{"count", deck.sample.count}, {"diameters", deck.sample.diameters},
                          {"density", deck.sample.density}, {"mean_diameter", mean_diameter(deck.sample)},
                          {"mean_sphere_volume", mean_sphere_volume(deck.sample)},
                          {"seed", deck.sample.seed}, {"grading", nullptr}}},
              {"particle_types", types},
              {"prepare", nullptr},
              {"initial_state", nullptr},
              {"tests", Json::array()}};
  // The material's moduli (null for a law without E and nu) and the mean contact at the confining stress
  // (null when the deck names no stress): core/plan's definitions, for the tools.
  const ContactDef& c = deck.contact;
  out["contact"] = {{"effective_modulus", has_material_moduli(c) ? Json(c.effective_modulus()) : Json(nullptr)},
                    {"effective_shear_modulus", has_material_moduli(c) ? Json(c.effective_shear_modulus()) : Json(nullptr)},
                    {"units", {{"effective_modulus", "Pa"}, {"effective_shear_modulus", "Pa"}}},
                    {"definitions", {{"effective_modulus", "E* = E / (2 (1 - nu^2))"},
                                     {"effective_shear_modulus", "G* = E / (4 (2 - nu) (1 + nu))"}}}};
  out["mean_contact"] = mean_contact_json(deck);
  if (const std::optional<GradingDef>& g = deck.sample.grading) {
    // The sample the seed draws; an initial_state's spheres are the run's (summary.json's "grading").
    Json grading = grading_json(*g, deck.initial_state ? std::vector<double>{} : graded_sample_diameters(deck.sample));
    if (deck.initial_state)
      grading["realised_percent"] = grading["largest_deviation_percent"] = grading["spheres"] = nullptr;
    out["sample"]["grading"] = grading;
  }
  if (deck.prepare)
    out["prepare"] = {{"friction", deck.prepare->friction}, {"target_pressure", deck.prepare->target_pressure},
                      {"fast_solid_fraction", deck.prepare->fast_solid_fraction},
                      {"fast_strain_increment", deck.prepare->fast_strain_increment},
                      {"output_interval", deck.prepare->output_interval},
                      {"time_step", deck.stage_time_step(*deck.prepare)},
                      {"time_step_ratio", deck.stage_time_step(*deck.prepare) / dt_crit}};
  if (deck.initial_state) out["initial_state"] = (fs::path(deck.source).parent_path() / *deck.initial_state).string();
  double start_fraction = -1.0;  // a preparation from initial_state starts at the state's solid fraction
  if (deck.prepare && deck.initial_state) {
    const PreparationStart start = preparation_start(deck);
    start_fraction = start.solid_fraction;
    out["prepare"]["start"] = {{"solid_fraction", start_fraction},
                               {"dilation", start.relaxation.factor},
                               {"worst_overlap", start.relaxation.before.worst},
                               {"worst_overlap_after", start.relaxation.after.worst},
                               {"fast_leg_skipped", preparation_program(*deck.prepare, start_fraction).skipped > 0}};
  }
  const RunEstimate estimate = estimate_run(deck, start_fraction);
  const auto steps = [](const StepRange& r) { return Json{{"low", r.low}, {"high", r.high < 0 ? Json() : Json(r.high)}}; };
  if (deck.prepare) {
    out["prepare"]["steps"] = steps(estimate.preparation);
    const PreparationPlan prep = plan_preparation(deck, start_fraction);
    out["prepare"]["legs"] = legs_json(prep.legs, prep.listed);
    std::int64_t rows = 0;
    for (const LegPlan& leg : prep.listed) rows = rows < 0 || leg.rows < 0 ? -1 : rows + leg.rows;
    out["prepare"]["rows"] = known(rows);
  }
  out["estimate"] = {{"bytes", estimate.bytes}, {"preparation_steps", steps(estimate.preparation)},
                     {"test_steps", steps(estimate.tests)}, {"particle_steps_low", estimate.particle_steps_low},
                     {"particle_steps_high", estimate.particle_steps_high < 0 ? Json() : Json(estimate.particle_steps_high)},
                     {"particle_steps_per_core_second", kParticleStepsPerCoreSecond}};
  for (const TestDef& t : deck.tests) out["tests"].push_back(test_plan_json(deck, t, dt_crit));
  return out;
}

// The floor model's line: what T floors of this deck are in the rules' scene.
std::string describe_calibration(const Json& t) {
  if (!t.contains("calibration") || !t["calibration"].contains("calibration_particles")) return "";
  const Json& c = t["calibration"];
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "time steps from the rules' level at %.3g floors of their %d-sphere scene (%g floors of "
                "these %.0f spheres, floors as 1/sqrt(N))",
                c["table_tolerance"].get<double>(), c["calibration_particles"].get<int>(), c["tolerance"].get<double>(),
                c["particles"].get<double>());
  return buf;
}

// Where the rate bias laws put the deck: the inertial number T allows, and each written leg's distance from I -> 0.
std::vector<std::string> describe_rate(const Json& t) {
  std::vector<std::string> lines;
  if (!t.contains("rate")) return lines;
  const Json& r = t["rate"];
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "strain-driven legs at actual inertial number %.3g (set by %s; checked after each test)",
                r["inertial_number"].get<double>(), r["limiting"].get<std::string>().c_str());
  lines.push_back(buf);
  for (const Json& w : r["written"]) {
    std::string d;
    for (const auto& [q, v] : w["distance_floors"].items()) {
      std::snprintf(buf, sizeof buf, "%s%s %.2f (up to %.2f)", d.empty() ? "" : ", ", q.c_str(), v[0].get<double>(),
                    v[1].get<double>());
      d += buf;
    }
    const double f = w["rate_factor"].get<double>();
    std::snprintf(buf, sizeof buf, "%s as written: I %.3g, %s floors from I -> 0; %s %.3gx",
                  w["stage"].get<std::string>().c_str(), w["inertial_number"].get<double>(), d.c_str(),
                  w["slowed"].get<bool>() ? "slowed" : "sped up", w["slowed"].get<bool>() ? 1.0 / f : f);
    lines.push_back(buf);
  }
  lines.push_back("promise: " + r["promise"].get<std::string>());
  return lines;
}

// The tolerance block of `plan` in words: per stage its time step, each leg's driving and inertial number,
// the damping, the output interval and the particle-steps against the deck as written.
void print_tolerance(const Json& t) {
  const auto steps = [](const Json& s) {
    char buf[96];
    if (s["high"].is_null()) std::snprintf(buf, sizeof buf, "%.3g or more", s["low"].get<double>());
    else if (s["high"] == s["low"]) std::snprintf(buf, sizeof buf, "%.3g", s["low"].get<double>());
    else std::snprintf(buf, sizeof buf, "%.3g to %.3g", s["low"].get<double>(), s["high"].get<double>());
    return std::string(buf);
  };
  const auto ratio = [](const Json& r) { return r.is_null() ? std::string("?") : std::to_string(r.get<double>()).substr(0, 5); };
  const Json& rules = t["rules"];
  std::printf(
      "tolerance %g noise floors from I -> 0 (io/time_to_answer_rules.json): time step %.3f of the stability "
      "limit %.3g s (preparation %.3f), actual inertial number %.3g, damping translational %.3g rotational %.3g\n",
      t["tolerance"].get<double>(), rules["time_step_fraction"].get<double>(), t["stability_limit"].get<double>(),
      rules["prepare_time_step_fraction"].get<double>(), rules["inertial_number"].get<double>(),
      t["damping"]["translational"].get<double>(), t["damping"]["rotational"].get<double>());
  if (const std::string c = describe_calibration(t); !c.empty()) std::printf("  %s\n", c.c_str());
  for (const std::string& line : describe_rate(t)) std::printf("  %s\n", line.c_str());
  for (const Json& s : t["stages"]) {
    std::printf("  %-12s dt %.3g s = %.3f of the limit (written %.3g s = %.3f); output every %lld steps (written %lld); "
                "%s particle-steps (written %s: %sx)\n",
                s["stage"].get<std::string>().c_str(), s["time_step"].get<double>(), s["time_step_fraction"].get<double>(),
                s["time_step_written"].get<double>(), s["time_step_fraction_written"].get<double>(),
                static_cast<long long>(s["output_interval"].get<std::int64_t>()),
                static_cast<long long>(s["output_interval_written"].get<std::int64_t>()), steps(s["particle_steps"]).c_str(),
                steps(s["particle_steps_written"]).c_str(), ratio(s["ratio_low"]).c_str());
    if (s.value("network_capped", false))
      std::printf(
          "    time step capped at %.3g of the contact network's limit, estimated at %.3g s before the packing "
          "exists (the rules' %.3g s would exceed it; docs/physics.md)\n",
          kNetworkWarnFraction, s["network_time_step_estimate"].get<double>(), s["time_step_rules"].get<double>());
    if (s.contains("fast_strain_increment"))
      std::printf("    fast compression %.3g per step (written %.3g)\n", s["fast_strain_increment"].get<double>(),
                  s["fast_strain_increment_written"].get<double>());
    if (s.contains("servo_max_strain_increment"))
      std::printf("    servo cap %.3g per step (written %.3g): the same strain rate\n",
                  s["servo_max_strain_increment"].get<double>(), s["servo_max_strain_increment_written"].get<double>());
    if (s.contains("equilibrium"))
      std::printf("    equilibrium: min_steps %lld (written %lld), checked every %lld (written %lld)\n",
                  static_cast<long long>(s["equilibrium"]["min_steps"].get<std::int64_t>()),
                  static_cast<long long>(s["equilibrium"]["min_steps_written"].get<std::int64_t>()),
                  static_cast<long long>(s["equilibrium"]["check_interval"].get<std::int64_t>()),
                  static_cast<long long>(s["equilibrium"]["check_interval_written"].get<std::int64_t>()));
    for (std::size_t j = 0; j < s["legs"].size(); ++j) {
      const Json& leg = s["legs"][j];
      if (!leg["strain_driven"].get<bool>()) {
        std::printf("    leg %zu: no strain-driven axis (its step ends keep their time)\n", j);
        continue;
      }
      std::printf("    leg %zu: %.3g per step = %.3g /s (written %.3g per step = %.3g /s)", j,
                  leg["driving_increment"].get<double>(), leg["strain_rate"].get<double>(),
                  leg["driving_increment_written"].get<double>(), leg["strain_rate_written"].get<double>());
      if (leg.contains("inertial_number"))
        std::printf(", actual inertial number %.3g predicted (written %.3g) at %.3g Pa: imposed %.3g x %.3g (%s path)",
                    leg["inertial_number"].get<double>(), leg["inertial_number_written"].get<double>(),
                    leg["confining_stress"].get<double>(), leg["imposed_inertial_number"].get<double>(),
                    leg["actual_to_imposed"].get<double>(), leg["path"].get<std::string>().c_str());
      else if (leg.contains("imposed_inertial_number"))
        std::printf(", imposed inertial number %.3g (written %.3g) at %.3g Pa",
                    leg["imposed_inertial_number"].get<double>(), leg["imposed_inertial_number_written"].get<double>(),
                    leg["confining_stress"].get<double>());
      std::printf("\n");
    }
  }
  // ratio_low is written over resolved: above 1 the tolerance saves steps, below 1 (a deck slowed toward I -> 0) it
  // costs more, which the line says as such rather than as a fraction "fewer".
  const Json& low = t["total"]["ratio_low"];
  const std::string cost = low.is_number() && low.get<double>() > 0.0 && low.get<double>() < 1.0
                               ? ratio(1.0 / low.get<double>()) + "x more"
                               : ratio(low) + "x fewer";
  std::printf("  total        %s particle-steps (written %s: %s, counting each equilibrium at its min_steps)\n",
              steps(t["total"]["particle_steps"]).c_str(), steps(t["total"]["particle_steps_written"]).c_str(),
              cost.c_str());
}

}  // namespace

// What --tolerance did (io/tolerance's resolved settings per stage) and the particle-steps each stage is
// predicted to take, against the deck as written and the ratio.
Json tolerance_json(const Deck& written, const Deck& resolved) {
  Json out = Json::parse(resolved.tolerance_settings);
  const double n = resolved.sample.count;
  const auto steps_json = [n](const StepRange& w, const StepRange& r) {
    const auto high = [n](const StepRange& s) { return s.high < 0 ? Json() : Json(n * static_cast<double>(s.high)); };
    return Json{{"particle_steps_written", {{"low", n * static_cast<double>(w.low)}, {"high", high(w)}}},
                {"particle_steps", {{"low", n * static_cast<double>(r.low)}, {"high", high(r)}}},
                {"ratio_low", r.low > 0 ? Json(static_cast<double>(w.low) / static_cast<double>(r.low)) : Json()}};
  };
  double start_fraction = -1.0;
  if (written.prepare && written.initial_state) start_fraction = preparation_start(written).solid_fraction;
  StepRange all_written, all;
  const auto add = [](StepRange& a, const StepRange& b) {
    a.low += b.low;
    a.high = a.high < 0 || b.high < 0 ? -1 : a.high + b.high;
  };
  std::size_t k = 0;
  if (written.prepare) {
    const StepRange w = preparation_steps(written, start_fraction), r = preparation_steps(resolved, start_fraction);
    out["stages"][k++].update(steps_json(w, r));
    add(all_written, w), add(all, r);
  }
  for (std::size_t i = 0; i < written.tests.size(); ++i) {
    const StepRange w = test_steps(written, written.tests[i]), r = test_steps(resolved, resolved.tests[i]);
    out["stages"][k++].update(steps_json(w, r));
    add(all_written, w), add(all, r);
  }
  out["total"] = steps_json(all_written, all);
  return out;
}

std::string describe_tolerance(const Json& t) {
  const Json& total = t["total"];
  const double ratio = total["ratio_low"].is_null() ? NAN : total["ratio_low"].get<double>();
  char buf[512];
  const Json& rules = t["rules"];
  std::snprintf(
      buf, sizeof buf,
      "tolerance %g noise floors from I -> 0 (io/time_to_answer_rules.json): time step %.3f "
      "of the stability limit, actual inertial number %.3g; predicted %.3g particle-steps against %.3g as written: "
      "%.3gx the deck's cost (each equilibrium at its min_steps; `celldem plan --tolerance %g` has every "
      "setting)",
      t["tolerance"].get<double>(), rules["time_step_fraction"].get<double>(), rules["inertial_number"].get<double>(),
      total["particle_steps"]["low"].get<double>(), total["particle_steps_written"]["low"].get<double>(), 1.0 / ratio,
      t["tolerance"].get<double>());
  std::string words = buf;
  std::string capped;
  for (const Json& s : t["stages"])
    if (s.value("network_capped", false)) capped += (capped.empty() ? "" : ", ") + s["stage"].get<std::string>();
  if (!capped.empty())
    words += "; time step capped at " + fmt3(kNetworkWarnFraction) + " of the contact network's estimated limit in " +
             capped;
  if (const std::string c = describe_calibration(t); !c.empty()) words += "; " + c;
  for (const std::string& line : describe_rate(t)) words += "\n  " + line;
  return words;
}

// The stability limit from the contact network of a state (measure/network_stiffness.hpp network_time_step_limit)
// beside the pair formula's, and the deck's time step against both: `plan`'s "network_time_step", when the deck
// has an initial_state or `--state` names a state file. Then each stage that would start from that state (the tests;
// the preparation too when the state is initial_state) judged as run_stage judges it (run/time_step_check: the
// stage's time step and friction), and the cost of the run's checks.
Json network_time_step_json(const Deck& deck, const std::string& state_path) {
  State state = state_path.empty() ? load_initial_state(deck) : read_state(state_path);
  state.pairs.skin = skin_length(deck);
  const Model model = make_model(deck, state.particles.radius);
  Json out = {{"state", state_path.empty() ? initial_state_path(deck) : state_path}, {"particles", state.particles.size()}};
  try {
    rebuild_pairs(model, state);
    const NetworkTimeStep t = network_time_step_limit(model, state);
    out.update({{"omega_max", t.omega_max},
                {"limit", t.limit},
                {"limit_over_unit", t.limit / t.unit},
                {"pair_limit", t.pair_limit},
                {"pair_limit_over_unit", t.pair_limit / t.unit},
                {"network_over_pair", t.limit / t.pair_limit},
                {"unit", t.unit},
                {"gershgorin_limit", t.gershgorin_omega > 0.0 ? Json(2.0 / t.gershgorin_omega) : Json(nullptr)},
                {"time_step_over_limit", deck.time_step / t.limit},
                {"contacts", t.contacts},
                {"unknowns", t.unknowns},
                {"iterations", t.iterations},
                {"residual_bound", t.residual_bound},
                {"seconds", t.seconds}});
    Json stages = Json::array();
    const auto judge = [&](const std::string& stage, double dt, const Friction& friction) {
      const Model stage_model = make_model(deck, state.particles.radius, dt);
      const std::string key = time_step_key(deck, stage);
      const NetworkStepJudgement j =
          judge_network_time_step(stage_model, state, friction, "stage '" + stage + "'", key);
      Json e = to_json(j);
      e.update({{"stage", stage}, {"key", key}, {"message", j.message}});
      stages.push_back(std::move(e));
    };
    if (deck.prepare && state_path.empty())
      judge("prepare", deck.stage_time_step(*deck.prepare), deck.prepare->stage_friction());
    for (const TestDef& test : deck.tests) judge(test.name, deck.stage_time_step(test), test.stage_friction());
    out["stages"] = std::move(stages);
    out["check_interval"] = deck.checkpoint_interval;
  } catch (const std::invalid_argument& e) {
    out["error"] = e.what();
  }
  return out;
}

void print_network_time_step(const Json& n) {
  if (n.contains("error")) {
    std::printf("  network stability limit of %s: %s\n", n["state"].get<std::string>().c_str(),
                n["error"].get<std::string>().c_str());
    return;
  }
  std::printf("  network stability limit (2/omega_max of the %lld contacts of %s, sticking, Lanczos %d steps, %.2g s): "
              "%.3g s = %.3f sqrt(m_min/kn); the pair formula's 2/omega %.3g s = %.3f sqrt(m_min/kn) (network/pair "
              "%.3f); time step %.3f of the network's limit\n",
              static_cast<long long>(n["contacts"].get<std::int64_t>()), n["state"].get<std::string>().c_str(),
              n["iterations"].get<int>(), n["seconds"].get<double>(), n["limit"].get<double>(),
              n["limit_over_unit"].get<double>(), n["pair_limit"].get<double>(), n["pair_limit_over_unit"].get<double>(),
              n["network_over_pair"].get<double>(), n["time_step_over_limit"].get<double>());
  for (const Json& s : n["stages"])
    std::printf(
        "    %-12s time step %.3g s = %.3f of its network's limit %.3g s (%s; warned above %.3g, refused above "
        "%.3g): %s\n",
        s["stage"].get<std::string>().c_str(), s["time_step"].get<double>(), s["time_step_over_limit"].get<double>(),
        s["limit"].is_null() ? 0.0 : s["limit"].get<double>(),
        s["tangential_springs"].get<bool>() ? "sticking" : "normal springs only, no friction",
        s["warn_above"].get<double>(), s["refuse_above"].get<double>(), s["verdict"].get<std::string>().c_str());
  std::printf(
      "  run-time checks of the network's limit: at each stage's start and every %lld steps (checkpoint_interval), "
      "each about %.2g s on this state (docs/physics.md has their cost per step)\n",
      static_cast<long long>(n["check_interval"].get<std::int64_t>()), n["seconds"].get<double>());
}

// The time step against the pair formula's limit per mode, the network's (with a state) and the bounds.
void print_time_steps(const std::string& deck_path, const Json& plan) {
  std::printf("%s: time step %.3g s = %.3f of the stability limit %.3g s (%s mode); skin %.3g m\n",
              deck_path.c_str(), plan["time_step"].get<double>(), plan["time_step_ratio"].get<double>(),
              plan["critical_time_step"].get<double>(), plan["limiting_mode"].get<std::string>().c_str(),
              plan["skin"].get<double>());
  std::printf("  stability limit per mode (sqrt(2)/omega, two smallest spheres sticking):\n");
  for (const char* name : {"normal", "tangential-rotational", "rolling", "twisting"}) {
    const Json& m = plan["time_step_limits"][name];
    if (m["time_step"].is_null()) {
      std::printf("    %-22s none (the law has no such spring)\n", name);
      continue;
    }
    std::printf("    %-22s %.3g s  (%s = %.3g)%s\n", name, m["time_step"].get<double>(),
                m["stiffness_name"].get<std::string>().c_str(), m["stiffness"].get<double>(),
                name == plan["limiting_mode"].get<std::string>() ? "  limiting" : "");
  }
  if (plan.contains("network_time_step")) print_network_time_step(plan["network_time_step"]);
  else
    std::printf(
        "  network stability limit: known once a packing exists (`plan --state FILE`, or the deck's "
        "initial_state); the run judges it at each stage's start and every %lld steps (checkpoint_interval): "
        "warned above %.3g of it, refused above %.3g (docs/physics.md has a check's cost)\n",
        static_cast<long long>(plan["checkpoint_interval"].get<std::int64_t>()), kNetworkWarnFraction,
        kNetworkRefuseFraction);
  std::printf("  time step bounds:\n");
  for (const Json& b : plan["time_step_bounds"])
    std::printf("    %-6s %-5s %5g %s = %.3g s  (%s)\n", b["action"].get<std::string>().c_str(),
                b["when"].get<std::string>().c_str(), b["fraction"].get<double>(),
                b["of"] == "normal_time_step" ? "t_c(normal)" : "t_c", b["time_step"].get<double>(),
                b["name"].get<std::string>().c_str());
}

// A grading's percent passing per sieve, asked and realised (nothing without a grading).
void print_grading(const Json& g, std::uint64_t seed) {
  if (g.is_null()) return;
  const bool realised = !g["realised_percent"].is_null();
  std::printf("  grading by %s, percent passing each sieve: asked, and realised by the %s\n",
              g["by"].get<std::string>().c_str(),
              realised ? (std::to_string(g["spheres"].get<std::size_t>()) + " spheres that seed " +
                          std::to_string(seed) + " draws").c_str()
                       : "initial_state's spheres (in the run's summary.json)");
  std::printf("    %12s %8s %9s\n", "size [m]", "asked", realised ? "realised" : "");
  for (std::size_t k = 0; k < g["sizes_m"].size(); ++k) {
    std::printf("    %12.4g %8.2f", g["sizes_m"][k].get<double>(), g["asked_percent"][k].get<double>());
    if (realised) std::printf(" %9.2f", g["realised_percent"][k].get<double>());
    std::printf("\n");
  }
  if (realised)
    std::printf("    largest deviation %.2f percentage points\n", g["largest_deviation_percent"].get<double>());
}

Command add_plan_command(CLI::App& app) {
  struct Args {
    std::string deck;
    bool json = false;
    std::optional<double> tolerance;
    std::string state;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("plan", "What a deck implies before it runs: steps and rows per test, "
                                             "particle masses and damping, the stability limit");
  cmd->add_option("deck", a->deck, "Deck file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_flag("--json", a->json, "Print JSON (for tools)");
  cmd->add_option("--tolerance", a->tolerance,
                  "The deck rewritten for T noise floors from I -> 0 (as `run --tolerance T`): how far the deck as "
                  "written is from I -> 0, each stage's settings and particle-steps against the deck as written");
  cmd->add_option("--state", a->state,
                  "A state file (e.g. a run's prepared.state) whose contact network gives the stability limit from "
                  "its spectrum beside the pair formula's (a deck with initial_state: that state by default)")
      ->check(CLI::ExistingFile);
  return [cmd, a]() -> int {
    if (!cmd->parsed()) return -1;
    const Deck deck = read_deck(a->deck, a->tolerance);
    Json plan = plan_json(deck);
    plan["checkpoint_interval"] = deck.checkpoint_interval;
    if (!a->state.empty() || deck.initial_state) plan["network_time_step"] = network_time_step_json(deck, a->state);
    if (deck.tolerance) plan["tolerance"] = tolerance_json(read_deck_as_written(a->deck), deck);
    if (a->json) {
      std::printf("%s\n", plan.dump(1).c_str());
      return 0;
    }
    print_time_steps(a->deck, plan);
    print_grading(plan["sample"]["grading"], deck.sample.seed);
    // A stage and its legs, the preparation's as a test's: steps, rows, each leg's end, driving and servo cap.
    const auto count = [](const Json& n) { return n.is_null() ? std::string("?") : std::to_string(n.get<std::int64_t>()); };
    const auto range = [&](const Json& r) {
      return r["high"] == r["low"] ? count(r["low"]) : count(r["low"]) + (r["high"].is_null() ? " or more" : " to " + count(r["high"]));
    };
    const auto print_stage = [&](const std::string& name, const Json& steps, const Json& rows, const Json& legs,
                                 const Json& equilibrium, double time_step, double ratio) {
      std::printf("  %-12s %zu leg%s, %s steps, %s rows; time step %.3g s = %.3f of the limit\n", name.c_str(),
                  legs.size(), legs.size() > 1 ? "s" : "", steps.is_object() ? range(steps).c_str() : count(steps).c_str(),
                  count(rows).c_str(), time_step, ratio);
      for (std::size_t j = 0; j < legs.size(); ++j) {
        const Json& leg = legs[j];
        for (const char* axis : {"x1", "x2", "x3"})
          if (const Json& a = leg["axes"][axis]; a.contains("stress_ramp"))
            std::printf("    leg %zu: %s stress ramp from %.6g Pa at %.6g Pa/s (%.3g Pa per step)\n", j, axis,
                        a["stress_ramp"]["from"].get<double>(), a["stress_ramp"]["rate"].get<double>(),
                        a["stress_ramp"]["rate"].get<double>() * time_step);
        if (leg.contains("ramp_target_steps"))
          std::printf("    leg %zu: its end stress is the ramp's target after %lld steps (the measured stress ends it)\n",
                      j, static_cast<long long>(leg["ramp_target_steps"].get<std::int64_t>()));
        if (leg.contains("equilibrium_max_steps") && equilibrium.is_object())
          std::printf("    leg %zu: ends in equilibrium after %lld to %lld steps, checked every %lld: |dp| <= %.3g, "
                      "max|ds| <= %.3g, unbalanced <= %.3g\n",
                      j, static_cast<long long>(equilibrium["min_steps"].get<std::int64_t>()),
                      static_cast<long long>(leg["equilibrium_max_steps"].get<std::int64_t>()),
                      static_cast<long long>(equilibrium["check_interval"].get<std::int64_t>()),
                      equilibrium["pressure_tolerance"].get<double>(), equilibrium["stress_tolerance"].get<double>(),
                      equilibrium["unbalanced_force_ratio"].get<double>());
        const double d = leg["driving_increment"].get<double>(), cap = leg["servo_cap"].get<double>();
        std::printf("    leg %zu: %s, %s steps, %s rows", j, describe_end(leg["end"]).c_str(), range(leg["steps"]).c_str(),
                    count(leg["rows"]).c_str());
        if (d > 0.0) std::printf("; driving %.3g per step (%.3g /s)", d, leg["driving_rate"].get<double>());
        if (const Json& a = leg.value("adaptive_rate", Json()); a.is_object())
          std::printf(" x an adaptive factor %.3g to %.3g (targets: unbalanced force %.3g, kinetic/elastic %.3g, "
                      "inertial number <= %.3g; checked every %lld steps)",
                      a["min_factor"].get<double>(), a["max_factor"].get<double>(),
                      a["unbalanced_force_ratio"].get<double>(), a["kinetic_to_elastic"].get<double>(),
                      a["inertial_number"].get<double>(), static_cast<long long>(a["check_interval"].get<std::int64_t>()));
        if (leg["servo"].get<bool>()) {
          std::printf("; servo cap %.3g", cap);
          if (d > 0.0)
            std::printf(" = %.3g x driving%s", cap / d, cap < kMinServoCapRatio * d ? " (below 3: refused)" : "");
        }
        std::printf("\n");
      }
    };
    if (deck.prepare) {
      const Json& p = plan["prepare"];
      print_stage("prepare", p["steps"], p["rows"], p["legs"], Json(), p["time_step"].get<double>(),
                  p["time_step_ratio"].get<double>());
    }
    for (const Json& t : plan["tests"]) {
      print_stage(t["name"].get<std::string>(), t["steps"], t["rows"], t["legs"], t.value("equilibrium", Json()),
                  t["time_step"].get<double>(), t["time_step_ratio"].get<double>());
      if (const Json& p = t.value("probes", Json()); p.is_object())
        std::printf("    probes: %lld points x (a rest of at most %lld steps + (%lld probes: a reference and the "
                    "directions at each magnitude, + %lld of the elastic check) x %lld steps) = %lld steps at most (a "
                    "point the test does not reach is not probed), side by side on the test's threads\n",
                    static_cast<long long>(p["points"].get<std::int64_t>()),
                    static_cast<long long>(p["rest_steps_per_point"].get<std::int64_t>()),
                    static_cast<long long>(p["probes_per_point"].get<std::int64_t>()),
                    static_cast<long long>(p["check_probes_per_point"].get<std::int64_t>()),
                    static_cast<long long>(p["steps_per_probe"].get<std::int64_t>()),
                    static_cast<long long>(p["steps"].get<std::int64_t>()));
      if (const Json& p = t.value("probes", Json()); p.is_object())
        std::printf("    probes: numbers %lld-%lld for `run --probes K-L` (one numbering over the deck's tests, point by "
                    "point in probes.csv's order; references not counted)\n",
                    static_cast<long long>(p["numbers"][0].get<std::int64_t>()),
                    static_cast<long long>(p["numbers"][1].get<std::int64_t>()));
    }
    const Json& start = plan["prepare"].is_object() ? plan["prepare"].value("start", Json()) : Json();
    std::printf("%s\n", describe_estimate(deck, start.is_null() ? -1.0 : start["solid_fraction"].get<double>()).c_str());
    if (plan.contains("tolerance")) print_tolerance(plan["tolerance"]);
    return 0;
  };
}

}  // namespace celldem::app
