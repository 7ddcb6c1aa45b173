// Hostile input and misuse, through the binary: `check` refuses what `run` would refuse or mis-run (bad
// state files, a sample that contradicts its state, a cell too small, a time step so small the run cannot
// end), reserved and duplicate names, exit codes, --force leaving only the new run, --resume on a finished
// run. (Write failures: test_write_failure.sh.)
#include <gtest/gtest.h>

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

// A deck that tests an existing state file, with the state's sample block.
std::string deck_on_state(const std::string& state_file, int count = 200) {
  std::string d = testing::small_deck_json(count, kTtc);
  const auto at = d.find("\"prepare\"");
  const auto end = d.find("}},", at) + 3;
  return d.replace(at, end - at, "\"initial_state\": \"" + state_file + "\",");
}

// One prepared 200-sphere state shared by the tests below.
fs::path prepared_state() {
  static const fs::path state = [] {
    const fs::path dir = test_dir("reliability_prepared");
    write_bytes(dir / "deck.json", testing::small_deck_json(200, "[]"));
    const Result r = celldem(dir, run_args(dir / "deck.json", dir / "run"));
    EXPECT_EQ(r.code, 0) << r.err;
    return dir / "run" / "prepared.state";
  }();
  return state;
}

TEST(Reliability, CheckReadsTheInitialState) {
  const fs::path dir = test_dir("check_state");
  fs::copy_file(prepared_state(), dir / "good.state");
  write_bytes(dir / "deck.json", deck_on_state("good.state"));
  Result r = check(dir, dir / "deck.json");
  EXPECT_EQ(r.code, 0) << r.err;

  // Missing, truncated and corrupted state files: exit 2 from check, naming the file.
  write_bytes(dir / "missing.json", deck_on_state("nothing.state"));
  r = check(dir, dir / "missing.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("nothing.state"), std::string::npos) << r.err;

  const std::string bytes = read_bytes(prepared_state());
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
  fs::copy_file(prepared_state(), dir / "s.state");
  write_bytes(dir / "count.json", deck_on_state("s.state", 8000));
  Result r = check(dir, dir / "count.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("sample.count"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("8000"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("200"), std::string::npos) << r.err;
  r = celldem(dir, run_args(dir / "count.json", dir / "run"));
  EXPECT_EQ(r.code, 2) << "run must refuse what check refuses";
  EXPECT_FALSE(fs::exists(dir / "run"));

  write_bytes(dir / "sizes.json", replaced(deck_on_state("s.state"), "\"min\": 3.0e-3", "\"min\": 2.0e-3"));
  r = check(dir, dir / "sizes.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("sample.diameters"), std::string::npos) << r.err;
}

TEST(Reliability, SampleTooSmallForItsCellIsRefusedByCheck) {
  const fs::path dir = test_dir("tiny_sample");
  write_bytes(dir / "deck.json", testing::small_deck_json(1, kTtc));
  const Result r = check(dir, dir / "deck.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("sample.count"), std::string::npos) << r.err;
}

TEST(Reliability, TimeStepTooSmallToEverFinishIsRefused) {
  const fs::path dir = test_dir("tiny_step");
  write_bytes(dir / "deck.json", replaced(testing::small_deck_json(200, kTtc), "\"time_step\": 3.0e-6",
                                          "\"time_step\": 1e-300"));
  Result r = check(dir, dir / "deck.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("time_step"), std::string::npos) << r.err;
  // A time step above half the stability limit is warned about by check, as by run.
  write_bytes(dir / "large.json", replaced(testing::small_deck_json(200, kTtc), "\"time_step\": 3.0e-6",
                                           "\"time_step\": 4.0e-6"));
  r = check(dir, dir / "large.json");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: time_step"), std::string::npos) << r.err;
}

TEST(Reliability, ReservedStageNamesAndDuplicateKeysAreErrors) {
  const fs::path dir = test_dir("names");
  write_bytes(dir / "prepare.json", replaced(testing::small_deck_json(200, kTtc), "\"name\": \"ttc\"",
                                             "\"name\": \"prepare\""));
  Result r = check(dir, dir / "prepare.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("tests[0].name"), std::string::npos) << r.err;

  write_bytes(dir / "twice.json",
              replaced(testing::small_deck_json(200, kTtc), "\"count\": 200,", "\"count\": 200, \"count\": 300,"));
  r = check(dir, dir / "twice.json");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("sample.count: duplicate key"), std::string::npos) << r.err;
}

// --force removes every output of the earlier run (test folders of tests the new deck no longer has
// included); files that are not run outputs stay.
TEST(Reliability, ForceLeavesOnlyTheNewRunsOutputs) {
  const fs::path dir = test_dir("force");
  fs::copy_file(prepared_state(), dir / "s.state");
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
}

}  // namespace
}  // namespace celldem
