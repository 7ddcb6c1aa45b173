// The runner (solver/run/runner.hpp): determinism across thread counts (same deck -> same bytes), the
// files a run writes, and refusing to overwrite results.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "helpers.hpp"
#include "io/state_file.hpp"
#include "measure/series.hpp"
#include "run/runner.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;
using testing::read_bytes;

void run(const std::string& deck_text, const fs::path& deck_path, const fs::path& out, int threads) {
  testing::write_bytes(deck_path, deck_text);
  RunOptions options;
  options.out_dir = out.string();
  options.threads = threads;
  options.quiet = true;
  const int saved = omp_get_max_threads();
  run_deck(read_deck(deck_path.string()), options);
  omp_set_num_threads(saved);
}

// The preparation with loose tolerances stops soon after the fast compression: enough steps with enough
// contacts (300 spheres: two blocks of owners in the pair loop) to show any thread-order dependence.
std::string quick_prepare_deck() {
  std::string d = testing::small_deck_json(300, "[]", 5);
  const std::string loose = R"("equilibrium": {"pressure_tolerance": 0.9, "stress_tolerance": 0.9, "unbalanced_force_ratio": 1.0,
                                 "min_steps": 200, "check_interval": 200, "max_steps": 100000})";
  const auto at = d.find("\"equilibrium\"");
  const auto end = d.find('}', at) + 1;
  return d.replace(at, end - at, loose);
}

TEST(Runner, PreparationIsByteIdenticalForOneAndTwoThreads) {
  testing::TempDir dir;
  const std::string deck = quick_prepare_deck();
  run(deck, dir.path() / "deck.json", dir.path() / "t1", 1);
  run(deck, dir.path() / "deck.json", dir.path() / "t2", 2);
  const std::string a = read_bytes(dir.path() / "t1" / "prepared.state");
  EXPECT_EQ(a, read_bytes(dir.path() / "t2" / "prepared.state"));
  EXPECT_EQ(read_bytes(dir.path() / "t1" / "prepare" / "series.csv"),
            read_bytes(dir.path() / "t2" / "prepare" / "series.csv"));
  EXPECT_GT(parse_state(a).touching, 300);
}

// From one prepared state, a short triaxial test with friction (sliding contacts, servo on two axes) gives
// the same series.csv and final state, byte for byte, on one and on two threads.
TEST(Runner, LoadingTestIsByteIdenticalForOneAndTwoThreads) {
  testing::TempDir dir;
  run(quick_prepare_deck(), dir.path() / "prep.json", dir.path() / "prep", 1);
  fs::copy_file(dir.path() / "prep" / "prepared.state", dir.path() / "start.state");
  std::string deck = testing::small_deck_json(300, R"([{"name": "ttc", "friction": 0.5,
      "axes": {"x1": {"strain_increment": 5e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"strain": 0.004}, "output_interval": 40}])", 5);
  const auto at = deck.find("\"prepare\"");
  const auto end = deck.find("\"tests\"");
  deck.replace(at, end - at, "\"initial_state\": \"start.state\",\n  ");
  run(deck, dir.path() / "deck.json", dir.path() / "t1", 1);
  run(deck, dir.path() / "deck.json", dir.path() / "t2", 2);
  const std::string series = read_bytes(dir.path() / "t1" / "ttc" / "series.csv");
  EXPECT_EQ(series, read_bytes(dir.path() / "t2" / "ttc" / "series.csv"));
  EXPECT_EQ(read_bytes(dir.path() / "t1" / "ttc" / "final.state"), read_bytes(dir.path() / "t2" / "ttc" / "final.state"));
  // 800 steps, a row every 40 and the first: 21 rows under the header.
  EXPECT_EQ(std::count(series.begin(), series.end(), '\n'), 22);
  EXPECT_EQ(series.rfind(series_header(), 0), 0u);
  const auto summary = nlohmann::json::parse(read_bytes(dir.path() / "t1" / "summary.json"));
  EXPECT_EQ(summary["tests"]["ttc"]["steps"], 800);
  EXPECT_NEAR(summary["tests"]["ttc"]["final_e1"].get<double>(), 0.004, 1e-12);
  EXPECT_EQ(summary["settings"]["threads"], 1);
  // The deck's servo cap (4e-5) is in the settings and on the leg, which records the cap it ran with.
  EXPECT_DOUBLE_EQ(summary["settings"]["servo_max_strain_increment"].get<double>(), 4e-5);
  EXPECT_DOUBLE_EQ(summary["tests"]["ttc"]["legs"][0]["servo_cap"].get<double>(), 4e-5);
}

TEST(Runner, RefusesToOverwriteResultsWithoutForce) {
  testing::TempDir dir;
  const fs::path out = dir.path() / "out";
  fs::create_directories(out);
  testing::write_bytes(out / "summary.json", "{}");
  testing::write_bytes(dir.path() / "deck.json", quick_prepare_deck());
  RunOptions options;
  options.out_dir = out.string();
  options.threads = 1;
  options.quiet = true;
  EXPECT_THROW(run_deck(read_deck((dir.path() / "deck.json").string()), options), UsageError);
  EXPECT_EQ(read_bytes(out / "summary.json"), "{}");
  options.resume = true;  // nothing to resume either: a usage error too
  EXPECT_THROW(run_deck(read_deck((dir.path() / "deck.json").string()), options), UsageError);
}

}  // namespace
}  // namespace celldem
