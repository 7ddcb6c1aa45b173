// The celldem command line, end to end, on a tiny deck written into the build tree: prepare + a triaxial
// test, the files and their documented header, refusing to overwrite, deck errors (exit 2, key path on
// stderr), and an interrupted run resumed to the same bytes as an uninterrupted one.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

#include "cli.hpp"
#include "helpers.hpp"
#include "io/state_file.hpp"
#include "measure/series.hpp"

extern char** environ;

namespace celldem {
namespace {

namespace fs = std::filesystem;
using testing::read_bytes;

using testing::celldem;
using testing::kBinary;
using testing::kTtc;
using testing::Result;
using testing::run_args;
using testing::test_dir;

TEST(EndToEnd, PrepareAndTriaxialTestWriteDocumentedFiles) {
  const fs::path dir = test_dir("prepare_ttc");
  const fs::path deck = dir / "deck.json", out = dir / "run";
  testing::write_bytes(deck, testing::small_deck_json(200, kTtc));

  const Result r = celldem(dir, run_args(deck, out));
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"prepared.state", "summary.json", "progress.json", "prepare/series.csv", "ttc/series.csv",
                        "ttc/final.state"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  for (const char* stage : {"prepare", "ttc"}) EXPECT_FALSE(fs::exists(out / stage / "checkpoint.state")) << stage;

  // The series: the documented header, then a row every 100 steps from 0 to 1000.
  const std::string series = read_bytes(out / "ttc" / "series.csv");
  const std::string header = series.substr(0, series.find('\n') + 1);
  EXPECT_EQ(header, series_header());
  EXPECT_EQ(header.rfind("step,time,e1,e2,e3,ev,s11,s22,s33,s12,s13,s23,p,q,ratio13,b,sin_phi,DI,", 0), 0u);
  EXPECT_EQ(std::count(series.begin(), series.end(), '\n'), 1 + 11);
  const std::string last = series.substr(series.rfind('\n', series.size() - 2) + 1);
  EXPECT_EQ(last.rfind("1000,", 0), 0u) << last;

  const auto summary = nlohmann::json::parse(read_bytes(out / "summary.json"));
  EXPECT_NEAR(summary["prepared"]["p"].get<double>(), 1e5, 0.011e5);  // the deck's pressure tolerance
  EXPECT_EQ(summary["tests"]["ttc"]["steps"], 1000);
  EXPECT_NEAR(summary["tests"]["ttc"]["final_e1"].get<double>(), 0.004, 1e-12);
  EXPECT_GT(summary["tests"]["ttc"]["peak_ratio13"].get<double>(), 1.2);
  EXPECT_EQ(read_state((out / "prepared.state").string()).particles.size(), 200u);
  std::string label;
  (void)read_state((out / "ttc" / "final.state").string(), &label);
  EXPECT_EQ(label, "test:ttc");

  // A second run into the same folder without --force fails and leaves every file as it was.
  std::map<std::string, std::pair<std::string, fs::file_time_type>> before;
  for (const auto& e : fs::recursive_directory_iterator(out))
    if (e.is_regular_file()) before[e.path().string()] = {read_bytes(e.path()), e.last_write_time()};
  const Result again = celldem(dir, run_args(deck, out));
  EXPECT_EQ(again.code, 2) << "a usage error, not a run-time failure";
  EXPECT_NE(again.err.find("--force"), std::string::npos) << again.err;
  std::size_t files = 0;
  for (const auto& e : fs::recursive_directory_iterator(out))
    if (e.is_regular_file()) {
      ++files;
      ASSERT_TRUE(before.count(e.path().string())) << "new file " << e.path();
      EXPECT_EQ(read_bytes(e.path()), before[e.path().string()].first) << e.path();
      EXPECT_EQ(e.last_write_time(), before[e.path().string()].second) << e.path();
    }
  EXPECT_EQ(files, before.size());
}

// Asking to resume what cannot be resumed, or to write an ensemble over one, is a usage error (exit 2, as
// "already holds results" is), not a run-time failure (1): nothing ran.
TEST(EndToEnd, ResumeAndEnsembleMisuseExitTwo) {
  const fs::path dir = test_dir("usage_errors");
  const fs::path deck = dir / "deck.json";
  testing::write_bytes(deck, testing::small_deck_json(125, "[]"));
  Result r = celldem(dir, run_args(deck, dir / "nothing", "--resume"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("holds no interrupted run to resume"), std::string::npos) << r.err;

  ASSERT_EQ(celldem(dir, run_args(deck, dir / "run", "--quiet")).code, 0);
  std::string other = testing::small_deck_json(125, "[]");
  other.replace(other.find("\"seed\": 3"), 9, "\"seed\": 4");
  testing::write_bytes(dir / "other.json", other);
  r = celldem(dir, run_args(dir / "other.json", dir / "run", "--resume"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--resume: the deck differs"), std::string::npos) << r.err;

  ASSERT_EQ(celldem(dir, run_args(deck, dir / "ensemble", "--quiet --seeds 1,2")).code, 0);
  r = celldem(dir, run_args(deck, dir / "ensemble", "--quiet --seeds 1,2"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("already holds an ensemble"), std::string::npos) << r.err;
}

TEST(EndToEnd, DeckErrorExitsTwoNamingTheKey) {
  const fs::path dir = test_dir("deck_error");
  std::string text = testing::small_deck_json(200, kTtc);
  text.replace(text.find("\"kn\": 1.0e6"), 11, "\"kn\": -1.0e6");
  testing::write_bytes(dir / "bad.json", text);
  Result r = celldem(dir, run_args(dir / "bad.json", dir / "run"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("contact.kn"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "run" / "summary.json"));
  r = celldem(dir, "check '" + (dir / "bad.json").string() + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("contact.kn"), std::string::npos) << r.err;

  text = testing::small_deck_json(200, kTtc);
  text.replace(text.find("\"friction\": 0.5"), 15, "\"friction\": 0.5, \"mu\": 0.5");
  testing::write_bytes(dir / "unknown.json", text);
  r = celldem(dir, "check '" + (dir / "unknown.json").string() + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("tests[0].mu"), std::string::npos) << r.err;

  testing::write_bytes(dir / "good.json", testing::small_deck_json(200, kTtc));
  r = celldem(dir, "check '" + (dir / "good.json").string() + "'");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("valid"), std::string::npos) << r.out;
  // What it costs: 200 spheres at 400 bytes, the preparation's range and the test's 1000 steps.
  EXPECT_NE(r.out.find("estimate: about 0.08 MB of memory;"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("preparation steps and 1000 test steps"), std::string::npos) << r.out;
  // What the servo can follow, before any work: the tightest leg's cap against its driving increment.
  EXPECT_NE(r.out.find("servo: 1 leg(s) with a servo beside a driven axis; the tightest cap is 10 x its driving"),
            std::string::npos) << r.out;

  // A snapshot beyond the test's end (e1 = 0.004) would never be written: check says so, naming the strain.
  text = testing::small_deck_json(200, kTtc);
  const std::string interval = "\"output_interval\": 100";
  text.replace(text.find(interval), interval.size(), interval + ", \"snapshots\": {\"e1\": [0.002, 0.05]}");
  testing::write_bytes(dir / "snapshots.json", text);
  r = celldem(dir, "check '" + (dir / "snapshots.json").string() + "'");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("tests[0].snapshots.e1: 0.05 lies beyond"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("0.002 lies"), std::string::npos) << r.err;
}

// A graded deck prepares; summary.json's grading is the prepared state's realised curve, the one `celldem plan`
// reports for the seed's draw; the translator, which types spheres by listed size, refuses it naming the key.
TEST(EndToEnd, GradedSamplePreparesAndReportsItsCurve) {
  const fs::path dir = test_dir("graded");
  std::string text = testing::small_deck_json(216, "[]");
  const std::string listed = R"("diameters": {"min": 3.0e-3, "max": 4.5e-3, "count": 4})";
  text.replace(text.find(listed), listed.size(),
               R"("diameters": {"grading": {"by": "mass", "sizes": [3.0e-3, 3.6e-3, 4.5e-3], "passing": [0, 30, 100]}})");
  const fs::path deck = dir / "deck.json", out = dir / "run";
  testing::write_bytes(deck, text);
  const Result plan = celldem(dir, "plan '" + deck.string() + "' --json");
  ASSERT_EQ(plan.code, 0) << plan.err;
  const auto planned = nlohmann::json::parse(plan.out)["sample"]["grading"];
  const Result r = celldem(dir, run_args(deck, out));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto grading = nlohmann::json::parse(read_bytes(out / "summary.json"))["grading"];
  ASSERT_TRUE(grading.is_object()) << grading;
  EXPECT_EQ(grading["by"], "mass");
  EXPECT_EQ(grading["asked_percent"], nlohmann::json::array({0, 30, 100}));
  EXPECT_EQ(grading["spheres"], 216);
  // The curve of the spheres the prepared state holds (their sizes do not change), counted here.
  const State prepared = read_state((out / "prepared.state").string());
  const std::vector<double> sieves = {3.0e-3, 3.6e-3, 4.5e-3};
  double total = 0.0;
  std::vector<double> below(3, 0.0);
  for (double radius : prepared.particles.radius) {
    const double d = 2.0 * radius, m = d * d * d;
    total += m;
    for (int k = 0; k < 3; ++k)
      if (d <= sieves[k]) below[k] += m;
  }
  double worst = 0.0;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(grading["realised_percent"][k].get<double>(), 100.0 * below[k] / total, 1e-9) << k;
    worst = std::max(worst, std::abs(100.0 * below[k] / total - grading["asked_percent"][k].get<double>()));
  }
  EXPECT_NEAR(grading["largest_deviation_percent"].get<double>(), worst, 1e-9);
  EXPECT_EQ(planned, grading);
  const Result text_plan = celldem(dir, "plan '" + deck.string() + "'");
  EXPECT_NE(text_plan.out.find("grading by mass"), std::string::npos) << text_plan.out;
  EXPECT_NE(text_plan.out.find("largest deviation"), std::string::npos) << text_plan.out;
  const Result translated = celldem(dir, "translate '" + deck.string() + "' --to lammps --out '" + (dir / "lmp").string() + "'");
  EXPECT_EQ(translated.code, 2);
  EXPECT_NE(translated.err.find("sample.diameters.grading"), std::string::npos) << translated.err;
}

// Interrupted by SIGINT part-way (during the preparation or the test, whichever it happens to be), then
// resumed: the series and states are byte-identical to an uninterrupted run's.
// Runs the deck, then the same run stopped at about 40 % of its wall time and resumed: the same bytes.
void expect_resume_to_same_bytes(const std::string& name, const std::string& text,
                                 const std::vector<std::string>& files = {"prepared.state", "prepare/series.csv",
                                                                          "ttc/series.csv", "ttc/final.state"},
                                 const fs::path& in = {}) {
  const fs::path dir = in.empty() ? test_dir(name) : in;
  const fs::path deck = dir / "deck.json";
  testing::write_bytes(deck, text);

  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(celldem(dir, run_args(deck, dir / "ref")).code, 0);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Start the same run and stop it at about 40 % of the reference's wall time.
  const fs::path out = dir / "cut";
  const std::string deck_s = deck.string(), out_s = out.string();
  std::vector<std::string> args = {kBinary, "run", deck_s, "--out", out_s, "--threads", "1", "--quiet"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid;
  ASSERT_EQ(posix_spawn(&pid, kBinary, nullptr, nullptr, argv.data(), environ), 0);
  std::this_thread::sleep_for(std::chrono::duration<double>(0.4 * wall));
  kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  const int code = WEXITSTATUS(status);
  EXPECT_TRUE(code == 130 || code == 0) << code;  // 0 if it finished before the signal
  if (code == 130) {
    EXPECT_TRUE(fs::exists(out / "prepare" / "checkpoint.state") || fs::exists(out / "ttc" / "checkpoint.state"));
    const Result r = celldem(dir, run_args(deck, out, "--resume"));
    ASSERT_EQ(r.code, 0) << r.err;
  } else {
    GTEST_LOG_(INFO) << "the run finished before the signal: resume not exercised";
  }
  for (const std::string& f : files) EXPECT_EQ(read_bytes(out / f), read_bytes(dir / "ref" / f)) << f;
  for (const char* stage : {"prepare", "ttc"}) EXPECT_FALSE(fs::exists(out / stage / "checkpoint.state")) << stage;
}

std::string checkpointed_deck() {
  std::string text = testing::small_deck_json(200, kTtc);
  text.replace(text.find("\"time_step\""), 0, "\"checkpoint_interval\": 700,\n  ");
  return text;
}

TEST(EndToEnd, InterruptedRunResumesToSameBytes) { expect_resume_to_same_bytes("resume", checkpointed_deck()); }

// Stages with their own time steps (the test continuing a state prepared at another one) resume exactly too.
TEST(EndToEnd, InterruptedRunWithStageTimeStepsResumesToSameBytes) {
  std::string text = checkpointed_deck();
  text.replace(text.find("\"target_pressure\""), 0, "\"time_step\": 2.0e-6, ");
  text.replace(text.find("\"friction\": 0.5"), 0, "\"time_step\": 2.5e-6, ");
  expect_resume_to_same_bytes("resume_stage_time_steps", text);
}

// An adaptive leg (tests[].adaptive_rate) resumes exactly too: its factor and progress are in the checkpoint
// (state format 6). The test starts from a prepared state, so that the signal falls in the adaptive leg.
TEST(EndToEnd, InterruptedAdaptiveLegResumesToSameBytes) {
  const fs::path dir = test_dir("resume_adaptive");
  testing::write_bytes(dir / "prep.json", testing::small_deck_json(200, "[]"));
  ASSERT_EQ(celldem(dir, run_args(dir / "prep.json", dir / "prep")).code, 0);
  std::string text = testing::small_deck_json(200, R"([{"name": "ttc", "friction": 0.5,
    "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
    "adaptive_rate": {"max_factor": 3, "unbalanced_force_ratio": 0.004, "check_interval": 50},
    "end": {"axis": "x1", "strain": 0.02}, "output_interval": 100}])");
  text.replace(text.find("\"time_step\""), 0, "\"checkpoint_interval\": 700,\n  ");
  const auto at = text.find("\"prepare\"");
  text.replace(at, text.find("}},", at) + 3 - at, "\"initial_state\": \"prep/prepared.state\",");
  expect_resume_to_same_bytes("resume_adaptive", text, {"ttc/series.csv", "ttc/final.state"}, dir);
  // The factor moved (else this is a fixed-rate resume).
  double low = 1.0, high = 1.0;
  for (const SeriesRow& r : testing::read_series(dir / "ref" / "ttc" / "series.csv"))
    low = std::min(low, r.rate_factor), high = std::max(high, r.rate_factor);
  EXPECT_LT(low, high);
}

// --tolerance: the run records the tolerance and each stage's resolved settings, writes the deck it ran,
// which runs again as written to the same bytes, and refuses to resume at another tolerance.
TEST(EndToEnd, ToleranceRunRecordsItsDeckWhichRunsAgainAsWritten) {
  const fs::path dir = test_dir("tolerance");
  const fs::path deck = dir / "deck.json", out = dir / "run";
  std::string text = testing::small_deck_json(150, kTtc);
  const std::string written_step = "\"time_step\": 3.0e-6";
  text.replace(text.find(written_step), written_step.size(), "\"time_step\": 1.0e-6");
  testing::write_bytes(deck, text);
  Result r = celldem(dir, run_args(deck, out, "--quiet --tolerance 3"));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto summary = nlohmann::json::parse(read_bytes(out / "summary.json"));
  const auto& settings = summary["settings"];
  EXPECT_EQ(settings["tolerance"], 3.0);
  ASSERT_EQ(settings["resolved"]["stages"].size(), 2u);
  const double dt = settings["resolved"]["stages"][1]["time_step"].get<double>();
  EXPECT_EQ(settings["stage_time_steps"]["ttc"].get<double>(), dt);
  EXPECT_GT(dt, 2.0 * 1.0e-6);  // the rules' fraction of the limit, not the deck's 0.3 of it
  EXPECT_EQ(settings["stage_time_steps"]["prepare"].get<double>(), settings["resolved"]["stages"][0]["time_step"].get<double>());
  // The resolved deck, run as written: the same bytes.
  ASSERT_TRUE(fs::exists(out / "resolved_deck.json"));
  r = celldem(dir, run_args(out / "resolved_deck.json", dir / "again", "--quiet"));
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* f : {"prepared.state", "prepare/series.csv", "ttc/series.csv", "ttc/final.state"})
    EXPECT_EQ(read_bytes(dir / "again" / f), read_bytes(out / f)) << f;
  // Resuming at another tolerance, or none, is refused before anything runs.
  r = celldem(dir, run_args(deck, out, "--quiet --resume --tolerance 2"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("started with --tolerance 3 and is resumed with --tolerance 2"), std::string::npos) << r.err;
  r = celldem(dir, run_args(deck, out, "--quiet --resume"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("and is resumed without --tolerance"), std::string::npos) << r.err;
  // plan --tolerance --json: each stage's particle-steps against the deck as written, as the two plans count them.
  r = celldem(dir, "plan '" + deck.string() + "' --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto written_plan = nlohmann::json::parse(r.out);
  EXPECT_FALSE(written_plan.contains("tolerance"));
  r = celldem(dir, "plan '" + deck.string() + "' --json --tolerance 3");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto plan = nlohmann::json::parse(r.out);
  const auto& ttc = plan["tolerance"]["stages"][1];
  EXPECT_EQ(ttc["stage"], "ttc");
  EXPECT_EQ(ttc["particle_steps"]["low"].get<double>(), 150.0 * plan["tests"][0]["steps"].get<double>());
  EXPECT_EQ(ttc["particle_steps_written"]["low"].get<double>(), 150.0 * written_plan["tests"][0]["steps"].get<double>());
  EXPECT_DOUBLE_EQ(ttc["ratio_low"].get<double>(),
                   written_plan["tests"][0]["steps"].get<double>() / plan["tests"][0]["steps"].get<double>());
  EXPECT_EQ(plan["tests"][0]["time_step"].get<double>(), dt);
  // Not a positive number of floors: a deck error naming the flag.
  r = celldem(dir, run_args(deck, dir / "outside", "--quiet --tolerance 0"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--tolerance"), std::string::npos) << r.err;
}

// `plan --tolerance T` says how far the deck as written is from I -> 0 and what T costs; its JSON holds the same,
// with the promise in words (a mean over seeds, and what one run adds).
TEST(EndToEnd, TolerancePlanSaysHowFarTheDeckIsFromTheQuasiStaticAnswer) {
  const fs::path dir = test_dir("tolerance_distance");
  const fs::path deck = dir / "deck.json";
  testing::write_bytes(deck, testing::small_deck_json(150, kTtc));
  Result r = celldem(dir, "plan '" + deck.string() + "' --tolerance 1");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("tolerance 1 noise floors from I -> 0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("strain-driven legs at actual inertial number"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ttc as written: I "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("floors from I -> 0; "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("promise: the mean over seeds"), std::string::npos) << r.out;
  r = celldem(dir, "plan '" + deck.string() + "' --json --tolerance 1");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto rate = nlohmann::json::parse(r.out)["tolerance"]["rate"];
  EXPECT_GT(rate["inertial_number"].get<double>(), 0.0);
  ASSERT_EQ(rate["written"].size(), 1u);
  EXPECT_EQ(rate["written"][0]["slowed"].get<bool>(),
            rate["written"][0]["inertial_number"].get<double>() > rate["inertial_number"].get<double>());
  EXPECT_NE(rate["promise"].get<std::string>().find("one run adds"), std::string::npos);
}

}  // namespace
}  // namespace celldem
