// Deck parsing and validation (solver/io/deck_reader.hpp, solver/core/deck_schema.hpp): a valid deck gives the expected values and defaults;
// every kind of bad input throws DeckError whose message starts with the JSON path of the offending key.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "helpers.hpp"
#include "core/plan.hpp"
#include "io/deck_reader.hpp"
#include "io/schema_print.hpp"

namespace celldem {
namespace {

using Json = nlohmann::json;

Json minimal_deck() {
  return Json::parse(R"({
    "format": 1,
    "sample": {"count": 100, "diameters": {"min": 3.0e-3, "max": 4.5e-3, "count": 4}, "density": 2650},
    "contact": {"kn": 1.0e6, "kt": 5.0e5},
    "damping": {"translational": 0.05, "rotational": 0.1},
    "time_step": 1.0e-6,
    "prepare": {"target_pressure": 1.0e5},
    "tests": [
      {"name": "ttc", "friction": 0.5,
       "axes": {"x1": {"strain_increment": 2.0e-7}, "x2": {"stress": 1.0e5}, "x3": {"stress": 1.0e5}},
       "end": {"strain": 0.1}},
      {"name": "psc", "friction": 0.5,
       "axes": {"x1": {"stress": 1.0e5}, "x2": {"strain_increment": 0.0}, "x3": {"strain_rate": 0.2}},
       "end": {"axis": "x3", "strain": 0.05, "max_steps": 1000}, "output_interval": 50}
    ]
  })");
}

TEST(Deck, MinimalDeckParsesWithExpectedValuesAndDefaults) {
  const Deck d = parse_deck(minimal_deck().dump(), "mine.json");
  EXPECT_EQ(d.format, 1);
  EXPECT_EQ(d.source, "mine.json");
  EXPECT_EQ(d.sample.count, 100);
  ASSERT_EQ(d.sample.diameters.size(), 4u);
  EXPECT_DOUBLE_EQ(d.sample.diameters[0], 3.0e-3);
  EXPECT_DOUBLE_EQ(d.sample.diameters[1], 3.5e-3);
  EXPECT_DOUBLE_EQ(d.sample.diameters[2], 4.0e-3);
  EXPECT_DOUBLE_EQ(d.sample.diameters[3], 4.5e-3);
  EXPECT_EQ(d.sample.density, 2650.0);
  EXPECT_EQ(d.sample.seed, 1u);
  EXPECT_DOUBLE_EQ(d.sample.grid_spacing, 1.1 * 4.5e-3);
  EXPECT_EQ(d.contact.kn, 1.0e6);
  EXPECT_EQ(d.contact.kt, 5.0e5);
  EXPECT_EQ(d.contact.rotation, TangentialRotation::Rotate);
  EXPECT_EQ(d.contact.moment_arm, MomentArm::ContactPoint);
  EXPECT_EQ(d.kinematics, Kinematics::Affine);
  EXPECT_EQ(d.damping.translational, 0.05);
  EXPECT_EQ(d.damping.rotational, 0.1);
  EXPECT_EQ(d.time_step, 1.0e-6);
  EXPECT_EQ(d.servo.gain, 0.05);
  EXPECT_EQ(d.servo.integral_gain, 0.002);
  EXPECT_EQ(d.servo.max_strain_increment, 1e-6);
  EXPECT_EQ(d.checkpoint_interval, 100000);
  ASSERT_TRUE(d.prepare.has_value());
  EXPECT_FALSE(d.initial_state.has_value());
  EXPECT_EQ(d.prepare->target_pressure, 1.0e5);
  EXPECT_EQ(d.prepare->friction, 0.0);
  EXPECT_EQ(d.prepare->fast_solid_fraction, 0.45);
  EXPECT_EQ(d.prepare->equilibrium.min_steps, 20000);
  ASSERT_EQ(d.tests.size(), 2u);
  const TestDef& t = d.tests[0];
  EXPECT_EQ(t.name, "ttc");
  EXPECT_EQ(t.friction, 0.5);
  EXPECT_EQ(t.legs[0].axes[0].mode, AxisMode::StrainIncrement);
  EXPECT_EQ(t.legs[0].axes[0].value, 2.0e-7);
  EXPECT_EQ(t.legs[0].axes[1].mode, AxisMode::Stress);
  EXPECT_EQ(t.legs[0].axes[1].value, 1.0e5);
  EXPECT_EQ(t.legs[0].end.axis, 0);
  EXPECT_EQ(t.legs[0].end.value, 0.1);
  EXPECT_EQ(t.legs[0].end.max_steps, 0);
  EXPECT_EQ(t.output_interval, 1000);
  const TestDef& u = d.tests[1];
  EXPECT_EQ(u.legs[0].axes[1].mode, AxisMode::StrainIncrement);
  EXPECT_EQ(u.legs[0].axes[1].value, 0.0);
  EXPECT_EQ(u.legs[0].axes[2].mode, AxisMode::StrainRate);
  EXPECT_EQ(u.legs[0].axes[2].value, 0.2);
  EXPECT_EQ(u.legs[0].end.axis, 2);
  EXPECT_EQ(u.legs[0].end.max_steps, 1000);
  EXPECT_EQ(u.output_interval, 50);
}

TEST(Deck, OptionalChoicesAndListDiameters) {
  Json j = minimal_deck();
  j["contact"]["tangential_rotation"] = "project";
  j["contact"]["moment_arm"] = "radius";
  j["kinematics"] = "lammps";
  j["sample"]["diameters"] = {{"list", {2e-3, 4e-3}}};
  j["sample"]["seed"] = 42;
  j["sample"]["grid_spacing"] = 5e-3;
  j["servo"] = {{"gain", 0.1}, {"integral_gain", 0.0}, {"max_strain_increment", 1e-5}};
  j.erase("prepare");
  j["initial_state"] = "prepared.state";
  const Deck d = parse_deck(j.dump());
  EXPECT_EQ(d.contact.rotation, TangentialRotation::Project);
  EXPECT_EQ(d.contact.moment_arm, MomentArm::Radius);
  EXPECT_EQ(d.kinematics, Kinematics::Lammps);
  EXPECT_EQ(d.sample.diameters, (std::vector<double>{2e-3, 4e-3}));
  EXPECT_EQ(d.sample.seed, 42u);
  EXPECT_EQ(d.sample.grid_spacing, 5e-3);
  EXPECT_EQ(d.servo.gain, 0.1);
  EXPECT_FALSE(d.prepare.has_value());
  EXPECT_EQ(d.initial_state, "prepared.state");
}

void expect_error(const Json& j, const std::string& path, const std::string& also = "");

Json graded_deck() {
  Json j = minimal_deck();
  j["sample"]["diameters"] = Json::parse(
      R"({"grading": {"by": "mass", "sizes": [2.5e-3, 3.5e-3, 4.5e-3], "passing": [0, 40, 100]}})");
  return j;
}

TEST(Deck, GradingParsesAndBoundsTheSizes) {
  const Deck d = parse_deck(graded_deck().dump());
  ASSERT_TRUE(d.sample.grading.has_value());
  EXPECT_EQ(d.sample.grading->by, GradingBasis::Mass);
  EXPECT_EQ(d.sample.grading->sizes, (std::vector<double>{2.5e-3, 3.5e-3, 4.5e-3}));
  EXPECT_EQ(d.sample.grading->passing, (std::vector<double>{0, 40, 100}));
  EXPECT_TRUE(d.sample.diameters.empty());
  EXPECT_EQ(d.sample.smallest_diameter(), 2.5e-3);
  EXPECT_EQ(d.sample.largest_diameter(), 4.5e-3);
  EXPECT_EQ(d.sample.grid_spacing, 1.1 * 4.5e-3);  // the default follows the largest size
  Json j = graded_deck();
  j["sample"]["diameters"]["grading"]["by"] = "number";
  EXPECT_EQ(parse_deck(j.dump()).sample.grading->by, GradingBasis::Number);
  // The listed forms have no grading.
  EXPECT_FALSE(parse_deck(minimal_deck().dump()).sample.grading.has_value());
}

TEST(DeckErrors, GradingNamesTheKey) {
  struct Case {
    const char* pointer;
    Json value;
    const char* path;
    const char* also;
  };
  const Case cases[] = {
      {"/sample/diameters/grading/by", "volume", "sample.diameters.grading.by", "\"mass\""},
      {"/sample/diameters/grading/sizes", Json::array({2.5e-3}), "sample.diameters.grading.sizes", "at least 2"},
      {"/sample/diameters/grading/sizes", "big", "sample.diameters.grading.sizes", "array"},
      {"/sample/diameters/grading/sizes/1", "big", "sample.diameters.grading.sizes[1]", "number"},
      {"/sample/diameters/grading/sizes/0", -1e-3, "sample.diameters.grading.sizes[0]", "> 0"},
      {"/sample/diameters/grading/sizes/0", 0.0, "sample.diameters.grading.sizes[0]", "> 0"},
      {"/sample/diameters/grading/sizes/2", 3.5e-3, "sample.diameters.grading.sizes[2]", "increase"},
      {"/sample/diameters/grading/sizes/1", 2.0e-3, "sample.diameters.grading.sizes[1]", "increase"},
      {"/sample/diameters/grading/passing", Json::array({0, 100}), "sample.diameters.grading.passing", "one per size"},
      {"/sample/diameters/grading/passing/1", -5, "sample.diameters.grading.passing[1]", "[0, 100]"},
      {"/sample/diameters/grading/passing/1", 120, "sample.diameters.grading.passing[1]", "[0, 100]"},
      {"/sample/diameters/grading/passing/1", "x", "sample.diameters.grading.passing[1]", "number"},
      {"/sample/diameters/grading/passing/0", 10, "sample.diameters.grading.passing[0]", "must be 0"},
      {"/sample/diameters/grading/passing/2", 90, "sample.diameters.grading.passing[2]", "must be 100"},
      {"/sample/diameters/grading/size", 1, "sample.diameters.grading.size", "unknown key"},
      {"/sample/diameters/list", Json::array({3e-3}), "sample.diameters.list", "not more"},
      {"/sample/diameters/min", 3e-3, "sample.diameters.min", "not more"},
      {"/sample/diameters/count", 3, "sample.diameters.count", "not more"},
      {"/sample/grid_spacing", 4.0e-3, "sample.grid_spacing", "largest diameter (0.0045)"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.pointer);
    Json j = graded_deck();
    j[Json::json_pointer(c.pointer)] = c.value;
    expect_error(j, c.path, c.also);
  }
  Json j = graded_deck();
  j["sample"]["diameters"]["grading"]["passing"] = {0, 60, 40};  // decreasing, though it ends at 40
  expect_error(j, "sample.diameters.grading.passing[2]", "never decreases");
  for (const char* key : {"by", "sizes", "passing"}) {
    j = graded_deck();
    j["sample"]["diameters"]["grading"].erase(key);
    expect_error(j, std::string("sample.diameters.grading.") + key, "missing");
  }
  j = graded_deck();
  j["sample"]["diameters"]["grading"] = 5;
  expect_error(j, "sample.diameters.grading", "object");
}

TEST(Deck, EnergyBudgetIsOffUnlessAskedAndOnlyABoolean) {
  EXPECT_FALSE(parse_deck(minimal_deck().dump()).energy_budget);
  Json j = minimal_deck();
  j["energy_budget"] = true;
  EXPECT_TRUE(parse_deck(j.dump()).energy_budget);
  for (const Json& bad : {Json(1), Json("true")}) {  // (null: as every optional key, left out)
    j["energy_budget"] = bad;
    expect_error(j, "energy_budget", "true or false");
  }
}

TEST(Deck, CriticalTimeStepIsSqrtOfLightestMassOverKn) {
  SampleDef s;
  s.density = 2650;
  s.diameters = {4e-3, 3e-3, 5e-3};
  const double m = 2650 * M_PI / 6.0 * 27e-9;
  ContactDef c;
  c.kn = 1e6;
  EXPECT_NEAR(critical_time_step(s, c), std::sqrt(m / 1e6), 1e-18);
}

// Parses a mutated deck and checks the error names `path` (the message is "path: what").
void expect_error(const Json& j, const std::string& path, const std::string& also) {
  try {
    (void)parse_deck(j.dump());
    ADD_FAILURE() << "no error for " << path;
  } catch (const DeckError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(path + ":", 0), 0u) << "message does not start with \"" << path << ":\": " << what;
    if (!also.empty()) { EXPECT_NE(what.find(also), std::string::npos) << what; }
  }
}

// The contact law's sub-models: a Hertz-Mindlin deck with rolling and twisting resistance, the tests' rolling
// friction from contact unless a test says, and the reference overlap from the deck's largest stress.
Json hertz_deck() {
  Json j = minimal_deck();
  j["contact"] = {{"normal", "hertz"}, {"tangential", "mindlin"}, {"rolling", "sds"}, {"twisting", "marshall"},
                  {"youngs_modulus", 7e10}, {"poisson_ratio", 0.25}, {"rolling_stiffness", 1e6},
                  {"rolling_friction", 0.1}};
  j["time_step"] = 1e-7;
  return j;
}

TEST(Deck, ContactSubModelsAndTheirParameters) {
  Json j = hertz_deck();
  j["tests"][1]["rolling_friction"] = 0.3;
  const Deck d = parse_deck(j.dump());
  const ContactDef& c = d.contact;
  EXPECT_EQ(c.normal, NormalModel::Hertz);
  EXPECT_EQ(c.tangential, TangentialModel::Mindlin);
  EXPECT_EQ(c.rolling, RollingModel::Sds);
  EXPECT_EQ(c.twisting, TwistingModel::Marshall);
  EXPECT_EQ(c.rolling_damping, 0.0);
  EXPECT_EQ(d.tests[0].rolling_friction, 0.1);
  EXPECT_EQ(d.tests[1].rolling_friction, 0.3);
  EXPECT_EQ(d.prepare->rolling_friction, 0.0);
  EXPECT_DOUBLE_EQ(c.effective_modulus(), 7e10 / (2.0 * (1.0 - 0.0625)));
  // The reference overlap: Hertz inverted at 10 x the mean contact force at 3 x the largest stress.
  double p = 0.0;
  for (const TestDef& t : d.tests)
    for (const AxisControl& a : t.legs[0].axes)
      if (a.mode == AxisMode::Stress) p = std::max(p, a.value);
  p = std::max(p, d.prepare->target_pressure);
  double d_mean = 0.0;
  for (double x : d.sample.diameters) d_mean += x / static_cast<double>(d.sample.diameters.size());
  const double force = 10.0 * M_PI * d_mean * d_mean * 3.0 * p / 3.6;
  const double r_eff = 0.25 * *std::max_element(d.sample.diameters.begin(), d.sample.diameters.end());
  const double overlap = std::pow(3.0 * force / (4.0 * c.effective_modulus() * std::sqrt(r_eff)), 2.0 / 3.0);
  EXPECT_NEAR(c.reference_overlap, overlap, 1e-12 * overlap);
  const ContactStiffness k = reference_stiffness(c, d.sample);
  EXPECT_NEAR(k.normal, 2.0 * c.effective_modulus() * std::sqrt(r_eff * overlap), 1e-9 * k.normal);
  // Given explicitly, it is kept.
  j["contact"]["reference_overlap"] = 1e-6;
  EXPECT_EQ(parse_deck(j.dump()).contact.reference_overlap, 1e-6);
}

TEST(DeckErrors, ContactSubModelsNeedTheirParametersAndNothingElse) {
  Json j = hertz_deck();
  j["contact"].erase("youngs_modulus");
  expect_error(j, "contact.youngs_modulus", "required with");
  j = hertz_deck();
  j["contact"]["kn"] = 1e6;
  expect_error(j, "contact.kn", "not used");
  j = hertz_deck();
  j["contact"]["normal"] = "jkr";
  expect_error(j, "contact.normal", "hertz");
  j = hertz_deck();
  j["contact"].erase("rolling_friction");
  expect_error(j, "contact.rolling_friction", "required with");
  j = hertz_deck();
  j["contact"]["poisson_ratio"] = 0.5;
  expect_error(j, "contact.poisson_ratio");
  j = minimal_deck();
  j["contact"]["rolling_friction"] = 0.1;
  expect_error(j, "contact.rolling_friction", "not used");
  j = minimal_deck();
  j["tests"][0]["rolling_friction"] = 0.1;
  expect_error(j, "tests[0].rolling_friction", "not used");
  j = minimal_deck();
  j["contact"]["youngs_modulus"] = 1e9;
  expect_error(j, "contact.youngs_modulus", "not used");
  j = minimal_deck();
  j["contact"]["tangential"] = "mindlin";
  expect_error(j, "contact.kt", "not used");  // mindlin's stiffness comes from the modulus
  j["contact"]["tangential"] = "mindlin_rescale";
  expect_error(j, "contact.kt", "not used with contact.tangential = \"mindlin_rescale\"");
  j["contact"].erase("kt");
  expect_error(j, "contact.youngs_modulus", "required with contact.tangential = \"mindlin_rescale\"");  // 8 G* a
  j = hertz_deck();
  j["contact"]["tangential"] = "mindlin_rescale";
  EXPECT_EQ(parse_deck(j.dump()).contact.tangential, TangentialModel::MindlinRescale);
  j = hertz_deck();
  j["time_step"] = 1e-5;  // above the stability limit at the reference overlap
  expect_error(j, "time_step", "of the stability limit");
}

// The key table's sub_models decide which contact keys a law takes: for every combination of choices, each key
// of a choice not made is refused, naming the deck's choice and the ones the key belongs to; each key a made
// choice needs is required, naming that choice. A deck with exactly the keys its choices use is accepted.
TEST(DeckErrors, SubModelKeysFollowTheKeyTable) {
  const std::map<std::string, double> value = {
      {"kn", 1e6},           {"kt", 5e5},           {"youngs_modulus", 7e10},  {"poisson_ratio", 0.25},
      {"rolling_stiffness", 1e6}, {"rolling_damping", 0.01}, {"rolling_friction", 0.1}, {"reference_overlap", 1e-6}};
  const auto spec_of = [](const std::string& name) -> const KeySpec& {
    for (const KeySpec* k : keys::kAll)
      if (k->path == "contact." + name) return *k;
    throw std::logic_error("no key contact." + name);
  };
  int refusals = 0, requirements = 0;
  for (const std::string_view normal : kNormalModelNames)
    for (const std::string_view tangential : kTangentialModelNames)
      for (const std::string_view rolling : kRollingModelNames)
        for (const std::string_view twisting : kTwistingModelNames) {
          const SubModelSelection chosen{normal, tangential, rolling, twisting};
          Json base = minimal_deck();
          base["time_step"] = 1e-7;
          base["contact"] = {{"normal", normal}, {"tangential", tangential}, {"rolling", rolling},
                             {"twisting", twisting}};
          for (const auto& [name, x] : value)
            if (key_used(spec_of(name), chosen)) base["contact"][name] = x;
          EXPECT_NO_THROW((void)parse_deck(base.dump())) << base["contact"].dump();
          for (const auto& [name, x] : value) {
            const KeySpec& k = spec_of(name);
            Json j = base;
            if (!key_used(k, chosen)) {
              j["contact"][name] = x;
              const SubModelChoice& first = k.sub_models[0];
              const std::string made = "contact." + std::string(first.sub_model) + " = \"" +
                                       std::string(chosen[sub_model_index(first.sub_model)]) + "\"";
              expect_error(j, "contact." + name, "not used with " + made);
              expect_error(j, "contact." + name, "(only with contact." + std::string(first.sub_model) + " = \"" +
                                                     std::string(first.choice) + "\"");
              ++refusals;
            } else if (k.required_when_used) {
              j["contact"].erase(name);
              const SubModelChoice& use = *chosen_use(k, chosen);
              expect_error(j, "contact." + name, "missing; required with contact." + std::string(use.sub_model) +
                                                     " = \"" + std::string(use.choice) + "\"");
              ++requirements;
            }
          }
          if (rolling == "none") {  // a test's rolling friction belongs to rolling: sds too
            Json j = base;
            j["tests"][0]["rolling_friction"] = 0.1;
            expect_error(j, "tests[0].rolling_friction",
                         "not used with contact.rolling = \"none\" (only with contact.rolling = \"sds\")");
          }
        }
  EXPECT_GT(refusals, 50);
  EXPECT_GT(requirements, 50);
  // A key of several choices names them all.
  Json j = minimal_deck();
  j["contact"]["youngs_modulus"] = 7e10;
  expect_error(j, "contact.youngs_modulus",
               "not used with contact.normal = \"linear\", contact.tangential = \"linear_history\" (only with "
               "contact.normal = \"hertz\", contact.tangential = \"mindlin\" or \"mindlin_rescale\")");
}

// `celldem schema --json` prints each contact key's sub-model choices, a sub-model key with all its choices.
TEST(DeckSchemaJson, SubModelsOfEveryContactKey) {
  const Json schema = Json::parse(deck_schema_json());
  int contact_keys = 0;
  for (const Json& e : schema) {
    const std::string key = e["key"].get<std::string>();
    if (key.rfind("contact.", 0) != 0) {
      const bool rolling_friction = key == "prepare.rolling_friction" || key == "tests[].rolling_friction";
      EXPECT_EQ(e.contains("sub_models"), rolling_friction) << key;
      continue;
    }
    ++contact_keys;
    ASSERT_TRUE(e.contains("sub_models")) << key;
    ASSERT_TRUE(e.contains("required_when_used")) << key;
    EXPECT_FALSE(e["sub_models"].empty()) << key;
  }
  EXPECT_EQ(contact_keys, 14);
  const auto entry = [&schema](const std::string& key) {
    for (const Json& e : schema)
      if (e["key"] == key) return e;
    return Json();
  };
  EXPECT_EQ(entry("contact.youngs_modulus")["sub_models"],
            Json::parse(R"([{"sub_model": "normal", "choices": ["hertz"]},
                            {"sub_model": "tangential", "choices": ["mindlin", "mindlin_rescale"]}])"));
  EXPECT_EQ(entry("contact.youngs_modulus")["required_when_used"], true);
  EXPECT_EQ(entry("contact.reference_overlap")["required_when_used"], false);
  EXPECT_EQ(entry("contact.normal")["sub_models"],
            Json::parse(R"([{"sub_model": "normal", "choices": ["linear", "hertz"]}])"));
  EXPECT_EQ(entry("tests[].rolling_friction")["sub_models"],
            Json::parse(R"([{"sub_model": "rolling", "choices": ["sds"]}])"));
  EXPECT_NE(deck_schema_markdown().find("| `normal: hertz`, `tangential: mindlin, mindlin_rescale` |"), std::string::npos);
}

TEST(DeckErrors, UnknownKeysTopLevelAndNested) {
  Json j = minimal_deck();
  j["frobnicate"] = 1;
  expect_error(j, "frobnicate", "unknown key");
  j = minimal_deck();
  j["contact"]["kN"] = 1.0;
  expect_error(j, "contact.kN", "unknown key");
  j = minimal_deck();
  j["tests"][1]["axes"]["x2"]["strain_incremnt"] = 0.0;
  expect_error(j, "tests[1].axes.x2.strain_incremnt", "unknown key");
  j = minimal_deck();
  j["prepare"]["equilibrium"] = {{"min_steps", 10}, {"tolerance", 0.1}};
  expect_error(j, "prepare.equilibrium.tolerance", "unknown key");
  j = minimal_deck();
  j["sample"]["diameters"]["mean"] = 1e-3;
  expect_error(j, "sample.diameters.mean", "unknown key");
  j = minimal_deck();
  j["tests"][0]["end"]["at"] = 1;
  expect_error(j, "tests[0].end.at", "unknown key");
}

// A key that is empty or holds what a path uses ('.', '[') or spaces is quoted in the path, as JSON writes it,
// so that the message shows it: sample[""], not "sample.".
TEST(DeckErrors, OddKeysAreQuotedInThePath) {
  Json j = minimal_deck();
  j["sample"][""] = 1;
  expect_error(j, "sample[\"\"]", "unknown key");
  j = minimal_deck();
  j[""] = 1;
  expect_error(j, "deck[\"\"]", "unknown key");
  j = minimal_deck();
  j["contact"]["k n"] = 1;
  expect_error(j, "contact[\"k n\"]", "unknown key");
  j = minimal_deck();
  j["tests"][0]["axes"]["x1.b"] = 1;
  expect_error(j, "tests[0].axes[\"x1.b\"]", "unknown key");
  j = minimal_deck();
  j["sample"]["say \"hi\""] = 1;
  expect_error(j, "sample[\"say \\\"hi\\\"\"]", "unknown key");
  // A duplicate key is found before the JSON library keeps one of the two: its path is quoted the same way.
  std::string text = minimal_deck().dump();
  text.replace(text.find("\"sample\":{"), 10, "\"sample\":{\"\":1,\"\":2,");
  try {
    (void)parse_deck(text);
    ADD_FAILURE() << "no error for a duplicate empty key";
  } catch (const DeckError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("sample[\"\"]: duplicate key", 0), 0u) << e.what();
  }
}

TEST(DeckErrors, WrongTypes) {
  Json j = minimal_deck();
  j["sample"]["density"] = "heavy";
  expect_error(j, "sample.density", "expected a number");
  j = minimal_deck();
  j["sample"]["count"] = 100.5;
  expect_error(j, "sample.count", "integer");
  j = minimal_deck();
  j["contact"]["kn"] = "1e6";
  expect_error(j, "contact.kn");
  j = minimal_deck();
  j["contact"] = 5;
  expect_error(j, "contact", "object");
  j = minimal_deck();
  j["tests"] = Json::object();
  expect_error(j, "tests", "array");
  j = minimal_deck();
  j["tests"][0]["name"] = 3;
  expect_error(j, "tests[0].name", "string");
  j = minimal_deck();
  j["contact"]["tangential_rotation"] = true;
  expect_error(j, "contact.tangential_rotation");
  j = minimal_deck();
  j["sample"]["diameters"] = {{"list", {1e-3, "big"}}};
  expect_error(j, "sample.diameters.list[1]");
}

TEST(DeckErrors, MissingKeys) {
  for (const char* key : {"sample", "contact", "damping", "time_step", "format"}) {
    Json j = minimal_deck();
    j.erase(key);
    expect_error(j, key, "missing");
  }
  Json j = minimal_deck();
  j["contact"].erase("kn");
  expect_error(j, "contact.kn", "missing");
  j = minimal_deck();
  j["sample"].erase("density");
  expect_error(j, "sample.density", "missing");
  j = minimal_deck();
  j["tests"][0].erase("axes");
  expect_error(j, "tests[0].axes", "missing");
  j = minimal_deck();
  j["tests"][0]["axes"].erase("x3");
  expect_error(j, "tests[0].axes.x3", "missing");
  j = minimal_deck();
  j["prepare"].erase("target_pressure");
  expect_error(j, "prepare.target_pressure", "missing");
  j = minimal_deck();
  j["damping"].erase("rotational");
  expect_error(j, "damping.rotational", "missing");
}

TEST(DeckErrors, OutOfRangeValues) {
  struct Case {
    const char* pointer;
    Json value;
    const char* path;
  };
  const Case cases[] = {
      {"/contact/kn", -1.0e6, "contact.kn"},
      {"/contact/kn", 0.0, "contact.kn"},
      {"/contact/kt", -1.0, "contact.kt"},
      {"/tests/0/friction", -0.1, "tests[0].friction"},
      {"/prepare/friction", -0.5, "prepare.friction"},
      {"/sample/count", 0, "sample.count"},
      {"/sample/count", -5, "sample.count"},
      {"/sample/count", 18446744073709551615ULL, "sample.count"},
      {"/sample/density", 0.0, "sample.density"},
      {"/damping/translational", -0.1, "damping.translational"},
      {"/time_step", 0.0, "time_step"},
      {"/time_step", 1.0e-5, "time_step"},  // above sqrt(m_min / kn) = 6.1e-6 s
      {"/sample/grid_spacing", 4.0e-3, "sample.grid_spacing"},  // below the largest diameter
      {"/sample/diameters/min", -3.0e-3, "sample.diameters.min"},
      {"/sample/diameters/max", 2.0e-3, "sample.diameters.max"},  // below min
      {"/prepare/target_pressure", -1.0, "prepare.target_pressure"},
      {"/prepare/fast_solid_fraction", 0.9, "prepare.fast_solid_fraction"},
      {"/tests/0/axes/x2/stress", -1.0e5, "tests[0].axes.x2.stress"},
      {"/tests/0/axes/x1/strain_increment", 0.5, "tests[0].axes.x1.strain_increment"},
      {"/tests/0/end/strain", 0.0, "tests[0].end.strain"},
      {"/tests/0/end/strain", -0.1, "tests[0].end.strain"},  // the axis is compressed, not extended
      {"/tests/0/output_interval", 0, "tests[0].output_interval"},
      {"/format", 2, "format"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.pointer);
    Json j = minimal_deck();
    j[Json::json_pointer(c.pointer)] = c.value;
    expect_error(j, c.path);
  }
  Json j = minimal_deck();
  j["servo"] = {{"gain", 1.5}};
  expect_error(j, "servo.gain");
  j["servo"] = {{"gain", 0.0}, {"integral_gain", 0.0}};
  expect_error(j, "servo");
  j = minimal_deck();
  j["sample"]["diameters"] = {{"list", {1e-3, -2e-3}}};
  expect_error(j, "sample.diameters.list[1]");
}

TEST(DeckErrors, BadEnumValuesListTheChoices) {
  Json j = minimal_deck();
  j["contact"]["tangential_rotation"] = "spin";
  expect_error(j, "contact.tangential_rotation", "\"rotate\"");
  j = minimal_deck();
  j["contact"]["moment_arm"] = "lever";
  expect_error(j, "contact.moment_arm", "\"radius\"");
  j = minimal_deck();
  j["kinematics"] = "liggghts";
  expect_error(j, "kinematics", "\"lammps\"");
  j = minimal_deck();
  j["tests"][0]["end"]["axis"] = "x4";
  expect_error(j, "tests[0].end.axis");
}

// A deck makes a sample (prepare), reuses one (initial_state) or prepares one from a state (both); the soft
// start for an imported sample's overlaps needs a state to relax, and a fraction in its range.
TEST(DeckErrors, PrepareInitialStateOrBoth) {
  Json both = minimal_deck();
  both["initial_state"] = "a.state";
  const Deck d = parse_deck(both.dump());
  ASSERT_TRUE(d.prepare.has_value());
  EXPECT_EQ(d.initial_state, "a.state");
  EXPECT_TRUE(d.prepare->default_legs);
  EXPECT_EQ(d.prepare->relax_overlaps, 0.0);
  Json neither = minimal_deck();
  neither.erase("prepare");
  expect_error(neither, "prepare", "or both");
  Json state_without_tests = minimal_deck();
  state_without_tests.erase("prepare");
  state_without_tests["initial_state"] = "a.state";
  state_without_tests.erase("tests");
  expect_error(state_without_tests, "tests");

  Json relax = both;
  relax["prepare"]["relax_overlaps"] = 0.01;
  EXPECT_EQ(parse_deck(relax.dump()).prepare->relax_overlaps, 0.01);
  relax["prepare"]["relax_overlaps"] = 0.2;  // beyond what the run accepts without relaxing
  expect_error(relax, "prepare.relax_overlaps", "0.05");
  relax["prepare"]["relax_overlaps"] = 0.0;
  expect_error(relax, "prepare.relax_overlaps");
  relax["prepare"]["relax_overlaps"] = true;
  expect_error(relax, "prepare.relax_overlaps", "number");
  Json generated = minimal_deck();  // nothing to relax in a generated sample
  generated["prepare"]["relax_overlaps"] = 0.01;
  expect_error(generated, "prepare.relax_overlaps", "initial_state");
  Json top = both;  // the key belongs to the preparation
  top["relax_overlaps"] = 0.01;
  expect_error(top, "relax_overlaps", "unknown");
  Json own_legs = both;
  own_legs["prepare"]["legs"] = Json::parse(R"([{"axes": {"x1": {"stress": 1e5}, "x2": {"stress": 1e5},
      "x3": {"stress": 1e5}}, "end": {"equilibrium": true}}])");
  EXPECT_FALSE(parse_deck(own_legs.dump()).prepare->default_legs);
}

TEST(DeckErrors, InconsistentTests) {
  Json j = minimal_deck();
  j["tests"][1]["name"] = "ttc";
  expect_error(j, "tests[1].name", "duplicate");
  j = minimal_deck();
  j["tests"][0]["name"] = "a/b";
  expect_error(j, "tests[0].name");
  j = minimal_deck();
  j["tests"][0]["name"] = std::string(65, 'a');  // check and run share the limit (a folder name)
  expect_error(j, "tests[0].name", "at most 64");
  j["tests"][0]["name"] = std::string(64, 'a');
  EXPECT_NO_THROW(parse_deck(j.dump()));
  j = minimal_deck();
  j["tests"][0]["axes"]["x1"] = {{"strain_increment", 1e-7}, {"stress", 1e5}};
  expect_error(j, "tests[0].axes.x1", "exactly one");
  j = minimal_deck();
  j["tests"][0]["axes"]["x1"] = Json::object();
  expect_error(j, "tests[0].axes.x1", "exactly one");
  j = minimal_deck();
  j["tests"][0]["end"]["axis"] = "x2";  // stress-controlled
  expect_error(j, "tests[0].end.axis");
  j = minimal_deck();
  j["tests"][1]["axes"]["x3"] = {{"strain_increment", 0.0}};  // never reaches its end strain
  expect_error(j, "tests[1].end.strain");
}

// A leg shorter than one step is refused: an end strain within half a step of the start, or a strain rate so
// large that one step passes the end (it ran 0 steps and exited 0).
TEST(DeckErrors, ZeroStepLegs) {
  Json j = minimal_deck();
  j["tests"][0]["axes"]["x1"] = {{"strain_rate", 1e6}};
  expect_error(j, "tests[0].end.strain", "shorter than one step");
  j = minimal_deck();
  j["tests"][0]["end"]["strain"] = 0.9e-7;  // under half of one 2e-7 step
  expect_error(j, "tests[0].end.strain", "shorter than one step");
  j["tests"][0]["end"]["strain"] = 1.9e-7;  // over half a step, still under one: refused too
  expect_error(j, "tests[0].end.strain", "shorter than one step");
  j["tests"][0]["end"]["strain"] = 2e-7;  // exactly one step
  EXPECT_NO_THROW(parse_deck(j.dump(), "x.json"));
  j = minimal_deck();
  j["tests"][0].erase("axes");
  j["tests"][0].erase("end");
  const Json axes = {{"x1", {{"strain_increment", 1e-6}}}, {"x2", {{"stress", 1e5}}}, {"x3", {{"stress", 1e5}}}};
  j["tests"][0]["legs"] = {{{"axes", axes}, {"end", {{"strain", 0.001}}}},
                           {{"axes", axes}, {"end", {{"strain", 0.0010004}}}}};
  expect_error(j, "tests[0].legs (leg 1 of the program, repeats unrolled): end.strain", "shorter than one step");
  j["tests"][0]["legs"][1]["end"]["strain"] = 0.002;
  EXPECT_NO_THROW(parse_deck(j.dump(), "x.json"));
}

// The servo's cap follows each leg's driving rate unless the deck gives it; control_failure is stop or warn.
TEST(Deck, ServoCapFollowsTheLegAndControlFailureChoice) {
  Json j = minimal_deck();
  Deck d = parse_deck(j.dump(), "x.json");
  EXPECT_FALSE(d.servo.max_strain_increment_given);
  EXPECT_EQ(d.control_failure, ControlFailure::Stop);
  EXPECT_DOUBLE_EQ(servo_cap(d.servo, d.tests[0].legs[0], d.time_step), 2e-6);  // 10 x 2e-7
  EXPECT_DOUBLE_EQ(leg_driving_increment(d.tests[1].legs[0], d.time_step), 2e-7);  // 0.2 /s x 1e-6 s
  Leg hold;  // nothing drives it (the preparation's servo): today's 1e-6
  std::fill_n(hold.axes.begin(), 3, AxisControl{AxisMode::Stress, 1e5});
  EXPECT_DOUBLE_EQ(servo_cap(d.servo, hold, d.time_step), 1e-6);
  j["servo"] = {{"max_strain_increment", 5e-7}};
  j["control_failure"] = "warn";
  d = parse_deck(j.dump(), "x.json");
  EXPECT_TRUE(d.servo.max_strain_increment_given);
  EXPECT_DOUBLE_EQ(servo_cap(d.servo, d.tests[0].legs[0], d.time_step), 5e-7);  // as given
  EXPECT_EQ(d.control_failure, ControlFailure::Warn);
  j["control_failure"] = "ignore";
  expect_error(j, "control_failure", "stop");
}

// Snapshots are binary unless the deck asks for zlib or ascii, per stage; another value names the key.
TEST(Deck, SnapshotFormatIsBinaryUnlessTheDeckSaysOtherwise) {
  Json j = minimal_deck();
  j["tests"][0]["snapshots"] = {{"interval", 100}};
  j["tests"][1]["snapshots"] = {{"e1", {0.01}}, {"format", "zlib"}};
  j["prepare"]["snapshots"] = {{"interval", 1000}, {"format", "ascii"}};
  const Deck d = parse_deck(j.dump(), "x.json");
  EXPECT_EQ(d.tests[0].snapshots.format, SnapshotFormat::Binary);
  EXPECT_EQ(d.tests[1].snapshots.format, SnapshotFormat::Zlib);
  EXPECT_EQ(d.prepare->snapshots.format, SnapshotFormat::Ascii);
  j["tests"][1]["snapshots"]["format"] = "hdf5";
  expect_error(j, "tests[1].snapshots.format", "\"binary\", \"zlib\", \"ascii\"");
  j["tests"][1]["snapshots"]["format"] = 1;
  expect_error(j, "tests[1].snapshots.format", "expected a string");
  j = minimal_deck();
  j["prepare"]["snapshots"] = {{"format", "binary"}};  // a format alone asks for no snapshot
  expect_error(j, "prepare.snapshots", "\"interval\" or \"e1\"");
}

// Shear axes x12, x13, x23 beside the normal ones (tests[].axes.xIJ), and zero_shear_stress.
TEST(Deck, ShearAxesParse) {
  Json j = minimal_deck();
  j["tests"][0]["axes"]["x12"] = {{"strain_increment", 1e-6}};
  j["tests"][0]["axes"]["x13"] = {{"stress", -2.5e3}};
  j["tests"][0]["axes"]["x23"] = {{"strain_rate", 0.3}};
  Deck d = parse_deck(j.dump());
  const Leg& leg = d.tests[0].legs[0];
  ASSERT_TRUE(leg.axes[3].mode != AxisMode::Held && leg.axes[4].mode != AxisMode::Held && leg.axes[5].mode != AxisMode::Held);
  EXPECT_EQ(leg.axes[3 + 0].mode, AxisMode::StrainIncrement);
  EXPECT_EQ(leg.axes[3 + 0].value, 1e-6);
  EXPECT_EQ(leg.axes[3 + 1].mode, AxisMode::Stress);
  EXPECT_EQ(leg.axes[3 + 1].value, -2.5e3);
  EXPECT_EQ(leg.axes[3 + 2].mode, AxisMode::StrainRate);
  EXPECT_DOUBLE_EQ(leg.strain_per_step(3 + 2, 1e-6), 0.3e-6);
  EXPECT_EQ(d.tests[1].legs[0].axes[3].mode, AxisMode::Held);  // left out: the tilt is held
  // zero_shear_stress: the three shear stresses servo-held at 0, in a program's leg too.
  j = minimal_deck();
  j["tests"][0]["zero_shear_stress"] = true;
  d = parse_deck(j.dump());
  for (int k = 3; k < kComponents; ++k) {
    const AxisControl* a = &d.tests[0].legs[0].axes[static_cast<std::size_t>(k)];
    ASSERT_TRUE(a);
    EXPECT_EQ(a->mode, AxisMode::Stress);
    EXPECT_EQ(a->value, 0.0);
  }
  j = minimal_deck();
  Json leg0 = {{"axes", j["tests"][0]["axes"]}, {"end", j["tests"][0]["end"]}, {"zero_shear_stress", true}};
  j["tests"][0].erase("axes");
  j["tests"][0].erase("end");
  j["tests"][0]["legs"] = Json::array({leg0});
  EXPECT_NE(parse_deck(j.dump()).tests[0].legs[0].axes[5].mode, AxisMode::Held);
}

// simple_shear: g12 driven, s22 held by the servo, e1 = e3 = 0, the other tilts held.
TEST(Deck, SimpleShearIsItsAxes) {
  Json j = minimal_deck();
  j["tests"][0].erase("axes");
  j["tests"][0]["simple_shear"] = {{"gamma_increment", 1e-6}, {"normal_stress", 1e5}};
  j["tests"][0]["end"] = {{"steps", 1000}};
  Deck d = parse_deck(j.dump());
  const Leg& leg = d.tests[0].legs[0];
  EXPECT_EQ(leg.axes[0].mode, AxisMode::StrainIncrement);
  EXPECT_EQ(leg.axes[0].value, 0.0);
  EXPECT_EQ(leg.axes[1].mode, AxisMode::Stress);
  EXPECT_EQ(leg.axes[1].value, 1e5);
  EXPECT_EQ(leg.axes[2].mode, AxisMode::StrainIncrement);
  EXPECT_EQ(leg.axes[2].value, 0.0);
  ASSERT_NE(leg.axes[3].mode, AxisMode::Held);
  EXPECT_EQ(leg.axes[3 + 0].mode, AxisMode::StrainIncrement);
  EXPECT_EQ(leg.axes[3 + 0].value, 1e-6);
  EXPECT_TRUE(leg.axes[4].mode == AxisMode::Held && leg.axes[5].mode == AxisMode::Held);
  j["tests"][0]["simple_shear"] = {{"gamma_rate", -2.0}, {"normal_stress", 5e4}};
  d = parse_deck(j.dump());
  EXPECT_EQ(d.tests[0].legs[0].axes[3 + 0].mode, AxisMode::StrainRate);
  EXPECT_EQ(d.tests[0].legs[0].axes[3 + 0].value, -2.0);
  // Errors name the key.
  j["tests"][0]["simple_shear"] = {{"gamma_rate", 1.0}, {"gamma_increment", 1e-6}, {"normal_stress", 5e4}};
  expect_error(j, "tests[0].simple_shear", "exactly one");
  j["tests"][0]["simple_shear"] = {{"gamma_rate", 1.0}};
  expect_error(j, "tests[0].simple_shear.normal_stress", "missing");
  j["tests"][0]["simple_shear"] = {{"gamma_increment", 0.0}, {"normal_stress", 5e4}};
  expect_error(j, "tests[0].simple_shear.gamma_increment", "non-zero");
  j["tests"][0]["simple_shear"] = {{"gamma_rate", 1.0}, {"normal_stress", -5e4}};
  expect_error(j, "tests[0].simple_shear.normal_stress", "> 0");
  j["tests"][0]["simple_shear"] = {{"gamma_rate", 1.0}, {"normal_stress", 5e4}};
  j["tests"][0]["zero_shear_stress"] = true;
  expect_error(j, "tests[0].zero_shear_stress", "simple_shear");
  j["tests"][0].erase("zero_shear_stress");
  j["tests"][0]["axes"] = minimal_deck()["tests"][0]["axes"];
  expect_error(j, "tests[0].simple_shear", "not both");
}

// A strain end on a shear axis (x12, x13, x23) ends the leg on its engineering shear strain g_ij, of an axis the
// leg drives by its strain; anything else is refused naming the key.
TEST(Deck, ShearLegsEndOnTheirShearStrain) {
  Json j = minimal_deck();
  j["tests"][0].erase("axes");
  j["tests"][0]["simple_shear"] = {{"gamma_increment", 1e-6}, {"normal_stress", 1e5}};
  j["tests"][0]["end"] = {{"axis", "x12"}, {"strain", 0.02}};
  const LegEnd e = parse_deck(j.dump()).tests[0].legs[0].end;
  EXPECT_EQ(e.kind, LegEndKind::Strain);
  EXPECT_EQ(e.axis, 3);  // x12, the fourth component
  EXPECT_EQ(e.value, 0.02);
  // A shear axis the leg does not drive, or holds at a shear stress.
  j["tests"][0]["end"] = {{"axis", "x13"}, {"strain", 0.02}};
  expect_error(j, "tests[0].end.axis", "x13");
  j["tests"][0]["end"] = {{"axis", "x12"}, {"stress", 1e5}, {"max_steps", 10}};
  expect_error(j, "tests[0].end.axis", "only on its strain");
  j["tests"][0]["end"] = {{"axis", "x12"}, {"strain", -0.02}};
  expect_error(j, "tests[0].end.strain", "not sheared towards");
  j["tests"][0]["end"] = {{"axis", "x12"}, {"strain", 5e-7}};
  expect_error(j, "tests[0].end.strain", "shorter than one step");
  j["tests"][0]["end"] = {{"axis", "x21"}, {"strain", 0.02}};
  expect_error(j, "tests[0].end.axis", "unknown value");
  Json held = minimal_deck();
  held["tests"][0]["axes"]["x12"] = {{"stress", 0.0}};
  held["tests"][0]["end"] = {{"axis", "x12"}, {"strain", 0.02}};
  expect_error(held, "tests[0].end.axis", "holds a stress on it");
  // In a program: the second leg shears back from where the first left g12, its path named.
  Json program = minimal_deck();
  program["tests"][0].erase("axes");
  program["tests"][0].erase("end");
  const Json axes = {{"x1", {{"strain_increment", 0.0}}}, {"x2", {{"stress", 1e5}}}, {"x3", {{"strain_increment", 0.0}}}};
  Json forward = {{"axes", axes}, {"end", {{"axis", "x12"}, {"strain", 0.01}}}};
  forward["axes"]["x12"] = {{"strain_increment", 2e-6}};
  Json back = {{"axes", axes}, {"end", {{"axis", "x12"}, {"strain", 0.004}}}};
  back["axes"]["x12"] = {{"strain_rate", -1.0}};
  program["tests"][0]["legs"] = Json::array({forward, back});
  const Deck d = parse_deck(program.dump());
  EXPECT_EQ(d.tests[0].legs[1].end.kind, LegEndKind::Strain);
  program["tests"][0]["legs"][1]["axes"].erase("x12");
  expect_error(program, "tests[0].legs[1].end.axis", "the leg holds its tilt");
  // The preparation has no shear axes to end on.
  Json prep = minimal_deck();
  prep["prepare"]["legs"] = Json::array({{{"axes", axes}, {"end", {{"axis", "x12"}, {"strain", 0.01}}}}});
  expect_error(prep, "prepare.legs[0].end.axis");
}

// rotate_principal_axes: the plane's two axes and its shear axis become stress axes whose targets rotate.
TEST(Deck, PrincipalAxisRotationParsesAndItsMixesAreChecked) {
  Json j = minimal_deck();
  j["tests"][0]["axes"] = {{"x3", {{"stress", 1e5}}}};
  j["tests"][0]["rotate_principal_axes"] = {{"plane", "x1x2"}, {"sigma1", 1.5e5}, {"sigma3", 1e5}, {"from", 30.0},
                                            {"angle_increment", 1e-3}};
  j["tests"][0]["end"] = {{"steps", 90000}};
  const Deck d = parse_deck(j.dump());
  const Leg& leg = d.tests[0].legs[0];
  ASSERT_TRUE(leg.rotation);
  EXPECT_EQ(leg.rotation->plane, 0);
  EXPECT_TRUE(leg.rotation->per_step);
  EXPECT_DOUBLE_EQ(leg.rotation->from, M_PI / 6.0);
  EXPECT_DOUBLE_EQ(leg.rotation->rate, 1e-3 * M_PI / 180.0);
  // At 30 degrees: s11 = m + r cos 60 = 1.375e5, s22 = 1.125e5, s12 = r sin 60 (m = 1.25e5, r = 2.5e4).
  EXPECT_EQ(leg.axes[0].mode, AxisMode::Stress);
  EXPECT_NEAR(leg.axes[0].value, 1.375e5, 1e-9);
  EXPECT_NEAR(leg.axes[1].value, 1.125e5, 1e-9);
  ASSERT_NE(leg.axes[3].mode, AxisMode::Held);
  EXPECT_NEAR(leg.axes[3 + 0].value, 2.5e4 * std::sqrt(3.0) / 2.0, 1e-9);
  EXPECT_EQ(leg.axes[2].value, 1e5);
  // 60000 steps later the angle is 90 degrees: sigma1 on x2.
  const std::array<double, 3> t = leg.rotation->targets(60000 * 1e-6, 1e-6);
  EXPECT_NEAR(t[0], 1e5, 1e-6);
  EXPECT_NEAR(t[1], 1.5e5, 1e-6);
  EXPECT_NEAR(t[2], 0.0, 1e-6);
  const std::string at = "tests[0]";
  Json e = j;
  e["tests"][0]["axes"]["x1"] = {{"stress", 1e5}};
  expect_error(e, at + ".axes.x1", "rotate_principal_axes");
  e = j;
  e["tests"][0]["axes"]["x12"] = {{"stress", 0.0}};
  expect_error(e, at + ".axes.x12", "rotate_principal_axes");
  e = j;
  e["tests"][0]["rotate_principal_axes"]["sigma3"] = 2e5;
  expect_error(e, at + ".rotate_principal_axes.sigma3", "<= sigma1");
  e = j;
  e["tests"][0]["rotate_principal_axes"]["rate"] = 10.0;
  expect_error(e, at + ".rotate_principal_axes", "exactly one");
  e = j;
  e["tests"][0]["rotate_principal_axes"]["plane"] = "x2x1";
  expect_error(e, at + ".rotate_principal_axes.plane", "unknown value");
  e = j;
  e["tests"][0]["axes"]["x3"] = {{"mean_stress", 1e5}};
  expect_error(e, at + ".axes.x3", "beside rotate_principal_axes");
  e = j;
  e["tests"][0]["end"] = {{"equilibrium", true}};
  expect_error(e, at + ".end.equilibrium", "rotation");
  e = j;
  e["tests"][0]["zero_shear_stress"] = true;
  expect_error(e, at + ".zero_shear_stress", "rotate_principal_axes");
}

TEST(DeckErrors, ShearAxesNameTheKey) {
  Json j = minimal_deck();
  j["tests"][0]["axes"]["x12"] = {{"strain_increment", 1e-6}, {"stress", 0.0}};
  expect_error(j, "tests[0].axes.x12", "exactly one");
  j["tests"][0]["axes"]["x12"] = Json::object();
  expect_error(j, "tests[0].axes.x12", "exactly one");
  j["tests"][0]["axes"]["x12"] = {{"b", 0.5}};  // the normal axes' couplings are not shear controls
  expect_error(j, "tests[0].axes.x12.b", "unknown key");
  j["tests"][0]["axes"]["x12"] = {{"strain_increment", 0.5}};
  expect_error(j, "tests[0].axes.x12.strain_increment", "must be in");
  j["tests"][0]["axes"]["x12"] = {{"stress", "zero"}};
  expect_error(j, "tests[0].axes.x12.stress", "expected a number");
  j = minimal_deck();
  j["tests"][0]["axes"]["x21"] = {{"stress", 0.0}};  // the lower triangle is no axis
  expect_error(j, "tests[0].axes.x21", "unknown key");
  // Contradictory: all three shear stresses at zero and a shear axis of its own.
  j = minimal_deck();
  j["tests"][0]["zero_shear_stress"] = true;
  j["tests"][0]["axes"]["x23"] = {{"strain_increment", 1e-6}};
  expect_error(j, "tests[0].zero_shear_stress", "x23");
  j["tests"][0]["axes"].erase("x23");
  j["tests"][0]["zero_shear_stress"] = false;
  expect_error(j, "tests[0].zero_shear_stress", "only true");
  // A leg that ends in equilibrium cannot shear: a shear strain that moves, refused; a held one accepted.
  j = minimal_deck();
  j["tests"][0]["axes"] = {{"x1", {{"stress", 1e5}}}, {"x2", {{"stress", 1e5}}}, {"x3", {{"mean_stress", 1e5}}},
                           {"x12", {{"strain_rate", 1.0}}}};
  j["tests"][0]["end"] = {{"equilibrium", true}};
  expect_error(j, "tests[0].axes.x12", "equilibrium");
  j["tests"][0]["axes"]["x12"] = {{"strain_increment", 0.0}};
  EXPECT_NO_THROW((void)parse_deck(j.dump()));
}

// A stress_ramp axis: its target moves from `from` at `rate` (tests[].axes.xK.stress_ramp).
Json ramp_deck();

// tests[].adaptive_rate: beside axes (and in a program's leg), its defaults from the key table; refused where the
// factor has no one meaning (stress ramps, rotations, a steps end), with nothing to drive, in the preparation,
// with min_factor above max_factor, or with an unknown key, each naming the key.
TEST(Deck, AdaptiveRateParsesAndIsRefusedWhereItMeansNothing) {
  Json j = minimal_deck();
  j["tests"][0]["adaptive_rate"] = {{"max_factor", 4}, {"unbalanced_force_ratio", 0.01}};
  Deck d = parse_deck(j.dump());
  ASSERT_TRUE(d.tests[0].legs[0].adaptive);
  const AdaptiveRate& a = *d.tests[0].legs[0].adaptive;
  EXPECT_EQ(a.max_factor, 4.0);
  EXPECT_EQ(a.unbalanced_force_ratio, 0.01);
  EXPECT_EQ(a.min_factor, keys::adaptive_min_factor.fallback);
  EXPECT_EQ(a.kinetic_to_elastic, keys::adaptive_kinetic_to_elastic.fallback);
  EXPECT_EQ(a.inertial_number, keys::adaptive_inertial_number.fallback);
  EXPECT_EQ(a.check_interval, static_cast<std::int64_t>(keys::adaptive_check_interval.fallback));
  EXPECT_FALSE(d.tests[1].legs[0].adaptive);
  // In a program's leg.
  Json legs = minimal_deck();
  Json leg0 = {{"axes", legs["tests"][0]["axes"]}, {"end", legs["tests"][0]["end"]}, {"adaptive_rate", Json::object()}};
  legs["tests"][0].erase("axes");
  legs["tests"][0].erase("end");
  legs["tests"][0]["legs"] = Json::array({leg0});
  EXPECT_TRUE(parse_deck(legs.dump()).tests[0].legs[0].adaptive.has_value());
  // Refusals.
  Json e = j;
  e["tests"][0]["adaptive_rate"] = {{"max_factor", 0.95}};  // (min_factor <= 1 <= max_factor: the key ranges)
  expect_error(e, "tests[0].adaptive_rate.max_factor");
  e["tests"][0]["adaptive_rate"] = {{"min_factor", 1.5}};
  expect_error(e, "tests[0].adaptive_rate.min_factor");
  e["tests"][0]["adaptive_rate"] = {{"min_factor", 1.0}, {"max_factor", 1.0}};
  EXPECT_NO_THROW(parse_deck(e.dump()));  // a fixed rate, written the long way
  e["tests"][0]["adaptive_rate"] = {{"speed", 2}};
  expect_error(e, "tests[0].adaptive_rate.speed");
  e["tests"][0]["adaptive_rate"] = {{"check_interval", 0}};
  expect_error(e, "tests[0].adaptive_rate.check_interval");
  e["tests"][0]["adaptive_rate"] = {{"unbalanced_force_ratio", 0}};
  expect_error(e, "tests[0].adaptive_rate.unbalanced_force_ratio");
  e = j;
  e["tests"][0]["end"] = {{"steps", 1000}};
  expect_error(e, "tests[0].adaptive_rate", "steps");
  e = ramp_deck();
  e["tests"][0]["adaptive_rate"] = Json::object();
  expect_error(e, "tests[0].adaptive_rate", "stress_ramp");
  e = minimal_deck();  // psc drives x3 at a rate: fine; with every axis on a stress: nothing to adapt
  e["tests"][1]["adaptive_rate"] = Json::object();
  EXPECT_NO_THROW(parse_deck(e.dump()));
  e["tests"][1]["axes"] = {{"x1", {{"stress", 1e5}}}, {"x2", {{"strain_increment", 0.0}}}, {"x3", {{"stress", 1e5}}}};
  e["tests"][1]["end"] = {{"ratio", 2.0}};
  expect_error(e, "tests[1].adaptive_rate", "nothing to adapt");
  e = minimal_deck();
  e["prepare"] = Json::parse(R"({"target_pressure": 1e5, "legs": [
      {"axes": {"x1": {"strain_increment": 1e-5}, "x2": {"strain_increment": 1e-5}, "x3": {"strain_increment": 1e-5}},
       "end": {"solid_fraction": 0.5}, "adaptive_rate": {}}]})");
  expect_error(e, "prepare.legs[0].adaptive_rate", "tests only");
}

Json ramp_deck() {
  Json j = minimal_deck();
  j["tests"][0]["axes"] = Json::parse(R"({"x1": {"stress_ramp": {"from": 1e5, "rate": 5e6}},
      "x2": {"stress": 1e5}, "x3": {"stress": 1e5}})");
  j["tests"][0]["end"] = Json::parse(R"({"axis": "x1", "stress": 1.5e5, "max_steps": 100000})");
  return j;
}

TEST(Deck, StressRampAxisParses) {
  const Deck d = parse_deck(ramp_deck().dump(), "x.json");
  const AxisControl& a = d.tests[0].legs[0].axes[0];
  EXPECT_EQ(a.mode, AxisMode::StressRamp);
  EXPECT_EQ(a.value, 1e5);
  EXPECT_EQ(a.rate, 5e6);
  EXPECT_TRUE(a.stress_driven());
  EXPECT_FALSE(a.strain_driven());
  EXPECT_DOUBLE_EQ(a.stress_target(0.004), 1e5 + 5e6 * 0.004);
  // Unloading: a negative rate towards a lower end stress.
  Json down = ramp_deck();
  down["tests"][0]["axes"]["x1"]["stress_ramp"]["rate"] = -5e6;
  down["tests"][0]["end"]["stress"] = 5e4;
  EXPECT_EQ(parse_deck(down.dump()).tests[0].legs[0].axes[0].rate, -5e6);
  // Beside a strain-driven axis, ending on a strain or a step count.
  Json path = ramp_deck();
  path["tests"][0]["axes"]["x1"] = {{"strain_increment", 2e-7}};
  path["tests"][0]["axes"]["x2"] = {{"stress_ramp", {{"from", 1e5}, {"rate", -1e6}}}};
  path["tests"][0]["end"] = {{"axis", "x1"}, {"strain", 0.01}};
  EXPECT_EQ(parse_deck(path.dump()).tests[0].legs[0].axes[1].mode, AxisMode::StressRamp);
}

TEST(DeckErrors, StressRampBadValuesNameTheKey) {
  const std::string at = "tests[0].axes.x1.stress_ramp";
  Json j = ramp_deck();
  j["tests"][0]["axes"]["x1"]["stress_ramp"]["rate"] = 0.0;
  expect_error(j, at + ".rate", "non-zero");
  j = ramp_deck();
  j["tests"][0]["axes"]["x1"]["stress_ramp"]["rate"] = 1e16;
  expect_error(j, at + ".rate", "must be in");
  j = ramp_deck();
  j["tests"][0]["axes"]["x1"]["stress_ramp"]["rate"] = "fast";
  expect_error(j, at + ".rate", "number");
  j = ramp_deck();
  j["tests"][0]["axes"]["x1"]["stress_ramp"].erase("rate");
  expect_error(j, at + ".rate", "missing");
  j = ramp_deck();
  j["tests"][0]["axes"]["x1"]["stress_ramp"].erase("from");
  expect_error(j, at + ".from", "missing");
  for (const double from : {0.0, -1e5}) {
    j = ramp_deck();
    j["tests"][0]["axes"]["x1"]["stress_ramp"]["from"] = from;
    expect_error(j, at + ".from", "> 0");
  }
  j = ramp_deck();
  j["tests"][0]["axes"]["x1"]["stress_ramp"]["to"] = 2e5;
  expect_error(j, at + ".to", "unknown key");
  j = ramp_deck();
  j["tests"][0]["axes"]["x1"]["stress_ramp"] = 5e6;
  expect_error(j, at, "object");
  j = ramp_deck();
  j["tests"][0]["axes"]["x1"]["stress"] = 1e5;
  expect_error(j, "tests[0].axes.x1", "exactly one");
  // The end stress lies behind the ramp.
  j = ramp_deck();
  j["tests"][0]["end"]["stress"] = 9e4;
  expect_error(j, "tests[0].end.stress", "moves away");
  // Beside axes whose targets follow the other stresses.
  j = ramp_deck();
  j["tests"][0]["axes"]["x2"] = {{"strain_increment", 1e-7}};
  j["tests"][0]["axes"]["x3"] = {{"mean_stress", 1e5}};
  expect_error(j, at, "b or mean_stress");
  j = ramp_deck();
  j["tests"][0]["axes"]["x2"] = {{"strain_increment", 1e-7}};
  j["tests"][0]["axes"]["x3"] = {{"b", 0.5}};
  expect_error(j, "tests[0].axes.x3.b", "one other stress");
  // An equilibrium end needs constant targets.
  j = ramp_deck();
  j["tests"][0]["end"] = {{"equilibrium", true}};
  expect_error(j, "tests[0].end.equilibrium", "every axis on stress or mean_stress");
}

// A test leg may end in equilibrium; its criterion is the test's `equilibrium`, each key defaulting to the
// preparation's.
Json hold_deck() {
  Json j = minimal_deck();
  j["prepare"]["equilibrium"] = {{"unbalanced_force_ratio", 0.02}, {"min_steps", 700}};
  j["tests"][0].erase("axes");
  j["tests"][0].erase("end");
  j["tests"][0]["legs"] = Json::parse(R"([
      {"axes": {"x1": {"stress_ramp": {"from": 1e5, "rate": 5e6}}, "x2": {"stress_ramp": {"from": 1e5, "rate": 5e6}},
                "x3": {"stress_ramp": {"from": 1e5, "rate": 5e6}}}, "end": {"axis": "x1", "stress": 1.2e5, "max_steps": 10000}},
      {"axes": {"x1": {"stress": 1.2e5}, "x2": {"stress": 1.2e5}, "x3": {"stress": 1.2e5}}, "end": {"equilibrium": true}}])");
  j["tests"][0]["equilibrium"] = {{"check_interval", 50}, {"stress_tolerance", 0.01}};
  return j;
}

TEST(Deck, TestLegsEndInEquilibriumWithTheTestsOrThePreparationsCriterion) {
  const Deck d = parse_deck(hold_deck().dump(), "x.json");
  const TestDef& t = d.tests[0];
  EXPECT_EQ(t.legs[1].end.kind, LegEndKind::Equilibrium);
  EXPECT_EQ(t.equilibrium.check_interval, 50);     // the test's
  EXPECT_EQ(t.equilibrium.stress_tolerance, 0.01);  // the test's
  EXPECT_EQ(t.equilibrium.unbalanced_force_ratio, 0.02);  // the preparation's
  EXPECT_EQ(t.equilibrium.min_steps, 700);                 // the preparation's
  EXPECT_EQ(t.equilibrium.pressure_tolerance, keys::equilibrium_pressure_tolerance.fallback);  // the default
  EXPECT_EQ(t.equilibrium.max_steps, static_cast<std::int64_t>(keys::equilibrium_max_steps.fallback));
  // Another test without the key takes the preparation's criterion whole.
  EXPECT_EQ(d.tests[1].equilibrium.min_steps, 700);
  EXPECT_EQ(d.tests[1].equilibrium.check_interval, d.prepare->equilibrium.check_interval);
  // Without a preparation: the defaults.
  Json state = hold_deck();
  state.erase("prepare");
  state["initial_state"] = "a.state";
  EXPECT_EQ(parse_deck(state.dump()).tests[0].equilibrium.min_steps,
            static_cast<std::int64_t>(keys::equilibrium_min_steps.fallback));
  // The one-leg form too.
  Json one = minimal_deck();
  one["tests"][0]["axes"] = Json::parse(R"({"x1": {"stress": 2e5}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}})");
  one["tests"][0]["end"] = {{"equilibrium", true}};
  EXPECT_EQ(parse_deck(one.dump()).tests[0].legs[0].end.kind, LegEndKind::Equilibrium);
}

TEST(DeckErrors, TestEquilibriumBadValuesNameTheKey) {
  Json j = hold_deck();
  j["tests"][0]["legs"][1]["end"]["equilibrium"] = false;
  expect_error(j, "tests[0].legs[1].end.equilibrium", "only true");
  j = hold_deck();
  j["tests"][0]["legs"][1]["axes"]["x1"] = {{"strain_increment", 0.0}};
  expect_error(j, "tests[0].legs[1].end.equilibrium", "every axis on stress or mean_stress");
  j = hold_deck();
  j["tests"][0]["legs"][1]["end"]["steps"] = 10;
  expect_error(j, "tests[0].legs[1].end", "exactly one");
  j = hold_deck();
  j["tests"][0]["equilibrium"]["tolerance"] = 0.1;
  expect_error(j, "tests[0].equilibrium.tolerance", "unknown key");
  j = hold_deck();
  j["tests"][0]["equilibrium"]["check_interval"] = 0;
  expect_error(j, "tests[0].equilibrium.check_interval", "must be in");
  j = hold_deck();
  j["tests"][0]["equilibrium"]["unbalanced_force_ratio"] = 2.0;
  expect_error(j, "tests[0].equilibrium.unbalanced_force_ratio", "must be in");
  j = hold_deck();
  j["tests"][0]["equilibrium"]["min_steps"] = 1.5;
  expect_error(j, "tests[0].equilibrium.min_steps", "integer");
  j = hold_deck();
  j["tests"][0]["equilibrium"] = 1;
  expect_error(j, "tests[0].equilibrium", "object");
  j = hold_deck();  // solid_fraction stays the preparation's
  j["tests"][0]["legs"][1]["end"] = {{"solid_fraction", 0.6}};
  expect_error(j, "tests[0].legs[1].end", "\"steps\", \"equilibrium\"");
}

TEST(DeckErrors, NotJsonOrTooDeepIsADeckError) {
  EXPECT_THROW(parse_deck("{\"format\": 1,"), DeckError);
  EXPECT_THROW(parse_deck(""), DeckError);
  EXPECT_THROW(parse_deck("[1, 2]"), DeckError);
  try {  // the top level has the empty path: the message names the deck, never ": expected"
    parse_deck("[1, 2]");
  } catch (const DeckError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("deck: expected an object", 0), 0u) << e.what();
  }
  EXPECT_THROW(parse_deck(std::string(100000, '[') + std::string(100000, ']')), DeckError);
  EXPECT_THROW(read_deck("/nonexistent/celldem/deck.json"), DeckError);
}

TEST(Deck, ReadDeckFromFileKeepsSource) {
  testing::TempDir dir;
  const auto path = dir.path() / "d.json";
  testing::write_bytes(path, "// a comment\n" + minimal_deck().dump(2));
  const Deck d = read_deck(path.string());
  EXPECT_EQ(d.source, path.string());
  EXPECT_EQ(d.sample.count, 100);
}

// Hostile numbers are refused naming the key that is wrong, not a key that a derived number trips.
TEST(DeckErrors, ExtremeNumbersNameTheirKey) {
  // A density whose spheres weigh less than the smallest normal double: the density, not the time step.
  Json j = minimal_deck();
  j["sample"]["density"] = 1e-300;
  expect_error(j, "sample.density", "below the smallest normal double");
  j["sample"]["density"] = 1e-30;  // light, but a double carries it (the time step's bounds judge it)
  expect_error(j, "time_step");
  // Diameters that break the bound at any density are named instead.
  j = minimal_deck();
  j["sample"]["diameters"] = {{"list", {1e-70}}};
  j["sample"]["grid_spacing"] = 2e-70;
  expect_error(j, "sample.diameters", "below the smallest normal double");
  // A grid whose cell volume overflows; a stiffness whose mode's frequency overflows (a stability limit of 0 s).
  j = minimal_deck();
  j["sample"]["grid_spacing"] = 1e200;
  expect_error(j, "sample.grid_spacing", "overflows");
  j = minimal_deck();
  j["contact"]["kn"] = 1e308;
  expect_error(j, "contact.kn", "stability limit is 0 s");
  j = minimal_deck();
  j["contact"]["kt"] = 1e308;
  expect_error(j, "contact.kt", "stability limit is 0 s");
  // A leg whose steps overflow the step count; stresses no sphere carries, or that round-off swallows.
  j = minimal_deck();
  j["tests"][0]["axes"]["x1"] = {{"strain_increment", 1e-300}};
  expect_error(j, "tests[0].end.strain", "the leg takes 1e+299 steps");
  j = minimal_deck();
  j["prepare"]["target_pressure"] = 1e308;
  expect_error(j, "prepare.target_pressure", "pass through one another");
  j["prepare"]["target_pressure"] = 1e-300;
  expect_error(j, "prepare.target_pressure", "round-off");
  j = minimal_deck();
  j["tests"][0]["axes"]["x2"] = {{"stress", 1e300}};
  expect_error(j, "tests[0] (test 'ttc', leg 0): axes.x2", "pass through one another");
}

Json probed_deck(const Json& probes) {
  Json j = minimal_deck();
  j["tests"][0]["probes"] = probes;
  return j;
}

// Probe directions whose length overflows, and probes too small to measure anything, are refused naming the key.
TEST(DeckErrors, ProbesOutsideWhatDoublesResolve) {
  const Json list = {{"at_e1", {0.002}}, {"plane", "list"}, {"magnitudes", {2000}}};
  Json j = probed_deck(list);
  j["tests"][0]["probes"]["list"] = {{1e308, 1e308, 1e308}};
  expect_error(j, "tests[0].probes.list[0]", "overflows");
  j["tests"][0]["probes"]["list"] = {{1.0, 0.0, 0.0}, {1e-160, 0.0, 0.0}};
  expect_error(j, "tests[0].probes.list[1]", "below the smallest normal double");
  j["tests"][0]["probes"]["list"] = {{0.0, 0.0, 0.0}};
  expect_error(j, "tests[0].probes.list[0]", "length 0");
  // Components of any ordinary size are a direction like any other, normalised to length 1.
  j["tests"][0]["probes"]["list"] = {{1e100, 0.0, 1e100}};
  const Deck d = parse_deck(j.dump());
  EXPECT_DOUBLE_EQ(d.tests[0].probes->list[0][0], std::sqrt(0.5));
  EXPECT_DOUBLE_EQ(d.tests[0].probes->list[0][2], std::sqrt(0.5));
  // 1e-12 Pa at 1e5 Pa: below 1e-9 of the test's stress.
  j = probed_deck({{"at_e1", {0.002}}, {"magnitudes", {2000, 1e-12}}});
  expect_error(j, "tests[0].probes.magnitudes[1]", "1e-17 of the test's stress");
  j["tests"][0]["probes"]["magnitudes"] = {1e-4};  // 1e-9 of 1e5 Pa: the smallest accepted
  EXPECT_NO_THROW(parse_deck(j.dump()));
  j = probed_deck({{"at_e1", {0.002}}, {"kind", "strain"}, {"magnitudes", {1e-12}}});
  expect_error(j, "tests[0].probes.magnitudes[0]", "at least 1e-08");
}

// The one-leg form's checks hold in every leg of a program: an end strain behind the leg's drive, a strain end
// on a shear axis the leg holds by stress; and an end that the leg's own servo keeps it from is refused, naming
// the leg and the key, in both forms.
TEST(DeckErrors, EveryLegIsCheckedLikeTheOneLegForm) {
  Json j = minimal_deck();
  j["tests"][0].erase("axes");
  j["tests"][0].erase("end");
  const Json axes = {{"x1", {{"strain_increment", 1e-6}}}, {"x2", {{"stress", 1e5}}}, {"x3", {{"stress", 1e5}}}};
  j["tests"][0]["legs"] = {{{"axes", axes}, {"end", {{"strain", 0.01}}}},
                           {{"axes", axes}, {"end", {{"strain", 0.005}}}}};
  expect_error(j, "tests[0].legs (leg 1 of the program, repeats unrolled): end.strain",
               "not strained towards this value");
  j["tests"][0]["legs"][1]["axes"]["x1"] = {{"strain_increment", -1e-6}};  // unloading: towards it
  EXPECT_NO_THROW(parse_deck(j.dump()));
  // A shear strain end on an axis the leg holds at a shear stress, in a program.
  Json shear = j;
  shear["tests"][0]["legs"][1]["axes"]["x12"] = {{"stress", 0.0}};
  shear["tests"][0]["legs"][1]["end"] = {{"axis", "x12"}, {"strain", 0.01}, {"max_steps", 1000}};
  expect_error(shear, "tests[0].legs[1].end.axis", "holds a stress on it");
  // A stress end on an axis the leg holds at 1e5 Pa, which it starts at (the leg before held it there).
  Json stress = j;
  stress["tests"][0]["legs"][1]["end"] = {{"axis", "x2"}, {"stress", 2e5}, {"max_steps", 100000}};
  expect_error(stress, "tests[0].legs (leg 1 of the program, repeats unrolled): end.stress",
               "never reaches this end stress");
  stress["tests"][0]["legs"][1]["axes"]["x2"] = {{"stress", 3e5}};  // a step of the target passes 2e5: reachable
  EXPECT_NO_THROW(parse_deck(stress.dump()));
  // The one-leg form after the preparation's servo (1e5 Pa on every axis).
  Json one = minimal_deck();
  one["tests"][0]["end"] = {{"axis", "x3"}, {"stress", 5e4}, {"max_steps", 100000}};
  expect_error(one, "tests[0].end.stress", "never reaches this end stress");
  // A ratio end s11/s33 that two held axes fix at 1.
  Json ratio = j;
  ratio["tests"][0]["legs"][1]["axes"] = {{"x1", {{"stress", 1e5}}}, {"x2", {{"stress", 1e5}}}, {"x3", {{"stress", 1e5}}}};
  ratio["tests"][0]["legs"][0]["axes"]["x1"] = {{"stress", 1e5}};
  ratio["tests"][0]["legs"][0]["end"] = {{"steps", 1000}};
  ratio["tests"][0]["legs"][1]["end"] = {{"ratio", 2.0}, {"max_steps", 1000}};
  expect_error(ratio, "tests[0].legs (leg 1 of the program, repeats unrolled): end.ratio", "never reaches this end ratio");
  ratio["tests"][0]["legs"][1]["end"] = {{"ratio", 1.02}, {"max_steps", 1000}};  // within the servo's wander
  EXPECT_NO_THROW(parse_deck(ratio.dump()));
}

}  // namespace
}  // namespace celldem
