// Per-stage time steps (prepare.time_step, tests[].time_step) and `--tolerance` (io/tolerance.hpp): the stage's
// time step reaches its model and plan and is held to the deck key's bounds; the time-to-answer rules embedded in
// the binary parse, interpolate log-linearly and refuse a tolerance outside them; a resolved deck meets the
// rules it was resolved by (time step fraction, inertial number from its definition, rows per unit strain,
// equilibrium and output in physical time) and leaves a deck without a tolerance as it was; the strain-driven legs'
// inertial number comes from the rate bias laws: T floors of the deck's own size from I -> 0 whatever rate the deck
// is written at, a tighter T never cheaper than a looser one, a deck written too fast slowed and saying so.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/model.hpp"
#include "core/plan.hpp"
#include "io/deck_reader.hpp"
#include "io/tolerance.hpp"
#include "io/translate.hpp"
#include "measure/quasi_static.hpp"

namespace celldem {
namespace {

using Json = nlohmann::json;

Json deck_json() {
  return Json::parse(R"({
    "format": 1,
    "sample": {"count": 100, "diameters": {"min": 3.0e-3, "max": 4.5e-3, "count": 4}, "density": 2650},
    "contact": {"kn": 1.0e6, "kt": 1.0e6},
    "damping": {"translational": 0.05, "rotational": 0.05},
    "time_step": 1.0e-6,
    "prepare": {"target_pressure": 1.0e5, "output_interval": 1000,
                "equilibrium": {"min_steps": 50000, "check_interval": 1000}},
    "tests": [
      {"name": "ttc", "friction": 0.5,
       "axes": {"x1": {"strain_increment": 2.0e-7}, "x2": {"stress": 1.0e5}, "x3": {"stress": 2.0e5}},
       "end": {"strain": 0.01}, "output_interval": 1000},
      {"name": "cyc", "friction": 0.5, "legs": [
         {"axes": {"x1": {"strain_rate": 0.4}, "x2": {"strain_rate": -0.2}, "x3": {"mean_stress": 4.0e5}},
          "end": {"axis": "x1", "strain": 0.002}},
         {"axes": {"x1": {"stress": 4.0e5}, "x2": {"stress": 4.0e5}, "x3": {"stress": 4.0e5}},
          "end": {"steps": 3000}}],
       "output_interval": 500}
    ]
  })");
}

TEST(StageTimeStep, EachStageRunsWithItsOwnOrTheDecks) {
  Json j = deck_json();
  j["prepare"]["time_step"] = 2.0e-6;
  j["tests"][0]["time_step"] = 1.5e-6;
  const Deck d = parse_deck(j.dump());
  EXPECT_EQ(d.stage_time_step(*d.prepare), 2.0e-6);
  EXPECT_EQ(d.stage_time_step(d.tests[0]), 1.5e-6);
  EXPECT_EQ(d.stage_time_step(d.tests[1]), 1.0e-6);  // none given: the deck's
  // The model and the plan of a stage take its time step: the strain-rate leg's steps are strain / (rate dt).
  EXPECT_EQ(make_model(d, {1.5e-3, 2e-3}, d.stage_time_step(d.tests[0])).dt, 1.5e-6);
  EXPECT_EQ(plan_test(d, d.tests[1]).legs[0].steps.low, std::llround(0.002 / (0.4 * 1.0e-6)));
  j["tests"][1]["time_step"] = 2.5e-6;
  const Deck e = parse_deck(j.dump());
  EXPECT_EQ(plan_test(e, e.tests[1]).legs[0].steps.low, std::llround(0.002 / (0.4 * 2.5e-6)));
  EXPECT_DOUBLE_EQ(plan_test(e, e.tests[0]).strain_rate, 2.0e-7 / 1.5e-6);
}

TEST(StageTimeStep, BoundsOfTheDeckKeyApplyPerStage) {
  const Deck d = parse_deck(deck_json().dump());
  const double limit = critical_time_step(d.sample, d.contact);
  for (const char* stage : {"prepare", "tests"}) {
    Json j = deck_json();
    Json& where = std::string(stage) == "prepare" ? j["prepare"] : j["tests"][1];
    where["time_step"] = 1.01 * limit;  // above the stability limit: refused, naming the stage's key
    try {
      parse_deck(j.dump());
      ADD_FAILURE() << stage << ": a time step above the limit was accepted";
    } catch (const DeckError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(std::string(stage) == "prepare" ? "prepare.time_step:" : "tests[1].time_step:", 0),
                0u) << e.what();
    }
    where["time_step"] = 0.5 * kMinTimeStepFraction * limit;  // below the minimum: refused too
    EXPECT_THROW(parse_deck(j.dump()), DeckError) << stage;
  }
}

// The translated scripts run each stage at its own time step: a deck with stages of their own translates, each
// script with its stage's timestep.
TEST(StageTimeStep, TranslationRunsEachStageAtItsOwn) {
  Json j = deck_json();
  j["prepare"]["time_step"] = 1.5e-6;
  j["tests"][1]["time_step"] = 2.0e-6;
  const Deck d = parse_deck(j.dump());
  const auto timestep_of = [](const std::string& script) {
    const auto at = script.find("\ntimestep ");
    return at == std::string::npos ? -1.0 : std::stod(script.substr(at + 10, script.find('\n', at + 1) - at - 10));
  };
  EXPECT_EQ(timestep_of(translate_preparation(d, TargetCode::Lammps)), 1.5e-6);
  EXPECT_EQ(timestep_of(translate_test(d, d.tests[0], TargetCode::Lammps)), 1.0e-6);
  EXPECT_EQ(timestep_of(translate_test(d, d.tests[1], TargetCode::Liggghts)), 2.0e-6);
}

// A simple_shear leg is driven by its g12: --tolerance gives it the inertial number's rate as it gives the same
// leg written with axes (x12 strain_increment, x2 stress, x1 and x3 held), and a strain end on x12 follows it.
TEST(Tolerance, SimpleShearLegIsResolvedAsItsAxes) {
  Json by_shear = deck_json();
  by_shear["tests"] = Json::array({Json::parse(R"({"name": "dss", "friction": 0.5, "output_interval": 1000,
      "simple_shear": {"gamma_increment": 2.0e-7, "normal_stress": 1.0e5}, "end": {"axis": "x12", "strain": 0.01}})")});
  Json by_axes = by_shear;
  by_axes["tests"][0].erase("simple_shear");
  by_axes["tests"][0]["axes"] = Json::parse(R"({"x1": {"strain_increment": 0.0}, "x2": {"stress": 1.0e5},
      "x3": {"strain_increment": 0.0}, "x12": {"strain_increment": 2.0e-7}})");
  const Deck shear = resolve_tolerance(parse_deck(by_shear.dump()), by_shear.dump(), 1.0);
  const Deck axes = resolve_tolerance(parse_deck(by_axes.dump()), by_axes.dump(), 1.0);
  const Leg& s = shear.tests[0].legs[0];
  const Leg& a = axes.tests[0].legs[0];
  ASSERT_TRUE(s.axes[3].strain_driven() && a.axes[3].strain_driven());
  EXPECT_NE(a.axes[3 + 0].value, 2.0e-7);  // (the rules do change it)
  EXPECT_EQ(s.axes[3 + 0].value, a.axes[3 + 0].value);
  EXPECT_EQ(shear.stage_time_step(shear.tests[0]), axes.stage_time_step(axes.tests[0]));
  EXPECT_EQ(plan_test(shear, shear.tests[0]).steps, plan_test(axes, axes.tests[0]).steps);
  EXPECT_EQ(plan_test(shear, shear.tests[0]).steps, std::llround(0.01 / s.axes[3 + 0].value));
}

// A principal-axis rotation keeps its angular rate: an angle_increment per step scales with the time step as its
// steps end keeps its time, so the rotation turns through the same angle in the same time.
TEST(Tolerance, RotationByAnglePerStepKeepsItsRate) {
  Json j = deck_json();
  j["tests"] = Json::array({Json::parse(R"({"name": "rot", "friction": 0.5, "output_interval": 1000,
      "axes": {"x2": {"stress": 1.0e5}},
      "rotate_principal_axes": {"plane": "x1x3", "sigma1": 1.5e5, "sigma3": 1.0e5, "angle_increment": 0.0009},
      "end": {"steps": 100000}})")});
  const Deck written = parse_deck(j.dump());
  const Deck resolved = resolve_tolerance(written, j.dump(), 1.0);
  const double dt_written = written.stage_time_step(written.tests[0]), dt = resolved.stage_time_step(resolved.tests[0]);
  ASSERT_NE(dt, dt_written);
  const Leg& w = written.tests[0].legs[0];
  const Leg& r = resolved.tests[0].legs[0];
  ASSERT_TRUE(w.rotation && r.rotation);
  EXPECT_DOUBLE_EQ(r.rotation->rate / dt, w.rotation->rate / dt_written);  // [rad/s]
  const double turned_written = static_cast<double>(w.end.steps) * w.rotation->rate;
  const double turned = static_cast<double>(r.end.steps) * r.rotation->rate;
  EXPECT_NEAR(turned, turned_written, std::abs(r.rotation->rate));  // 90 degrees, within one step's angle
  EXPECT_NEAR(turned_written, M_PI / 2.0, 1e-12);
}

TEST(ToleranceRules, EmbeddedTableParsesAndInterpolatesLogLinearly) {
  const ToleranceRules& rules = time_to_answer_rules();
  ASSERT_GE(rules.levels.size(), 2u);
  for (std::size_t k = 1; k < rules.levels.size(); ++k) EXPECT_GT(rules.levels[k].tolerance, rules.levels[k - 1].tolerance);
  // At a level: the level. Halfway between two: each number the geometric mean of theirs.
  for (const ToleranceLevel& level : rules.levels)
    EXPECT_EQ(interpolate_rules(rules, level.tolerance, "t").inertial_number, level.inertial_number);
  const ToleranceLevel& a = rules.levels[0];
  const ToleranceLevel& b = rules.levels[1];
  const ToleranceLevel mid = interpolate_rules(rules, 0.5 * (a.tolerance + b.tolerance), "t");
  EXPECT_NEAR(mid.inertial_number, std::sqrt(a.inertial_number * b.inertial_number), 1e-12 * a.inertial_number);
  EXPECT_NEAR(mid.time_step_fraction, std::sqrt(a.time_step_fraction * b.time_step_fraction), 1e-12);
  // Outside the table: refused, naming where the tolerance came from and the range.
  try {
    interpolate_rules(rules, rules.levels.back().tolerance * 1.5, "--tolerance");
    ADD_FAILURE() << "a tolerance above the table was accepted";
  } catch (const DeckError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--tolerance: ", 0), 0u) << e.what();
  }
  EXPECT_THROW(interpolate_rules(rules, 0.5 * rules.levels.front().tolerance, "t"), DeckError);
}

TEST(ToleranceRules, MalformedTablesAreRefused) {
  const std::string level = R"({"tolerance": 1, "time_step_fraction": 0.5, "prepare_time_step_fraction": 0.5,
                                "inertial_number": 1e-4, "fast_strain_increment_scale": 1, "damping_scale": 1})";
  EXPECT_NO_THROW(parse_tolerance_rules(R"({"levels": [)" + level + "]}"));
  EXPECT_THROW(parse_tolerance_rules(R"({"levels": [)" + level + "," + level + "]}"), DeckError);  // not ascending
  EXPECT_THROW(parse_tolerance_rules(R"({"levels": []})"), DeckError);
  Json bad = Json::parse(level);
  bad["time_step_fraction"] = 1.2;  // above the stability limit
  EXPECT_THROW(parse_tolerance_rules(Json{{"levels", {bad}}}.dump()), DeckError);
  bad["time_step_fraction"] = -0.5;
  EXPECT_THROW(parse_tolerance_rules(Json{{"levels", {bad}}}.dump()), DeckError);
}

// The preparation's own servo cap binds its legs only; a value out of range is refused naming its key.
TEST(StageServo, PreparationCapIsItsOwnAndOutOfRangeIsRefused) {
  Json j = deck_json();
  j["prepare"]["servo_max_strain_increment"] = 4.0e-6;
  const Deck d = parse_deck(j.dump(), "deck.json");
  EXPECT_EQ(d.stage_servo(*d.prepare).max_strain_increment, 4.0e-6);
  EXPECT_TRUE(d.stage_servo(*d.prepare).max_strain_increment_given);
  EXPECT_FALSE(d.stage_servo(d.tests[0]).max_strain_increment_given);
  for (const double bad : {0.5, -1.0e-6}) {
    j["prepare"]["servo_max_strain_increment"] = bad;
    try {
      parse_deck(j.dump(), "deck.json");
      ADD_FAILURE() << bad << " was accepted";
    } catch (const DeckError& e) {
      EXPECT_NE(std::string(e.what()).find("prepare.servo_max_strain_increment"), std::string::npos) << e.what();
    }
  }
}

TEST(Tolerance, ResolvedDeckMeetsTheRules) {
  const std::string text = deck_json().dump();
  const Deck written = parse_deck(text, "deck.json");
  const double limit = critical_time_step(written.sample, written.contact);
  const double d_mean = mean_diameter(written.sample), rho = written.sample.density;
  for (const double t : {0.7, 1.0, 2.5}) {
    SCOPED_TRACE(t);
    ToleranceLevel level = interpolate_rules(time_to_answer_rules(), t, "tolerance");  // 100 spheres keep T
    level.inertial_number = inertial_number_for_tolerance(time_to_answer_rules().rate_bias, t, 100).inertial_number;
    const Deck d = resolve_tolerance(written, text, t);
    ASSERT_TRUE(d.tolerance.has_value());
    EXPECT_EQ(*d.tolerance, t);
    // Time steps: the level's fraction of the limit, rounded down to three significant digits, and never above 0.9
    // of the contact network's limit estimated as 0.600 of the pair's leapfrog limit 2/omega: with friction (the
    // tests) the tangential-rotational mode's omega^2 = 7 kt / m_min; without (the preparation) the normal 2 kn /
    // m_min.
    const double m_min = rho * std::acos(-1.0) / 6.0 * std::pow(3.0e-3, 3);
    const double tests_cap = 0.9 * 0.600 * 2.0 / std::sqrt(7.0 * 1.0e6 / m_min);
    const double prep_cap = 0.9 * 0.600 * 2.0 / std::sqrt(2.0 * 1.0e6 / m_min);
    const double expected = std::min(level.time_step_fraction * limit, tests_cap);
    const double dt = d.stage_time_step(d.tests[0]);
    EXPECT_LE(dt, expected);
    EXPECT_GT(dt, 0.99 * expected);
    EXPECT_LE(d.stage_time_step(*d.prepare), std::min(level.prepare_time_step_fraction * limit, prep_cap));
    const Json stage_settings = Json::parse(d.tolerance_settings);
    EXPECT_EQ(stage_settings["stages"][1]["network_capped"].get<bool>(), level.time_step_fraction * limit > tests_cap);
    EXPECT_FALSE(stage_settings["stages"][0]["network_capped"].get<bool>());  // the preparation: normal springs alone
    // Strain-driven legs: the level's (actual) inertial number at the leg's confining stress (the mean of its
    // targets) over its path's actual-to-imposed ratio: the TTC's an axial path, measured.
    const RateBiasModel& model = time_to_answer_rules().rate_bias;
    const double axial = actual_to_imposed(model, Json::parse(R"({"x1": {"strain_increment": 1e-7},
        "x2": {"stress": 1e5}, "x3": {"stress": 2e5}})"),
                                           false)
                             .ratio;
    const double ttc_stress = 1.5e5;
    EXPECT_NEAR(axial * inertial_number(plan_test(d, d.tests[0]).strain_rate, d_mean, rho, ttc_stress),
                level.inertial_number, 1e-9 * level.inertial_number);
    // Two driven axes (x1 and x2 = -x1/2) beside a mean-stress servo: a path not measured, at the largest ratio;
    // the inertial number's deviatoric scale of both axes.
    const double largest =
        model.path_margin * std::max_element(model.paths.begin(), model.paths.end(), [](const auto& a, const auto& b) {
                              return a.ratio < b.ratio;
                            })->ratio;
    const Leg& leg = d.tests[1].legs[0];
    EXPECT_NEAR(largest * inertial_number(leg_inertial_rate(leg, d.stage_time_step(d.tests[1])), d_mean, rho, 4.0e5),
                level.inertial_number, 1e-9 * level.inertial_number);
    EXPECT_EQ(stage_settings["stages"][2]["legs"][0]["path"], "unmeasured");
    EXPECT_NEAR(leg_inertial_rate(leg, d.stage_time_step(d.tests[1])), std::sqrt(1.75) * std::abs(leg.axes[0].value),
                1e-12 * std::abs(leg.axes[0].value));
    EXPECT_DOUBLE_EQ(leg.axes[1].value / leg.axes[0].value, -0.5);  // the axes scaled together
    // The hold leg keeps its physical time; the output interval its rows per unit strain.
    const double dt_cyc = d.stage_time_step(d.tests[1]);
    EXPECT_NEAR(static_cast<double>(d.tests[1].legs[1].end.steps) * dt_cyc, 3000 * 1.0e-6, 0.5 * dt_cyc);
    const double written_rows_per_strain = 1.0 / (1000 * 2.0e-7);
    const double rows_per_strain = 1.0 / (static_cast<double>(d.tests[0].output_interval) * plan_test(d, d.tests[0]).strain_per_step);
    EXPECT_NEAR(rows_per_strain / written_rows_per_strain, 1.0, 0.5 / static_cast<double>(d.tests[0].output_interval));
    // The preparation's equilibrium checks and rows keep their physical time.
    const double dt_prep = d.stage_time_step(*d.prepare);
    EXPECT_NEAR(static_cast<double>(d.prepare->equilibrium.min_steps) * dt_prep, 50000 * 1.0e-6, dt_prep);
    EXPECT_NEAR(static_cast<double>(d.prepare->equilibrium.check_interval) * dt_prep, 1000 * 1.0e-6, dt_prep);
    EXPECT_NEAR(static_cast<double>(d.prepare->output_interval) * dt_prep, 1000 * 1.0e-6, dt_prep);
    // Its fast leg and its servo's cap keep their strain rates (the fast leg times the level's scale), so the
    // preparation follows the deck's schedule in time; the tests keep the deck's servo rule.
    EXPECT_NEAR(d.prepare->fast_strain_increment / dt_prep,
                level.fast_strain_increment_scale * written.prepare->fast_strain_increment / 1.0e-6,
                1e-12 * d.prepare->fast_strain_increment / dt_prep);
    ASSERT_TRUE(d.prepare->servo_max_strain_increment.has_value());
    EXPECT_NEAR(*d.prepare->servo_max_strain_increment / dt_prep, kDefaultServoCap / 1.0e-6, 1e-12 / 1.0e-6);
    EXPECT_EQ(d.stage_servo(*d.prepare).max_strain_increment, *d.prepare->servo_max_strain_increment);
    EXPECT_FALSE(d.stage_servo(d.tests[0]).max_strain_increment_given);
    // The resolved settings name every stage.
    const Json settings = Json::parse(d.tolerance_settings);
    ASSERT_EQ(settings["stages"].size(), 3u);
    EXPECT_EQ(settings["stages"][2]["stage"], "cyc");
    // The resolved deck reads again as written, to the same deck.
    const Json resolved = Json::parse(d.canonical);
    EXPECT_FALSE(resolved.contains("tolerance"));
    EXPECT_EQ(parse_deck(d.canonical).canonical, d.canonical);
  }
}

TEST(Tolerance, DeckKeyAndArgumentResolveAlikeAndNoneLeavesTheDeck) {
  Json j = deck_json();
  const Deck plain = parse_deck(j.dump());
  EXPECT_FALSE(plain.tolerance.has_value());
  EXPECT_EQ(plain.canonical, j.dump());
  j["tolerance"] = 1.0;
  const std::string with_key = j.dump();
  const Deck as_written = parse_deck(with_key);  // parse_deck reads the key, read_deck applies it
  ASSERT_TRUE(as_written.tolerance.has_value());
  const Deck by_key = resolve_tolerance(as_written, with_key, *as_written.tolerance);
  const Deck by_argument = resolve_tolerance(plain, deck_json().dump(), 1.0);
  Json a = Json::parse(by_key.canonical), b = Json::parse(by_argument.canonical);
  a.erase("description"), b.erase("description");
  EXPECT_EQ(a, b);
  j["tolerance"] = -1.0;
  EXPECT_THROW(resolve_tolerance(parse_deck(j.dump()), j.dump(), -1.0), DeckError);
}

// The floor model carries T to the table's scene for the time steps (T sqrt(1000 / N) for a larger deck, T for a
// smaller one), clamped to the table's range: no T is refused and none runs the deck as written by default.
TEST(Tolerance, LargerDecksCarryTheirTightFloorsToTheTable) {
  const ToleranceRules& rules = time_to_answer_rules();
  ASSERT_EQ(rules.particles, 1000);
  EXPECT_DOUBLE_EQ(calibration_tolerance(rules, 1.0, 8000.0), std::sqrt(1000.0 / 8000.0));
  EXPECT_DOUBLE_EQ(calibration_tolerance(rules, 2.0, 4000.0), 1.0);
  EXPECT_EQ(calibration_tolerance(rules, 1.0, 150.0), 1.0);
  Json j = deck_json();
  j["sample"]["count"] = 8000;
  const std::string text = j.dump();
  const Deck written = parse_deck(text, "deck.json");
  const Deck faster = resolve_tolerance(written, text, 2.0);
  const Json rules_at = Json::parse(faster.tolerance_settings)["rules"];
  EXPECT_NEAR(rules_at["time_step_fraction"].get<double>(),
              interpolate_rules(rules, 2.0 * std::sqrt(0.125), "t").time_step_fraction, 1e-15);
  for (const double t : {0.5, 1.0, 100.0, 1e300}) EXPECT_NO_THROW(resolve_tolerance(written, text, t)) << t;
  EXPECT_THROW(resolve_tolerance(written, text, 0.0), DeckError);
  EXPECT_THROW(resolve_tolerance(written, text, 1e-6), DeckError);  // no inertial number down to 1e-9 promises it
}

// The rate bias laws against their own definition: the upper bias at the inertial number T allows is T floors for
// the limiting law and at most T for the others; floors narrow with N as the conservative exponent says.
TEST(ToleranceRateBias, TheRateForTIsTFloorsOfTheLimitingLaw) {
  const RateBiasModel& m = time_to_answer_rules().rate_bias;
  ASSERT_GE(m.laws.size(), 2u);
  for (const double n : {150.0, 1000.0, 8000.0})
    for (const double t : {0.5, 1.0, 2.0}) {
      const RateForTolerance r = inertial_number_for_tolerance(m, t, n);
      ASSERT_GT(r.inertial_number, 0.0);
      if (r.limiting.empty()) {  // capped at the measured top: every law within T there
        EXPECT_EQ(r.inertial_number, m.max_inertial_number);
        continue;
      }
      for (const RateBiasLaw& law : m.laws) {
        const double b = rate_bias_floors(m, law, r.inertial_number, n, true);
        if (law.quantity == r.limiting)
          EXPECT_NEAR(b, t, 1e-9 * t) << law.quantity;
        else
          EXPECT_LE(b, t * (1.0 + 1e-9)) << law.quantity;
      }
    }
  const RateBiasLaw& law = m.laws.front();
  // central: C (I / I_ref)^p / (floor (N / N0)^b)
  EXPECT_NEAR(rate_bias_floors(m, law, 2e-4, 4000.0, false),
              std::exp(law.log_coefficient) * std::pow(2e-4 / m.reference_inertial_number, law.order) /
                  (law.floor * std::pow(4.0, m.floor_exponent)),
              1e-12);
  // upper: larger than central; at 8000 spheres with the steep exponent, at 150 with the shallow one
  EXPECT_GT(rate_bias_floors(m, law, 2e-4, 8000.0, true), rate_bias_floors(m, law, 2e-4, 8000.0, false));
  EXPECT_GT(rate_bias_floors(m, law, 2e-4, 150.0, true), rate_bias_floors(m, law, 2e-4, 150.0, false));
}

// Monotone: over a sweep of T, the predicted particle-steps of a deck (and its inertial number's inverse) never
// grow as T grows, for decks written at a quarter, once and eight times the paper's rate and at 1000 and 8000
// spheres; the deck as written does not change what T costs, only how far it is said to be from I -> 0.
TEST(ToleranceRateBias, ATighterTNeverRunsFaster) {
  for (const int count : {1000, 8000})
    for (const double speed : {0.25, 1.0, 8.0}) {
      SCOPED_TRACE(std::to_string(count) + " spheres at " + std::to_string(speed) + "x");
      Json j = deck_json();
      j["sample"]["count"] = count;
      j["tests"][0]["axes"]["x1"]["strain_increment"] = 2.0e-7 * speed;
      const std::string text = j.dump();
      const Deck written = parse_deck(text, "deck.json");
      double last_steps = std::numeric_limits<double>::infinity(), last_I = 0.0;
      for (double t = 0.5; t < 50.0; t *= 1.25) {
        const Deck d = resolve_tolerance(written, text, t);
        double steps = static_cast<double>(preparation_steps(d).low);
        for (const TestDef& test : d.tests) steps += static_cast<double>(test_steps(d, test).low);
        EXPECT_LE(steps, last_steps) << "T " << t;
        const double I = Json::parse(d.tolerance_settings)["rate"]["inertial_number"].get<double>();
        EXPECT_GE(I, last_I) << "T " << t;
        last_steps = steps, last_I = I;
      }
    }
}

// Honest on decks written at 1/4, 1 and 8 times the paper's rate: the same T gives the same rate whatever the
// deck's, a deck written faster than T allows is slowed and says so, and its distance from I -> 0 is reported.
TEST(ToleranceRateBias, AFastDeckIsSlowedAndSaysHowFarItWas) {
  std::vector<double> rates;
  for (const double speed : {0.25, 1.0, 8.0}) {
    Json j = deck_json();
    j["sample"]["count"] = 1000;
    j["tests"][0]["axes"]["x1"]["strain_increment"] = 2.0e-7 * speed;
    const std::string text = j.dump();
    const Deck d = resolve_tolerance(parse_deck(text, "deck.json"), text, 1.0);
    const Json rate = Json::parse(d.tolerance_settings)["rate"];
    rates.push_back(plan_test(d, d.tests[0]).strain_rate);
    ASSERT_FALSE(rate["written"].empty());
    const Json& w = rate["written"][0];
    EXPECT_EQ(w["stage"], "ttc");
    const double I_written = w["inertial_number"].get<double>(), I = rate["inertial_number"].get<double>();
    EXPECT_EQ(w["slowed"].get<bool>(), I_written > I) << speed;
    // the written deck's distance: each law's central and upper bias at its inertial number
    const RateBiasModel& m = time_to_answer_rules().rate_bias;
    for (const RateBiasLaw& law : m.laws) {
      EXPECT_NEAR(w["distance_floors"][law.quantity][0].get<double>(), rate_bias_floors(m, law, I_written, 1000, false),
                  1e-12);
      EXPECT_NEAR(w["distance_floors"][law.quantity][1].get<double>(), rate_bias_floors(m, law, I_written, 1000, true),
                  1e-12);
    }
    EXPECT_NE(Json::parse(d.tolerance_settings)["rate"]["promise"].get<std::string>().find("mean over seeds"),
              std::string::npos);
  }
  EXPECT_NEAR(rates[0], rates[1], 1e-12 * rates[1]);  // the written rate does not matter
  EXPECT_NEAR(rates[2], rates[1], 1e-12 * rates[1]);
}

// The laws are in the cell's actual inertial number; a plan knows only the imposed one. Each path's ratio: exactly
// 2/sqrt(3) with every component strain-driven (the two scales of one tensor, checked on a rate tensor here), the
// measured ratio of a TTC (axial), PSC (plane strain) or simple shear path, the largest measured for any other path
// with a servo.
TEST(ToleranceRateBias, EachPathPredictsItsActualInertialNumberFromTheImposed) {
  const RateBiasModel& m = time_to_answer_rules().rate_bias;
  ASSERT_GE(m.paths.size(), 2u);
  EXPECT_GE(m.path_margin, 1.0);
  double largest = 0.0;
  for (const MeasuredPath& p : m.paths) largest = std::max(largest, m.path_margin * p.ratio);
  const auto ratio_of = [&](const std::string& name) {  // as used: times the margin
    for (const MeasuredPath& p : m.paths)
      if (p.path == name) return m.path_margin * p.ratio;
    ADD_FAILURE() << name;
    return 0.0;
  };
  const auto path = [&](const char* axes, bool shear = false) {
    return actual_to_imposed(m, Json::parse(axes), shear);
  };
  const PathRatio ttc = path(R"({"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}})");
  EXPECT_EQ(ttc.path, "axial");
  EXPECT_EQ(ttc.ratio, ratio_of("axial"));
  const PathRatio tte = path(R"({"x1": {"stress": 1e5}, "x2": {"mean_stress": 1e5}, "x3": {"strain_rate": -0.1}})");
  EXPECT_EQ(tte.path, "axial");
  // a b axis: its measured b, or the larger ratio of the measured b around it (b = 0.5 and 0.75 are measured)
  const auto at_b = [&](double b) {
    Json axes = Json::parse(R"({"x1": {"strain_increment": 2e-7}, "x3": {"mean_stress": 1e5}})");
    axes["x2"] = Json{{"b", b}};
    return actual_to_imposed(m, axes, false);
  };
  EXPECT_EQ(at_b(0.5).ratio, ratio_of("true triaxial, b = 0.5"));
  EXPECT_EQ(at_b(0.6).ratio, std::max(ratio_of("true triaxial, b = 0.5"), ratio_of("true triaxial, b = 0.75")));
  EXPECT_EQ(at_b(1.0).ratio, largest);  // b = 1, the largest measured
  for (double b = 0.0; b < 1.0; b += 0.05) EXPECT_GE(at_b(b + 0.05).ratio, at_b(b).ratio) << b;
  const PathRatio psc =
      path(R"({"x1": {"strain_increment": 2e-7}, "x2": {"strain_increment": 0}, "x3": {"stress": 1e5}})");
  EXPECT_EQ(psc.path, "plane strain");
  EXPECT_EQ(psc.ratio, ratio_of("plane strain"));
  // every component strain-driven: sqrt(2 D':D') over core/plan's sqrt(3/2 e':e'), engineering shears (D12 = g12/2)
  const std::array<double, kComponents> e = {0.3, -0.1, 0.05, 0.2, 0.0, -0.07};
  const PathRatio strain = path(R"({"x1": {"strain_rate": 0.3}, "x2": {"strain_rate": -0.1},
      "x3": {"strain_rate": 0.05}, "x12": {"strain_rate": 0.2}, "x23": {"strain_rate": -0.07}})");
  EXPECT_EQ(strain.path, "strain-driven");
  const double mean = (e[0] + e[1] + e[2]) / 3.0;
  double dd = 0.0;
  for (int k = 0; k < 3; ++k) dd += (e[k] - mean) * (e[k] - mean);
  for (int k = 3; k < 6; ++k) dd += 2.0 * (0.5 * e[k]) * (0.5 * e[k]);
  EXPECT_NEAR(strain.ratio * inertial_strain_rate(e), std::sqrt(2.0 * dd), 1e-14);
  // a servo on a shear, a moving shear beside two servos, a constant volume: not measured
  for (const char* axes : {R"({"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5},
                              "x12": {"stress": 1e3}})",
                           R"({"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5},
                              "x13": {"strain_rate": 0.1}})",
                           R"({"x1": {"strain_increment": 2e-7}, "x2": {"constant_volume": true},
                              "x3": {"constant_volume": true}})"}) {
    const PathRatio other = path(axes);
    EXPECT_EQ(other.path, "unmeasured") << axes;
    EXPECT_EQ(other.ratio, largest) << axes;
  }
  // a simple shear, by its key or by its axes
  EXPECT_EQ(path("{}", true).path, "simple shear");
  EXPECT_EQ(path("{}", true).ratio, ratio_of("simple shear"));
  EXPECT_EQ(path(R"({"x1": {"strain_increment": 0}, "x2": {"stress": 1e5}, "x3": {"strain_increment": 0},
      "x12": {"strain_increment": 2e-7}})")
                .path,
            "simple shear");
  // At one T the PSC (the larger ratio) runs at a slower imposed rate than the TTC; both at the same actual I.
  Json j = deck_json();
  j["sample"]["count"] = 1000;
  j["tests"][1] = j["tests"][0];
  j["tests"][1]["name"] = "psc";
  j["tests"][1]["axes"]["x2"] = Json{{"strain_increment", 0.0}};
  j["tests"][1]["axes"]["x3"] = Json{{"stress", 1.5e5}};  // the TTC's confining stress, the mean of its two
  const Deck d = resolve_tolerance(parse_deck(j.dump(), "deck.json"), j.dump(), 1.0);
  const Json settings = Json::parse(d.tolerance_settings);
  const double I = settings["rate"]["inertial_number"].get<double>();
  for (int k : {1, 2}) {
    const Json& leg = settings["stages"][k]["legs"][0];
    EXPECT_NEAR(leg["inertial_number"].get<double>(), I, 1e-12 * I);
    EXPECT_NEAR(leg["imposed_inertial_number"].get<double>() * leg["actual_to_imposed"].get<double>(), I, 1e-12 * I);
  }
  EXPECT_NEAR(plan_test(d, d.tests[1]).strain_rate / plan_test(d, d.tests[0]).strain_rate,
              ratio_of("axial") / ratio_of("plane strain"), 1e-9);
}

// An adaptive rate speeds a leg up to its ceiling on the actual inertial number: under --tolerance that ceiling is
// at most the inertial number T allows (a lower written one kept), so the adaptive rate cannot run past the promise.
TEST(ToleranceRateBias, AnAdaptiveRatesCeilingIsAtMostWhatTAllows) {
  for (const double written : {5e-4, 1e-9}) {
    Json j = deck_json();
    j["sample"]["count"] = 1000;
    j["tests"][0]["adaptive_rate"] = Json{{"inertial_number", written}};
    const Deck d = resolve_tolerance(parse_deck(j.dump(), "deck.json"), j.dump(), 3.0);
    const double allowed = Json::parse(d.tolerance_settings)["rate"]["inertial_number"].get<double>();
    ASSERT_LT(allowed, 5e-4);
    ASSERT_TRUE(d.tests[0].legs[0].adaptive.has_value());
    EXPECT_EQ(d.tests[0].legs[0].adaptive->inertial_number, std::min(written, allowed)) << written;
    EXPECT_EQ(Json::parse(d.tolerance_settings)["stages"][1]["legs"][0]["adaptive_ceiling_written"].get<double>(),
              written);
  }
}

// The promise checked after a run: at the allowed inertial number every law is within T (the limiting one at T);
// 1 % above it the limiting law is beyond T; with no inertial number measured nothing is kept.
TEST(ToleranceRateBias, TheCheckAfterARunKeepsTOnlyAtOrBelowTheAllowedRate) {
  const RateBiasModel& m = time_to_answer_rules().rate_bias;
  for (const double n : {1000.0, 8000.0}) {
    const RateForTolerance r = inertial_number_for_tolerance(m, 1.0, n);
    ASSERT_FALSE(r.limiting.empty());
    const ToleranceCheck at = check_tolerance(m, 1.0, n, r.inertial_number, r.inertial_number / 2.2);
    EXPECT_TRUE(at.kept);
    EXPECT_EQ(at.inertial_number_allowed, r.inertial_number);
    ASSERT_EQ(at.distances.size(), m.laws.size());
    for (const ToleranceCheck::Distance& x : at.distances)
      if (x.quantity == r.limiting) {
        EXPECT_NEAR(x.upper, 1.0, 1e-9);
      }
    const ToleranceCheck above = check_tolerance(m, 1.0, n, 1.01 * r.inertial_number, r.inertial_number / 2.2);
    EXPECT_FALSE(above.kept);
    EXPECT_NEAR(above.to_json()["actual_to_imposed"].get<double>(), 2.2 * 1.01, 1e-12);
    EXPECT_TRUE(check_tolerance(m, 1.0, n, 0.5 * r.inertial_number, 1e-5).kept);
    EXPECT_FALSE(check_tolerance(m, 1.0, n, 0.0, 0.0).kept);
  }
}

}  // namespace
}  // namespace celldem
