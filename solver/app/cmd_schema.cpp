// celldem schema: the deck's keys and the series' columns, from the tables the code itself uses.
// celldem plan: what a deck implies before it runs (steps, rows, particle properties), for people and tools.
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "app/commands.hpp"
#include "core/plan.hpp"
#include "io/deck_reader.hpp"
#include "measure/quasi_static.hpp"
#include "measure/series.hpp"

namespace celldem::app {
namespace fs = std::filesystem;
using Json = nlohmann::json;

Command add_schema_command(CLI::App& app) {
  struct Args {
    bool markdown = false, json = false, series = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("schema", "Print the deck keys (type, unit, default, range, meaning) or the "
                                               "series columns");
  cmd->add_flag("--series", a->series, "The series.csv columns instead of the deck keys");
  cmd->add_flag("--markdown", a->markdown, "A Markdown table (default)");
  cmd->add_flag("--json", a->json, "JSON");
  return [cmd, a]() -> int {
    if (!cmd->parsed()) return -1;
    if (a->markdown && a->json) throw CLI::ValidationError("--markdown and --json exclude each other");
    const std::string text = a->series ? (a->json ? series_columns_json() : series_columns_markdown())
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
  }
  return nullptr;
}

Json end_json(const LegEnd& e) {
  switch (e.kind) {
    case LegEndKind::Strain: return {{"axis", kAxisNames[e.axis]}, {"strain", e.value}};
    case LegEndKind::Ratio: return {{"ratio", e.value}};
    case LegEndKind::Stress: return {{"axis", kAxisNames[e.axis]}, {"stress", e.value}};
    case LegEndKind::Steps: return {{"steps", e.steps}};
    case LegEndKind::SolidFraction: return {{"solid_fraction", e.value}};
    case LegEndKind::Equilibrium: return {{"equilibrium", true}};
  }
  return nullptr;
}

Json axes_json(const Leg& leg) {
  Json axes;
  for (int k = 0; k < 3; ++k) axes[std::string(kAxisNames[k])] = axis_json(leg.axes[k]);
  return axes;
}

Json plan_json(const Deck& deck) {
  Json types = Json::array();
  std::vector<double> seen;
  for (double d : deck.sample.diameters) {
    if (std::find(seen.begin(), seen.end(), d) != seen.end()) continue;
    seen.push_back(d);
    const BodyProperties b = body_properties(0.5 * d, deck.sample.density, deck.damping, reference_stiffness(deck.contact, deck.sample));
    types.push_back({{"diameter", d}, {"mass", b.mass}, {"inertia", b.inertia},
                     {"translational_drag", b.translational_drag}, {"rotational_drag", b.rotational_drag}});
  }
  const double dt_crit = critical_time_step(deck.sample, deck.contact);
  Json out = {{"deck", deck.source},
              {"time_step", deck.time_step},
              {"critical_time_step", dt_crit},
              {"time_step_ratio", deck.time_step / dt_crit},
              {"skin", skin_length(deck)},
              {"sample", {{"count", deck.sample.count}, {"diameters", deck.sample.diameters},
                          {"density", deck.sample.density}, {"mean_diameter", mean_diameter(deck.sample)},
                          {"seed", deck.sample.seed}}},
              {"particle_types", types},
              {"prepare", nullptr},
              {"initial_state", nullptr},
              {"tests", Json::array()}};
  if (deck.prepare)
    out["prepare"] = {{"friction", deck.prepare->friction}, {"target_pressure", deck.prepare->target_pressure},
                      {"fast_solid_fraction", deck.prepare->fast_solid_fraction},
                      {"fast_strain_increment", deck.prepare->fast_strain_increment},
                      {"output_interval", deck.prepare->output_interval}};
  if (deck.initial_state) out["initial_state"] = (fs::path(deck.source).parent_path() / *deck.initial_state).string();
  for (const TestDef& t : deck.tests) {
    const TestPlan p = plan_test(deck, t);
    const Leg& first = t.legs.front();
    double stress_sum = 0.0;
    int stress_axes = 0;
    for (const AxisControl& a : first.axes)
      if (a.mode == AxisMode::Stress || a.mode == AxisMode::MeanStress) stress_sum += a.value, ++stress_axes;
    const Json inertia = stress_axes ? Json(inertial_number(loading_rate(deck, t), mean_diameter(deck.sample),
                                                            deck.sample.density, stress_sum / stress_axes))
                                     : Json(nullptr);
    Json legs = Json::array();
    for (const Leg& leg : t.legs) {
      // What the servo can follow: the leg's driving strain per step against its cap (check refuses a ratio
      // below kMinServoCapRatio in a leg with servo axes).
      const double d = leg_driving_increment(leg, deck.time_step);
      const double cap = servo_cap(deck.servo, leg, deck.time_step);
      legs.push_back({{"axes", axes_json(leg)}, {"end", end_json(leg.end)}, {"driving_increment", d},
                      {"servo_cap", cap}, {"servo", leg_has_servo(leg)},
                      {"cap_ratio", d > 0.0 ? Json(cap / d) : Json(nullptr)}});
    }
    const auto known = [](std::int64_t n) { return n >= 0 ? Json(n) : Json(nullptr); };
    out["tests"].push_back({{"name", t.name}, {"friction", t.friction}, {"steps", known(p.steps)},
                            {"end_axis", kAxisNames[first.end.axis]}, {"end_strain", first.end.value},
                            {"strain_per_step", p.strain_per_step}, {"strain_rate", p.strain_rate},
                            {"output_interval", t.output_interval}, {"rows", known(p.rows)},
                            {"axes", axes_json(first)}, {"legs", legs}, {"inertial_number", inertia}});
  }
  return out;
}

}  // namespace

Command add_plan_command(CLI::App& app) {
  struct Args {
    std::string deck;
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("plan", "What a deck implies before it runs: steps and rows per test, "
                                             "particle masses and damping, the stability limit");
  cmd->add_option("deck", a->deck, "Deck file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_flag("--json", a->json, "Print JSON (for tools)");
  return [cmd, a]() -> int {
    if (!cmd->parsed()) return -1;
    const Json plan = plan_json(read_deck(a->deck));
    if (a->json) {
      std::printf("%s\n", plan.dump(1).c_str());
      return 0;
    }
    std::printf("%s: time step %.3g s = %.3f of sqrt(m_min/kn) = %.3g s; skin %.3g m\n", a->deck.c_str(),
                plan["time_step"].get<double>(), plan["time_step_ratio"].get<double>(),
                plan["critical_time_step"].get<double>(), plan["skin"].get<double>());
    for (const Json& t : plan["tests"]) {
      const auto count = [](const Json& n) { return n.is_null() ? std::string("?") : std::to_string(n.get<std::int64_t>()); };
      std::printf("  %-12s %zu leg%s, %s steps, %s rows\n", t["name"].get<std::string>().c_str(), t["legs"].size(),
                  t["legs"].size() > 1 ? "s" : "", count(t["steps"]).c_str(), count(t["rows"]).c_str());
      for (std::size_t j = 0; j < t["legs"].size(); ++j) {
        const Json& leg = t["legs"][j];
        if (!leg["servo"].get<bool>()) continue;
        const double d = leg["driving_increment"].get<double>(), cap = leg["servo_cap"].get<double>();
        std::printf("    leg %zu: driving %.3g per step, servo cap %.3g", j, d, cap);
        if (d > 0.0)
          std::printf(" = %.3g x driving%s", cap / d, cap < kMinServoCapRatio * d ? " (below 3: refused)" : "");
        std::printf("\n");
      }
    }
    return 0;
  };
}

}  // namespace celldem::app
