// What a run checks before it does any work (solver/run/preflight.hpp), called directly: a state that agrees
// with the deck passes; one made with other physics, another sphere count or a missing file is refused
// naming the key and both values; override_state_physics turns the physics refusal into a warning naming it.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace celldem
