// The runner (solver/run/runner.hpp): determinism across thread counts (same deck -> same bytes), the
// files a run writes, and refusing to overwrite results.
#include <gtest/gtest.h>
#include <omp.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "helpers.hpp"
#include "io/state_file.hpp"
#include "measure/series.hpp"
#include "run/run_directory.hpp"
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

// The message of a refusal, or "" when `f` did not throw UsageError.
template <class F>
std::string refusal(F f) {
  try {
    f();
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(FolderLock, RefusesALinkedLockFileAndWritesNothingThroughIt) {
  testing::TempDir dir;
  testing::write_bytes(dir.path() / "victim", "another file\n");
  fs::create_directories(dir.path() / "run");
  fs::create_symlink(dir.path() / "victim", dir.path() / "run" / kLockName);
  const std::string why = refusal([&] { FolderLock lock(dir.path() / "run"); });
  EXPECT_NE(why.find("is a symbolic link"), std::string::npos) << why;
  EXPECT_EQ(testing::read_bytes(dir.path() / "victim"), "another file\n");
}

// The folder itself is locked: deleting or replacing run.lock under its holder lets no one else in, and the one
// refused is told the holder's pid (this process's: flock locks of two open files conflict within one process).
TEST(FolderLock, HoldsWhenTheLockFileIsDeletedAndNamesTheHolder) {
  testing::TempDir dir;
  const fs::path run = dir.path() / "run";
  FolderLock held(run);
  EXPECT_EQ(testing::read_bytes(run / kLockName), "");  // the pid only once the holder writes (claim)
  held.claim();
  EXPECT_EQ(testing::read_bytes(run / kLockName), std::to_string(::getpid()) + "\n");
  fs::remove(run / kLockName);
  std::string why = refusal([&] { FolderLock second(run); });
  EXPECT_NE(why.find("in use by another celldem process (pid " + std::to_string(::getpid()) + ","), std::string::npos)
      << why;
  testing::write_bytes(run / kLockName, "1\n");  // a stale pid there: the kernel's word comes first
  why = refusal([&] { FolderLock second(run, LockMode::shared); });
  EXPECT_NE(why.find("(pid " + std::to_string(::getpid()) + ","), std::string::npos) << why;
}

TEST(FolderLock, ReadersShareAFolderAndExcludeAWriter) {
  testing::TempDir dir;
  const fs::path run = dir.path() / "run";
  fs::create_directories(run);
  {
    FolderLock a(run, LockMode::shared), b(run, LockMode::shared);  // no run.lock yet: none made
    EXPECT_FALSE(fs::exists(run / kLockName));
    EXPECT_NE(refusal([&] { FolderLock writer(run); }), "");
  }
  FolderLock writer(run);
  EXPECT_NE(refusal([&] { FolderLock reader(run, LockMode::shared); }), "");
  EXPECT_NE(refusal([&] { FolderLock reader(dir.path() / "none", LockMode::shared); }), "");
}

RunOptions options_for(const fs::path& out, bool resume) {
  RunOptions options;
  options.out_dir = out.string();
  options.threads = 1;
  options.quiet = true;
  options.resume = resume;
  return options;
}

// Marking a stage done removes its checkpoint; a run killed between the two (the stage marked, the checkpoint still
// there) has it removed by its resume. The finished stage's files are proven by their hashes: a resume refuses one
// that changed, naming it.
TEST(RunDirectory, AStageMarkedDoneKeepsNoCheckpoint) {
  testing::TempDir dir;
  testing::write_bytes(dir.path() / "deck.json", quick_prepare_deck());
  const Deck deck = read_deck((dir.path() / "deck.json").string());
  const fs::path out = dir.path() / "out";
  {
    RunDirectory run(deck, options_for(out, false));
    fs::create_directories(run.stage_dir("prepare"));
    testing::write_bytes(run.checkpoint("prepare"), "state");
    testing::write_bytes(run.stage_dir("prepare") / "series.csv", "step\n0\n");
    testing::write_bytes(run.prepared_state(), "prepared");
    run.update_summary([](nlohmann::json& s) { s["prepared"] = {{"Z", 6.0}}; });
    run.mark_done("prepare");
    EXPECT_FALSE(fs::exists(run.checkpoint("prepare")));
  }
  testing::write_bytes(out / "prepare" / kCheckpointName, "a stale checkpoint");  // as a kill in between leaves it
  {
    RunDirectory resumed(deck, options_for(out, true));
    EXPECT_TRUE(resumed.completed("prepare"));
    EXPECT_FALSE(fs::exists(out / "prepare" / kCheckpointName));
  }
  testing::write_bytes(out / "prepare" / "series.csv", "step\n0\n1\n");  // a row appended behind the run
  try {
    RunDirectory resumed(deck, options_for(out, true));
    ADD_FAILURE() << "a changed series was accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("prepare/series.csv was changed"), std::string::npos) << e.what();
  }
}

// A stage folder linked into another run is refused (fresh, --force and --resume alike), naming it; a link that
// stays in the run folder is the run's own.
TEST(RunDirectory, RefusesAStageFolderLinkedOutOfTheRun) {
  testing::TempDir dir;
  testing::write_bytes(dir.path() / "deck.json", quick_prepare_deck());
  const Deck deck = read_deck((dir.path() / "deck.json").string());
  const fs::path out = dir.path() / "out", other = dir.path() / "other" / "prepare";
  fs::create_directories(other);
  testing::write_bytes(other / "series.csv", "another run's series\n");
  fs::create_directories(out);
  fs::create_symlink(other, out / "prepare");
  for (const bool force : {false, true}) {
    RunOptions options = options_for(out, false);
    options.force = force;
    const std::string why = refusal([&] { RunDirectory run(deck, options); });
    EXPECT_NE(why.find((out / "prepare").string() + " is a symbolic link to " + other.string() +
                       ", outside the run folder"), std::string::npos) << why;
  }
  EXPECT_EQ(testing::read_bytes(other / "series.csv"), "another run's series\n");
  fs::remove(out / "prepare");
  fs::create_directories(out / "mine");
  fs::create_symlink("mine", out / "prepare");
  EXPECT_NO_THROW(RunDirectory(deck, options_for(out, false)));
}

}  // namespace
}  // namespace celldem
