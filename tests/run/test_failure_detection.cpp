// Run-time detection of settings that break the physics: an unstable time step stops the run with the
// cause and the step; a loading too fast for quasi-static conditions is reported in summary.json and on
// stderr; a servo that misses its target stops the test (or, with control_failure "warn", marks it).
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "helpers.hpp"
#include "run/preflight.hpp"
#include "run/run_directory.hpp"
#include "run/runner.hpp"
#include "run/time_step_check.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;
using testing::read_bytes;

// A dense 300-sphere sample at 100 kPa, made once for all tests here.
class FailureDetection : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    run(testing::small_deck_json(300, "[]", 7), "prep");
  }
  static void TearDownTestSuite() { delete dir_; }

  static void run(const std::string& deck_text, const std::string& name) {
    testing::write_bytes(dir_->path() / (name + ".json"), deck_text);
    RunOptions options;
    options.out_dir = (dir_->path() / name).string();
    options.threads = 1;
    options.quiet = true;
    run_deck(read_deck((dir_->path() / (name + ".json")).string()), options);
  }

  // A deck that loads the prepared sample with the given test JSON and extra top-level keys.
  static std::string test_deck(const std::string& test, const std::string& replace_from = "",
                               const std::string& replace_to = "") {
    std::string d = testing::small_deck_json(300, "[" + test + "]", 7);
    const auto at = d.find("\"prepare\"");
    d.replace(at, d.find("\"tests\"") - at, "\"initial_state\": \"prep/prepared.state\",\n  ");
    if (!replace_from.empty()) d.replace(d.find(replace_from), replace_from.size(), replace_to);
    return d;
  }

  static nlohmann::json summary(const std::string& name) {
    return nlohmann::json::parse(read_bytes(dir_->path() / name / "summary.json"));
  }

  static testing::TempDir* dir_;
};
testing::TempDir* FailureDetection::dir_ = nullptr;

TEST_F(FailureDetection, QuasiStaticLoadingRaisesNoWarning) {
  // At 2.4e-6 s: below 0.9 of the packing's contact network limit (2.79e-6 s), where the deck's 3e-6 s is warned.
  run(test_deck(R"({"name": "slow", "friction": 0.5, "axes": {"x1": {"strain_increment": 2e-7},
      "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"strain": 0.0004}, "output_interval": 100})",
                "\"time_step\": 3.0e-6", "\"time_step\": 2.4e-6"),
      "slow");
  const auto s = summary("slow");
  // The imposed rate's I = (2e-7 / 2.4e-6 s) * 3.75 mm * sqrt(2650 / 1e5), mean diameter of the four sizes 3..4.5 mm.
  // The cell's own rate is larger: the servo-held axes expand too (elastically at first, at about Poisson's ratio
  // nu times e1-dot: gamma_dot = 2 (1 + nu) / sqrt(3) e1-dot, about 1.4 e1-dot).
  const double expected = 2e-7 / 2.4e-6 * 3.75e-3 * std::sqrt(2650 / 1e5);
  EXPECT_NEAR(s["tests"]["slow"]["imposed_inertial_number"].get<double>(), expected, 0.2 * expected);
  EXPECT_GT(s["tests"]["slow"]["inertial_number"].get<double>(), 1.1 * expected);
  EXPECT_LT(s["tests"]["slow"]["inertial_number"].get<double>(), 3.0 * expected);
  EXPECT_FALSE(s.contains("warnings")) << s.dump(2);
  // 2000 steps of 2e-7: shorter than the first 0.2 % of driving strain, so no control error was measured.
  EXPECT_TRUE(s["tests"]["slow"]["servo_max_error"].is_null()) << s["tests"]["slow"].dump(1);
  EXPECT_TRUE(s["tests"]["slow"]["legs"][0]["control_errors"]["stress"].is_null());
  EXPECT_TRUE(s["tests"]["slow"]["controlled"].get<bool>());
}

TEST_F(FailureDetection, FastLoadingIsReportedAsNotQuasiStatic) {
  run(test_deck(R"({"name": "fast", "friction": 0.5, "axes": {"x1": {"strain_increment": 2e-5},
      "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"strain": 0.004}, "output_interval": 20})",
                "\"servo\": {\"max_strain_increment\": 4e-5}",
                "\"servo\": {\"max_strain_increment\": 2e-4}, \"control_failure\": \"warn\""),
      "fast");
  const auto s = summary("fast");
  EXPECT_GT(s["tests"]["fast"]["inertial_number"].get<double>(), 1e-3);
  ASSERT_TRUE(s.contains("warnings"));
  EXPECT_NE(s["warnings"].dump().find("inertial number"), std::string::npos) << s["warnings"].dump();
}

// A servo too weak to follow (not at its cap) stops the test with exit 1, naming the leg, the axis and the
// gains; with control_failure "warn" the run goes on and the test is marked uncontrolled.
const char* kWeakTest = R"({"name": "weak", "friction": 0.5, "axes": {"x1": {"strain_increment": 2e-6},
      "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"strain": 0.004}, "output_interval": 20})";
const char* kWeakServo = "\"servo\": {\"gain\": 0.0005, \"integral_gain\": 0, \"max_strain_increment\": 4e-5}";

TEST_F(FailureDetection, WeakServoStopsTheTest) {
  try {
    run(test_deck(kWeakTest, "\"servo\": {\"max_strain_increment\": 4e-5}", kWeakServo), "weak_stop");
    FAIL() << "a test whose servo missed its target finished";
  } catch (const RunError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("test 'weak' leg 0"), std::string::npos) << what;
    EXPECT_NE(what.find("axis x"), std::string::npos) << what;
    EXPECT_NE(what.find("tolerance 0.5 %"), std::string::npos) << what;
    EXPECT_NE(what.find("raise servo.gain/integral_gain"), std::string::npos) << what;
  }
}

TEST_F(FailureDetection, WeakServoIsMarkedWithWarn) {
  run(test_deck(kWeakTest, "\"servo\": {\"max_strain_increment\": 4e-5}",
                std::string(kWeakServo) + ", \"control_failure\": \"warn\""),
      "weak");
  const auto s = summary("weak");
  const auto& t = s["tests"]["weak"];
  EXPECT_GT(t["servo_max_error"].get<double>(), 0.005);
  EXPECT_FALSE(t["controlled"].get<bool>());
  ASSERT_FALSE(t["control_failures"].empty());
  EXPECT_EQ(t["control_failures"][0]["kind"], "stress");
  EXPECT_EQ(t["control_failures"][0]["tolerance"].get<double>(), 0.005);
  ASSERT_TRUE(s.contains("warnings"));
  EXPECT_NE(s["warnings"].dump().find("uncontrolled"), std::string::npos) << s["warnings"].dump();
}

// A servo held at its cap cannot follow: the message says so and names the cap. x3 is asked for a hundred times
// the sample's stress with a cap of 3 x the driving increment (the smallest check accepts).
TEST_F(FailureDetection, SaturatedServoNamesTheCap) {
  try {
    run(test_deck(R"({"name": "capped", "friction": 0.5, "axes": {"x1": {"strain_increment": 1e-6},
      "x2": {"strain_increment": 0}, "x3": {"stress": 1e7}}, "end": {"strain": 0.006}, "output_interval": 100})",
                  "\"servo\": {\"max_strain_increment\": 4e-5}", "\"servo\": {\"max_strain_increment\": 3e-6}, \"checkpoint_interval\": 500"),
        "capped");
    FAIL() << "a test whose servo sat at its cap finished";
  } catch (const RunError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("test 'capped' leg 0"), std::string::npos) << what;
    EXPECT_NE(what.find("axis x3"), std::string::npos) << what;
    EXPECT_NE(what.find("raise servo.max_strain_increment (now 3e-06)"), std::string::npos) << what;
  }
  // The last checkpoint is kept for a look (or a resume with other settings).
  EXPECT_TRUE(fs::exists(dir_->path() / "capped" / "capped" / kCheckpointName));
}

// A leg that does not reach its end condition within end.max_steps stops the run naming the test and the leg;
// a strain leg that end.max_steps stops short of its end strain is warned about before the run.
TEST_F(FailureDetection, LegLimitedByMaxStepsNamesTheTestOrIsWarned) {
  try {
    run(test_deck(R"({"name": "never", "friction": 0.5, "axes": {"x1": {"strain_increment": 2e-7},
        "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"ratio": 100, "max_steps": 50}})"), "never");
    FAIL() << "a leg that cannot end finished";
  } catch (const RunError& e) {
    EXPECT_NE(std::string(e.what()).find("test 'never' leg 0 did not reach its end condition in 50 steps"),
              std::string::npos) << e.what();
  }
  testing::write_bytes(dir_->path() / "short.json",
                       test_deck(R"({"name": "short", "friction": 0.5, "axes": {"x1": {"strain_increment": 2e-7},
        "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"strain": 0.01, "max_steps": 100}})"));
  std::string all;
  for (const std::string& w : preflight(read_deck((dir_->path() / "short.json").string()))) all += w + "\n";
  EXPECT_NE(all.find("tests[0] (test 'short', leg 0): end.max_steps 100 stops the leg at x1 strain 2e-05, short of its "
                     "end strain 0.01"), std::string::npos) << all;
}

// A strain leg after a leg whose length only running tells (here a ratio end) starts at a strain nobody knows
// before the run: when end.max_steps stops it short of its end strain, the run says so when the leg ends, on
// stderr and in summary.json's warnings, through the binary as a user runs it.
TEST_F(FailureDetection, StrainLegCutShortByMaxStepsIsWarnedAtRunTime) {
  testing::write_bytes(dir_->path() / "cut.json", test_deck(R"({"name": "cut", "friction": 0.5, "output_interval": 100,
      "legs": [
        {"axes": {"x1": {"strain_increment": 2e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
         "end": {"ratio": 1.2, "max_steps": 20000}},
        {"axes": {"x1": {"strain_increment": 2e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
         "end": {"axis": "x1", "strain": 0.05, "max_steps": 100}}]})"));
  const testing::Result r = testing::celldem(dir_->path(), testing::run_args(dir_->path() / "cut.json", dir_->path() / "cut"));
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string expected = "test 'cut' leg 1: end.max_steps 100 stopped the leg at x1 strain ";
  EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
  std::string recorded;
  const nlohmann::json written = summary("cut");
  for (const auto& w : written["warnings"]) recorded += w.get<std::string>() + "\n";
  EXPECT_NE(recorded.find(expected), std::string::npos) << recorded;
  EXPECT_NE(recorded.find("short of its end strain 0.05"), std::string::npos) << recorded;
  // Only the warning of the run: the check before it could not know where the leg starts.
  EXPECT_EQ(recorded.find("stops the leg"), std::string::npos) << recorded;
}

// A time step just under sqrt(m_min/kn) (kt = kn / 10: the normal mode limits; the deck reader refuses it above
// 0.9 of that, so the deck is changed after reading): a sphere pressed by several neighbours oscillates at
// sqrt(Z kn / m), the packing boils (unbalanced force 0.41, kinetic energy 0.037 of the elastic) or runs away,
// and the run must stop with the cause.
TEST_F(FailureDetection, UnstableTimeStepStopsTheRunWithTheCause) {
  std::string deck =
      test_deck(R"({"name": "unstable", "friction": 0.5, "axes": {"x1": {"strain_increment": 2e-7},
      "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"strain": 0.002}, "output_interval": 50})");
  deck.replace(deck.find("\"kt\": 1.0e6"), 11, "\"kt\": 1.0e5");
  deck.replace(deck.find("\"initial_state\""), 0, "\"override_state_physics\": true, ");  // prepared with kt = kn
  try {
    testing::write_bytes(dir_->path() / "unstable.json", deck);
    Deck d = read_deck((dir_->path() / "unstable.json").string());
    d.time_step = 5.9e-6;
    RunOptions options;
    options.out_dir = (dir_->path() / "unstable").string();
    options.threads = 1;
    options.quiet = true;
    run_deck(d, options);
    FAIL() << "an unstable run finished";
  } catch (const RunError& e) {
    const std::string what = e.what();
    EXPECT_TRUE(what.find("runaway") != std::string::npos || what.find("non-finite") != std::string::npos ||
                what.find("not quasi-static") != std::string::npos) << what;
    EXPECT_NE(what.find("at step"), std::string::npos) << what;
  }
}

// kt = kn/10 at 0.96 of the normal mode's limit sqrt(m/kn) = 6.12e-6 s (refused by the deck reader: set after
// reading): a frictionless preparation boils, held at its pressure with an unbalanced force ratio near 0.26, and
// its failure names the time step, not the equilibrium's step budget.
TEST_F(FailureDetection, BoilingPreparationNamesTheTimeStep) {
  Deck d = read_deck((fs::path(__FILE__).parent_path() / "small_run.json").string());
  d.contact.kt = 1e5;
  d.time_step = 0.96 * std::sqrt(2650.0 * M_PI / 6.0 * 27e-9 / 1e6);
  RunOptions options;
  options.out_dir = (dir_->path() / "boil_prep").string();
  options.threads = 1;
  options.quiet = true;
  try {
    run_deck(d, options);
    FAIL() << "a boiling preparation reached equilibrium";
  } catch (const RunError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("did not reach equilibrium"), std::string::npos) << what;
    EXPECT_NE(what.find("means the packing boils: the time step is likely too close to the stability limit"),
              std::string::npos) << what;
  }
}

// kt = 10 kn at 3e-6 s (0.49 sqrt(m/kn), 2.9 times the tangential-rotational limit; the deck reader refuses
// it, so the deck is changed after reading): the sample boils (unbalanced force ~0.4, kinetic energy ~0.14 of
// the elastic) without running away, and the run stops naming the mode; declared dynamic, it runs.
// Stiff tangential springs (kt = 10 kn) at the deck's 3e-6 s: 3.4 times the contact network's limit, where the packing
// boils (docs/physics.md), so the run is refused before it starts, naming the key and the margin. The same springs
// between the margins (1.05 of the limit, warned) stay quasi-static: sliding contacts hold the sticking network.
TEST_F(FailureDetection, BoilingSampleIsRefusedAndOneBetweenTheMarginsRuns) {
  const std::string test = R"({"name": "boil", "friction": 0.5, "axes": {"x1": {"strain_increment": 2e-7},
      "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"strain": 0.001}, "output_interval": 100})";
  const auto run_stiff = [](const std::string& deck_text, const std::string& name, double time_step) {
    testing::write_bytes(dir_->path() / (name + ".json"), deck_text);
    Deck deck = read_deck((dir_->path() / (name + ".json")).string());
    deck.contact.kt = 1e7;
    deck.override_state_physics = true;  // the prepared state's kt is kn's
    if (time_step > 0.0) deck.time_step = time_step;
    RunOptions options;
    options.out_dir = (dir_->path() / name).string();
    options.threads = 1;
    options.quiet = true;
    run_deck(deck, options);
  };
  try {
    run_stiff(test_deck(test), "boil", 0.0);
    FAIL() << "a test 3.4 times its network's limit ran";
  } catch (const DeckError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("test 'boil'"), std::string::npos) << what;
    EXPECT_NE(what.find("the refusal margin 1.1"), std::string::npos) << what;
    EXPECT_NE(what.find("set time_step to at most"), std::string::npos) << what;
  }
  Deck stiff = read_deck((dir_->path() / "boil.json").string());
  stiff.contact.kt = 1e7;
  State state = read_state((dir_->path() / "prep" / "prepared.state").string());
  state.pairs.skin = skin_length(stiff);
  const double limit =
      judge_network_time_step(make_model(stiff, state.particles.radius), state, Friction{0.5}, "x", "time_step")
          .network.limit;
  EXPECT_NO_THROW(run_stiff(test_deck(test), "boil_between", 1.05 * limit));
  EXPECT_EQ(summary("boil_between")["tests"]["boil"]["network_time_step"]["at_start"]["verdict"], "warn");
}

}  // namespace
}  // namespace celldem
