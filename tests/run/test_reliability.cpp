// Hostile input and misuse, through the binary: `check` refuses what `run` would refuse or mis-run (bad
// state files, a sample that contradicts its state, a cell too small, a time step so small the run cannot
// end), reserved and duplicate names, exit codes, --force leaving only the new run, --resume on a finished
// run. (Write failures: test_write_failure.sh.)
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "helpers.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;
using testing::celldem;
using testing::kTtc;
using testing::read_bytes;
using testing::Result;
using testing::run_args;
using testing::test_dir;
using testing::write_bytes;

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

Result check(const fs::path& dir, const fs::path& deck) { return celldem(dir, "check '" + deck.string() + "'"); }

// `check` of the deck text refuses it with exit code 2 and a message that names `key`.
void expect_refused(const fs::path& dir, const std::string& name, const std::string& deck, const std::string& key) {
  write_bytes(dir / name, deck);
  const Result r = check(dir, dir / name);
  EXPECT_EQ(r.code, 2) << name;
  EXPECT_NE(r.err.find(key), std::string::npos) << name << ": " << r.err;
}

// A deck that tests an existing state file, with the state's sample block.
std::string deck_on_state(const std::string& state_file, int count = 200) {
  std::string d = testing::small_deck_json(count, kTtc);
  const auto at = d.find("\"prepare\"");
  const auto end = d.find("}},", at) + 3;
  return d.replace(at, end - at, "\"initial_state\": \"" + state_file + "\",");
}

// A prepared 200-sphere state in the test's folder (ctest runs each test in its own process, side by side).
fs::path prepared_state(const fs::path& dir) {
  write_bytes(dir / "prep.json", testing::small_deck_json(200, "[]"));
  const Result r = celldem(dir, run_args(dir / "prep.json", dir / "prep"));
  EXPECT_EQ(r.code, 0) << r.err;
  return dir / "prep" / "prepared.state";
}

TEST(Reliability, CheckReadsTheInitialState) {
  const fs::path dir = test_dir("check_state");
  fs::copy_file(prepared_state(dir), dir / "good.state");
  write_bytes(dir / "deck.json", deck_on_state("good.state"));
  Result r = check(dir, dir / "deck.json");
  EXPECT_EQ(r.code, 0) << r.err;

  // Missing, truncated and corrupted state files: exit 2 from check, naming the file.
  write_bytes(dir / "missing.json", deck_on_state("nothing.state"));
  r = check(dir, dir / "missing.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("nothing.state"), std::string::npos) << r.err;

  const std::string bytes = read_bytes(dir / "good.state");
  write_bytes(dir / "cut.state", bytes.substr(0, bytes.size() / 2));
  write_bytes(dir / "cut.json", deck_on_state("cut.state"));
  r = check(dir, dir / "cut.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("cut.state"), std::string::npos) << r.err;

  std::string flipped = bytes;
  flipped[flipped.size() / 2] ^= 0x5a;
  write_bytes(dir / "bad.state", flipped);
  write_bytes(dir / "bad.json", deck_on_state("bad.state"));
  r = check(dir, dir / "bad.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("bad.state"), std::string::npos) << r.err;
}

TEST(Reliability, SampleMustAgreeWithTheInitialState) {
  const fs::path dir = test_dir("state_sample");
  fs::copy_file(prepared_state(dir), dir / "s.state");
  write_bytes(dir / "count.json", deck_on_state("s.state", 8000));
  Result r = check(dir, dir / "count.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("sample.count"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("8000"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("200"), std::string::npos) << r.err;
  r = celldem(dir, run_args(dir / "count.json", dir / "run"));
  EXPECT_EQ(r.code, 2) << "run must refuse what check refuses";
  EXPECT_FALSE(fs::exists(dir / "run"));

  // Larger spheres than the state's (smaller ones would lower the stability limit below the time step).
  expect_refused(dir, "sizes.json", replaced(deck_on_state("s.state"), "\"min\": 3.0e-3", "\"min\": 4.0e-3"),
                 "sample.diameters");
}

TEST(Reliability, SampleTooSmallForItsCellIsRefusedByCheck) {
  const fs::path dir = test_dir("tiny_sample");
  expect_refused(dir, "deck.json", testing::small_deck_json(1, kTtc), "sample.count");
}

TEST(Reliability, TimeStepTooSmallToEverFinishIsRefused) {
  const fs::path dir = test_dir("tiny_step");
  const std::string deck = testing::small_deck_json(200, kTtc);
  expect_refused(dir, "deck.json", replaced(deck, "\"time_step\": 3.0e-6", "\"time_step\": 1e-300"), "time_step");
  // A time step close to the stability limit (3.27e-6 s, the tangential-rotational mode at kt = kn) is warned
  // about by check, as by run; 3e-6 s (0.917 of it) is not.
  write_bytes(dir / "large.json", replaced(deck, "\"time_step\": 3.0e-6", "\"time_step\": 3.1e-6"));
  const Result r = check(dir, dir / "large.json");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: time_step"), std::string::npos) << r.err;
  write_bytes(dir / "fine.json", deck);
  const Result fine = check(dir, dir / "fine.json");
  EXPECT_EQ(fine.code, 0) << fine.err;
  EXPECT_EQ(fine.err.find("warning"), std::string::npos) << fine.err;
}

// kt = 10 kn: the tangential-rotational mode limits the step at sqrt(2m/(7kt)) = 0.169 sqrt(m/kn) = 1.03e-6 s,
// so both 0.9 sqrt(m/kn) (which ran away) and 3e-6 s (which boiled) are refused, naming the mode.
TEST(Reliability, StiffTangentialSpringRefusesTheTimeStep) {
  const fs::path dir = test_dir("stiff_kt");
  const std::string deck = replaced(testing::small_deck_json(200, kTtc), "\"kt\": 1.0e6", "\"kt\": 1.0e7");
  for (const char* dt : {"5.5e-6", "3.0e-6"}) {
    const std::string name = std::string("dt") + dt + ".json";
    expect_refused(dir, name, replaced(deck, "\"time_step\": 3.0e-6", std::string("\"time_step\": ") + dt),
                   "time_step");
    const Result r = check(dir, dir / name);
    EXPECT_NE(r.err.find("tangential-rotational mode: kt = 1e+07 N/m"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("of the stability limit 1.03e-06 s"), std::string::npos) << r.err;
  }
  write_bytes(dir / "ok.json", replaced(deck, "\"time_step\": 3.0e-6", "\"time_step\": 9e-7"));
  EXPECT_EQ(check(dir, dir / "ok.json").code, 0);
}

// kt = kn/10: the normal mode limits the step at sqrt(m/kn) = 6.12e-6 s for the smallest spheres; a packing
// boils from about 0.9 of it (docs/physics.md's sweep; at 0.96 a frictionless preparation held at its pressure
// keeps an unbalanced force ratio near 0.26), so `check` and `run` refuse 0.92 and 0.99 of it with exit 2,
// naming time_step and the bound, and accept 0.88 (test_failure_detection boils such decks past the reader).
TEST(Reliability, TimeStepWherePackingsBoilIsRefused) {
  const fs::path dir = test_dir("boiling_time_step");
  const fs::path here = fs::path(__FILE__).parent_path();
  nlohmann::json deck = nlohmann::json::parse(read_bytes(here / "small_run.json"));
  deck["contact"]["kt"] = 1e5;
  const double normal = std::sqrt(2650.0 * M_PI / 6.0 * 27e-9 / 1e6);
  for (const double f : {0.92, 0.99}) {
    deck["time_step"] = f * normal;
    const std::string name = "boil" + std::to_string(f) + ".json";
    expect_refused(dir, name, deck.dump(), "time_step");
    const Result checked = check(dir, dir / name);
    EXPECT_NE(checked.err.find(" of the normal mode's limit 6.12e-06 s (normal mode: kn = 1e+06 N/m), above 0.9 "
                               "of it: a packing boils"), std::string::npos) << checked.err;
    EXPECT_NE(checked.err.find("use at most 5.45e-06 s"), std::string::npos) << checked.err;
    const Result r = celldem(dir, run_args(dir / name, dir / "run", "--quiet"));
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("time_step"), std::string::npos) << r.err;
  }
  deck["time_step"] = 0.88 * normal;
  write_bytes(dir / "ok.json", deck.dump());
  const Result ok = check(dir, dir / "ok.json");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_EQ(ok.err.find("normal mode's limit"), std::string::npos) << ok.err;
}

TEST(Reliability, ReservedStageNamesAndDuplicateKeysAreErrors) {
  const fs::path dir = test_dir("names");
  const std::string deck = testing::small_deck_json(200, kTtc);
  expect_refused(dir, "prepare.json", replaced(deck, "\"name\": \"ttc\"", "\"name\": \"prepare\""), "tests[0].name");
  expect_refused(dir, "figures.json", replaced(deck, "\"name\": \"ttc\"", "\"name\": \"figures\""), "tests[0].name");
  expect_refused(dir, "twice.json", replaced(deck, "\"count\": 200,", "\"count\": 200, \"count\": 300,"),
                 "sample.count: duplicate key");
}

// --force removes every output of the earlier run (test folders of tests the new deck no longer has
// included); files that are not run outputs stay.
TEST(Reliability, ForceLeavesOnlyTheNewRunsOutputs) {
  const fs::path dir = test_dir("force");
  fs::copy_file(prepared_state(dir), dir / "s.state");
  std::string two = deck_on_state("s.state");
  two = replaced(two, "\"end\": {\"axis\": \"x1\", \"strain\": 0.004}", "\"end\": {\"axis\": \"x1\", \"strain\": 0.0004}");
  const std::string first = replaced(two, "\"name\": \"ttc\"", "\"name\": \"old\"");
  write_bytes(dir / "first.json", first);
  write_bytes(dir / "second.json", two);
  ASSERT_EQ(celldem(dir, run_args(dir / "first.json", dir / "run")).code, 0);
  write_bytes(dir / "run" / "notes.txt", "mine");
  ASSERT_TRUE(fs::exists(dir / "run" / "old" / "series.csv"));
  const Result r = celldem(dir, run_args(dir / "second.json", dir / "run", "--force"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir / "run" / "old"));
  EXPECT_TRUE(fs::exists(dir / "run" / "ttc" / "series.csv"));
  EXPECT_EQ(read_bytes(dir / "run" / "notes.txt"), "mine");
  const auto summary = nlohmann::json::parse(read_bytes(dir / "run" / "summary.json"));
  EXPECT_FALSE(summary["tests"].contains("old"));

  // Resuming a finished run says so and changes nothing.
  const std::string before = read_bytes(dir / "run" / "summary.json");
  const Result again = celldem(dir, run_args(dir / "second.json", dir / "run", "--resume"));
  EXPECT_EQ(again.code, 0) << again.err;
  EXPECT_NE(again.out.find("complete"), std::string::npos) << again.out;
  EXPECT_EQ(read_bytes(dir / "run" / "summary.json"), before);

  // Killed inside its last summary write (after the open or a write of summary.json.tmp): the resume of the
  // complete run removes the temporary it left, as the uninterrupted run has none (found by the file-event visit).
  write_bytes(dir / "run" / "summary.json.tmp", before.substr(0, before.size() / 2));
  write_bytes(dir / "run" / "progress.json.tmp", "");
  const Result stray = celldem(dir, run_args(dir / "second.json", dir / "run", "--resume"));
  EXPECT_EQ(stray.code, 0) << stray.err;
  EXPECT_FALSE(fs::exists(dir / "run" / "summary.json.tmp"));
  EXPECT_FALSE(fs::exists(dir / "run" / "progress.json.tmp"));
  EXPECT_EQ(read_bytes(dir / "run" / "summary.json"), before);
}

}  // namespace
}  // namespace celldem

namespace celldem {
namespace {

// In a log file (stderr not a terminal) a run writes plain progress lines at the chosen interval.
TEST(Reliability, ProgressLinesInALog) {
  const fs::path dir = test_dir("progress_log");
  write_bytes(dir / "deck.json", testing::small_deck_json(200, kTtc));
  const Result r = celldem(dir, run_args(dir / "deck.json", dir / "run", "--progress-interval 0.01"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("[prepare] step "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("[ttc] "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("% "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("steps/s"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("ETA"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << "no terminal control characters in a log";
  const Result quiet = celldem(dir, run_args(dir / "deck.json", dir / "run", "--force --quiet"));
  EXPECT_EQ(quiet.err.find("steps/s"), std::string::npos) << quiet.err;
}

}  // namespace
}  // namespace celldem
