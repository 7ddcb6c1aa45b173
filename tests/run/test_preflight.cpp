// What a run checks before it does any work (solver/run/preflight.hpp), called directly: a state that agrees
// with the deck passes; one made with other physics, another sphere count or a missing file is refused
// naming the key and both values; override_state_physics turns the physics refusal into a warning naming it.
// The physics record keeps the springs' parameters that the key table gives the deck's sub-model choices.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "helpers.hpp"
#include "io/deck_reader.hpp"
#include "io/state_file.hpp"
#include "run/preflight.hpp"
#include "run/sample.hpp"

namespace celldem {
namespace {

// A 27-sphere deck that tests a state in `dir` (initial_state: sample.state); `extra` adds top-level keys.
std::string deck_text(double density, int count, const std::string& extra = "") {
  return R"({"format":1,
 "sample":{"count":)" + std::to_string(count) + R"(,"diameters":{"list":[0.003,0.004]},"density":)" +
         std::to_string(density) + R"(,"seed":3,"grid_spacing":0.005},
 "contact":{"kn":1e6,"kt":1e6},"damping":{"translational":0.05,"rotational":0.05},"time_step":1e-6,
 "initial_state":"sample.state",)" + extra + R"(
 "tests":[{"name":"ttc","friction":0.5,"axes":{"x1":{"strain_increment":1e-6},"x2":{"stress":1e5},"x3":{"stress":1e5}},
           "end":{"axis":"x1","strain":0.001}}]})";
}

class Preflight : public ::testing::Test {
 protected:
  // The state file of a deck with density 2650, as a run of that deck writes it (its physics record).
  void SetUp() override {
    const Deck maker = parse_deck(deck_text(2650, 27), (dir.path() / "deck.json").string());
    write_state((dir.path() / "sample.state").string(), make_grid_sample(maker.sample, 1e-4), "prepared",
                state_physics(maker));
  }
  Deck deck(double density, int count, const std::string& extra = "") {
    return parse_deck(deck_text(density, count, extra), (dir.path() / "deck.json").string());
  }
  static std::string refusal(const Deck& d) {
    try {
      preflight(d);
    } catch (const DeckError& e) {
      return e.what();
    }
    return "no refusal";
  }
  testing::TempDir dir;
};

TEST_F(Preflight, AStateThatAgreesWithItsDeckPasses) {
  EXPECT_NO_THROW(preflight(deck(2650, 27)));
  EXPECT_EQ(initial_state_path(deck(2650, 27)), (dir.path() / "sample.state").string());
}

TEST_F(Preflight, OtherPhysicsIsRefusedNamingBothValuesUnlessOverridden) {
  const std::string m = refusal(deck(2000, 27));
  EXPECT_NE(m.find("sample.density"), std::string::npos) << m;
  EXPECT_NE(m.find("2000"), std::string::npos) << m;
  EXPECT_NE(m.find("2650"), std::string::npos) << m;
  const std::vector<std::string> warnings = preflight(deck(2000, 27, R"("override_state_physics":true,)"));
  bool named = false;
  for (const std::string& w : warnings) named |= w.find("override_state_physics") != std::string::npos;
  EXPECT_TRUE(named);
}

TEST_F(Preflight, AnotherSphereCountOrAMissingFileIsRefused) {
  const std::string m = refusal(deck(2650, 26));
  EXPECT_NE(m.find("sample.count"), std::string::npos) << m;
  EXPECT_NE(m.find("27"), std::string::npos) << m;
  std::filesystem::remove(dir.path() / "sample.state");
  EXPECT_NE(refusal(deck(2650, 27)).find("no such file"), std::string::npos);
}

TEST_F(Preflight, StatePhysicsRecordsDensityAndContactLaw) {
  const std::string a = state_physics(deck(2650, 27)), b = state_physics(deck(2000, 27));
  EXPECT_NE(a, b);
  EXPECT_NE(a.find("sample.density"), std::string::npos) << a;
  EXPECT_NE(a.find("contact.kn"), std::string::npos) << a;
}


// Every combination of contact sub-model choices: the record holds a spring parameter exactly when the key
// table's sub_models give its key to one of the choices (key_used), with the deck's value, and no other
// contact number. A state_physics that keeps its own list of which law takes which key fails here.
TEST(StatePhysics, RecordsTheSpringKeysTheKeyTableGivesTheChosenSubModels) {
  const std::set<std::string> springs = {"contact.kn", "contact.kt", "contact.youngs_modulus",
                                         "contact.poisson_ratio", "contact.rolling_stiffness"};
  int combinations = 0;
  for (std::size_t n = 0; n < kNormalModelNames.size(); ++n)
    for (std::size_t t = 0; t < kTangentialModelNames.size(); ++t)
      for (std::size_t r = 0; r < kRollingModelNames.size(); ++r)
        for (std::size_t w = 0; w < kTwistingModelNames.size(); ++w) {
          Deck deck;
          deck.sample.density = 2650;
          ContactDef& c = deck.contact;
          c.normal = static_cast<NormalModel>(n);
          c.tangential = static_cast<TangentialModel>(t);
          c.rolling = static_cast<RollingModel>(r);
          c.twisting = static_cast<TwistingModel>(w);
          double value = 1.0;
          for (const ContactParameter& p : kContactParameters) c.*p.field = (value += 1.0);
          const nlohmann::json record = nlohmann::json::parse(state_physics(deck));
          const SubModelSelection chosen = c.selection();
          for (const KeySpec* key : keys::kAll) {
            const std::string path(key->path);
            if (!springs.contains(path)) continue;
            ASSERT_EQ(record.contains(path), key_used(*key, chosen)) << path << " in " << record.dump();
          }
          for (const ContactParameter& p : kContactParameters) {
            const std::string path(p.key->path);
            if (record.contains(path)) {
              EXPECT_EQ(record[path].get<double>(), c.*p.field) << path;
            }
          }
          for (const auto& [path, entry] : record.items())
            if (path.starts_with("contact.") && entry.is_number()) {
              EXPECT_TRUE(springs.contains(path)) << path << " is no spring parameter";
            }
          ++combinations;
        }
  EXPECT_EQ(combinations, 24);
  // Two laws by hand, independent of the table: linear springs record kn and kt only; hertz, mindlin and sds
  // the material and the rolling spring.
  Deck linear;
  linear.contact.kn = 1e6;
  linear.contact.kt = 2e5;
  const nlohmann::json a = nlohmann::json::parse(state_physics(linear));
  EXPECT_TRUE(a.contains("contact.kn") && a.contains("contact.kt") && !a.contains("contact.youngs_modulus") &&
              !a.contains("contact.rolling_stiffness"))
      << a.dump();
  Deck hertz;
  hertz.contact.normal = NormalModel::Hertz;
  hertz.contact.tangential = TangentialModel::Mindlin;
  hertz.contact.rolling = RollingModel::Sds;
  const nlohmann::json b = nlohmann::json::parse(state_physics(hertz));
  EXPECT_TRUE(!b.contains("contact.kn") && !b.contains("contact.kt") && b.contains("contact.youngs_modulus") &&
              b.contains("contact.poisson_ratio") && b.contains("contact.rolling_stiffness"))
      << b.dump();
}

}  // namespace
}  // namespace celldem
