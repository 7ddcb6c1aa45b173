// The one stage runner (run/stage_runner.hpp) and its observers (run/stage_observer.hpp): every hook is called where
// it says, and an observer that ends the stage at a leg's end leaves the stage there, its last row that leg's end.
// No checkpoint is written at a step where a leg ends (a resume there would end with no step and no pair forces).
#include <gtest/gtest.h>
#include <omp.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "helpers.hpp"
#include "io/state_file.hpp"
#include "run/errors.hpp"
#include "run/run_directory.hpp"
#include "run/run_options.hpp"
#include "run/runner.hpp"
#include "run/stage_runner.hpp"
#include "run/time_step_check.hpp"
#include "step.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;

// Counts every hook, and ends the stage at the end of leg `end_at`.
class Recorder : public StageObserver {
 public:
  explicit Recorder(int end_at) : end_at_(end_at) {}
  void on_start(const State&) override { ++starts; }
  void on_resume(const State&, const std::vector<SeriesRow>&) override { ++resumes; }
  void on_row(const State& state, const SeriesRow& row) override {
    ++rows;
    EXPECT_EQ(row.step, static_cast<double>(state.control.stage_steps));
  }
  void on_step(const State&) override { ++steps; }
  bool on_leg_end(const State& state) override {
    leg_ends.push_back(state.control.leg);
    return state.control.leg == end_at_;
  }
  void on_finish(const State&, const std::vector<SeriesRow>& all) override { ++finishes, finished_rows = all.size(); }

  int starts = 0, resumes = 0, rows = 0, steps = 0, finishes = 0;
  std::size_t finished_rows = 0;
  std::vector<int> leg_ends;

 private:
  int end_at_;
};

// A quick preparation (150 spheres, loose equilibrium) in `dir`: its deck, and prepared.state in dir/prep.
Deck prepare_packing(const fs::path& dir, RunOptions& options) {
  std::string deck_text = testing::small_deck_json(150, "[]", 5);
  const std::string loose = R"("equilibrium": {"pressure_tolerance": 0.9, "stress_tolerance": 0.9, "unbalanced_force_ratio": 1.0,
                                 "min_steps": 200, "check_interval": 200, "max_steps": 100000})";
  const auto at = deck_text.find("\"equilibrium\"");
  deck_text.replace(at, deck_text.find('}', at) + 1 - at, loose);
  testing::write_bytes(dir / "deck.json", deck_text);
  const Deck deck = read_deck((dir / "deck.json").string());
  options.out_dir = (dir / "prep").string();
  options.threads = 1;
  options.quiet = true;
  const int saved = omp_get_max_threads();
  run_deck(deck, options);
  omp_set_num_threads(saved);
  return deck;
}

// A hold of the packing's stresses, ending after `steps`.
Leg hold_leg(const State& state, std::int64_t steps) {
  Leg hold;
  hold.end.kind = LegEndKind::Steps;
  hold.end.steps = steps;
  const Vec3 s = state.normal_stress();
  for (int k = 0; k < 3; ++k) hold.axes[static_cast<std::size_t>(k)] = AxisControl{AxisMode::Stress, s[k]};
  return hold;
}

TEST(StageRunner, ObserversSeeEveryHookAndMayEndTheStageAtALegsEnd) {
  testing::TempDir dir;
  RunOptions options;
  const Deck deck = prepare_packing(dir.path(), options);
  options.out_dir = (dir.path() / "run").string();
  RunDirectory run(deck, options);
  State state = read_state((dir.path() / "prep" / "prepared.state").string());
  begin_stage(state);
  const Model model = make_model(deck, state.particles.radius, deck.time_step);
  evaluate_forces(model, Friction{}, state);
  const Leg hold = hold_leg(state, 40);
  Recorder recorder(/*end_at=*/1);
  const StageResult result = run_stage({run, deck, options}, model,
                                       {.name = "hold",
                                        .legs = std::vector<Leg>(3, hold),
                                        .output_interval = 25,
                                        .branch = true,
                                        .adaptive_threads = false,
                                        .progress_line = false},
                                       state, {&recorder});
  EXPECT_EQ(recorder.starts, 1);
  EXPECT_EQ(recorder.resumes, 0);
  EXPECT_EQ(recorder.steps, 80);                        // two legs of 40 steps: the third never ran
  EXPECT_EQ(recorder.leg_ends, (std::vector<int>{0, 1}));  // asked at each leg's end until it ended the stage
  EXPECT_EQ(result.state.control.leg, 1);
  EXPECT_EQ(result.state.control.stage_steps, 80);
  // Rows: the first, step 25, the end of leg 0 (40), 50, 75, the end of leg 1 (80); each seen once.
  EXPECT_EQ(recorder.rows, 6);
  EXPECT_EQ(result.rows.size(), 6u);
  EXPECT_EQ(result.rows.back().step, 80.0);
  EXPECT_EQ(recorder.finishes, 1);
  EXPECT_EQ(recorder.finished_rows, 6u);
  EXPECT_EQ(result.control_errors.size(), 3u);
  EXPECT_TRUE(fs::exists(run.stage_dir("hold") / "series.csv"));
}

// The time step against the contact network (run/time_step_check): run_stage refuses a stage above the refusal margin
// of its starting state's network before it writes anything, runs one above the warning margin with a warning that
// names the margin, and judges the state again every checkpoint_interval steps as the stage goes on.
TEST(StageRunner, TimeStepAboveTheNetworksLimitIsRefusedOrWarned) {
  testing::TempDir dir;
  RunOptions options;
  Deck deck = prepare_packing(dir.path(), options);
  deck.checkpoint_interval = 20;
  State state = read_state((dir.path() / "prep" / "prepared.state").string());
  begin_stage(state);
  const Friction friction{0.5};
  const Model base = make_model(deck, state.particles.radius, deck.time_step);
  evaluate_forces(base, friction, state);
  const double limit = judge_network_time_step(base, state, friction, "x", "time_step").network.limit;
  ASSERT_GT(limit, 0.0);
  const auto judged = [&](double fraction) {
    return judge_network_time_step(make_model(deck, state.particles.radius, fraction * limit), state, friction,
                                   "stage 'hold' as it starts", "tests[0].time_step");
  };
  EXPECT_EQ(judged(0.85).verdict, NetworkStepVerdict::Ok);
  EXPECT_TRUE(judged(0.85).message.empty());
  for (const double f : {0.95, 1.05}) {
    const NetworkStepJudgement j = judged(f);
    EXPECT_EQ(j.verdict, NetworkStepVerdict::Warn) << f;
    EXPECT_NEAR(j.ratio, f, 1e-9);
    for (const char* word : {"stage 'hold' as it starts", "tests[0].time_step", "the margin 0.9", "refused above 1.1"})
      EXPECT_NE(j.message.find(word), std::string::npos) << word << " in " << j.message;
  }
  const NetworkStepJudgement refused = judged(1.2);
  EXPECT_EQ(refused.verdict, NetworkStepVerdict::Refuse);
  EXPECT_NE(refused.message.find("the refusal margin 1.1"), std::string::npos) << refused.message;
  // Without friction the tangential springs hold nothing: the network's limit is the normal springs' alone, longer.
  EXPECT_GT(judge_network_time_step(base, state, Friction{}, "x", "time_step").network.limit, limit);

  options.out_dir = (dir.path() / "run").string();
  RunDirectory run(deck, options);
  const auto spec = [&](const std::string& name) {
    return StageSpec{.name = name,
                     .legs = {hold_leg(state, 40)},
                     .friction = friction,
                     .output_interval = 20,
                     .branch = true,
                     .adaptive_threads = false,
                     .progress_line = false};
  };
  const Model fast = make_model(deck, state.particles.radius, 1.2 * limit);
  try {
    (void)run_stage({run, deck, options}, fast, spec("refused"), state);
    ADD_FAILURE() << "a time step 1.2 times the network's limit ran";
  } catch (const DeckError& e) {
    EXPECT_NE(std::string(e.what()).find("time_step"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(run.stage_dir("refused") / "series.csv"));

  const Model close = make_model(deck, state.particles.radius, 0.95 * limit);
  const StageResult result = run_stage({run, deck, options}, close, spec("warned"), state);
  EXPECT_EQ(result.state.control.stage_steps, 40);
  EXPECT_EQ(result.network_time_step["checks"], 3);  // the start, step 20, step 40
  EXPECT_EQ(result.network_time_step["at_start"]["verdict"], "warn");
  EXPECT_GT(result.network_time_step["largest_time_step_over_limit"].get<double>(), 0.9);
  int warned = 0;
  const nlohmann::json summary = run.summary();  // (a copy: the loop must not run over a temporary's member)
  for (const auto& w : summary["warnings"]) warned += w.get<std::string>().find("the margin 0.9") != std::string::npos;
  EXPECT_EQ(warned, 1);  // once for the margin, not at every check
}

// Records the steps of the checkpoints; keeps a copy of the checkpoint and series as they stand after step `keep_at`
// (what a kill then leaves); raises SIGINT after step `stop_at`.
class CheckpointWatch : public StageObserver {
 public:
  CheckpointWatch(fs::path stage_dir, fs::path keep_dir, std::int64_t keep_at, std::int64_t stop_at = -1)
      : stage_dir_(std::move(stage_dir)), keep_dir_(std::move(keep_dir)), keep_at_(keep_at), stop_at_(stop_at) {}
  void on_checkpoint(const State& state) override { steps.push_back(state.control.stage_steps); }
  void on_step(const State& state) override {
    if (state.control.stage_steps == keep_at_) {
      fs::create_directories(keep_dir_);
      for (const char* f : {"checkpoint.state", "series.csv"}) fs::copy_file(stage_dir_ / f, keep_dir_ / f);
    }
    if (state.control.stage_steps == stop_at_) std::raise(SIGINT);
  }
  std::vector<std::int64_t> steps;

 private:
  fs::path stage_dir_, keep_dir_;
  std::int64_t keep_at_, stop_at_;
};

// The prepared packing of prepare_packing with checkpoints due every 20 steps, its forces evaluated at 0.8 of the
// deck's time step (well inside the network's limit with friction: no warning), and a hold leg of 40 steps.
struct HoldScene {
  Deck deck;
  State state;
  Friction friction{0.5};
  Model model;
  Leg hold;
  HoldScene(const fs::path& dir, RunOptions& options)
      : deck(prepare_packing(dir, options)), state(read_state((dir / "prep" / "prepared.state").string())) {
    deck.checkpoint_interval = 20;
    begin_stage(state);
    model = make_model(deck, state.particles.radius, 0.8 * deck.time_step);
    evaluate_forces(model, friction, state);
    hold = hold_leg(state, 40);
  }
};

// Three hold legs of 40 steps, a checkpoint due every 20 steps and a row every 25: the checkpoints due at the legs'
// ends (40, 80) and at the stage's (120) are not written, so that no resume starts where a leg ends; the steps after
// them rebuild the neighbour list as after a checkpoint. Killed after step 61 (its checkpoint at 60) and resumed, the
// stage ends with the same series and state bytes, the leg-end row at 80 and the last at 120 from steps it took.
TEST(StageRunner, NoCheckpointWhereALegEndsAndAResumeEndsByteIdentical) {
  testing::TempDir dir;
  RunOptions options;
  HoldScene scene(dir.path(), options);
  auto& [deck, state, friction, model, hold] = scene;
  options.out_dir = (dir.path() / "run").string();
  RunDirectory run(deck, options);
  const fs::path stage = run.stage_dir("hold"), kept = dir.path() / "kept";
  const auto spec = [&](bool resumed, const std::string& final_state) {
    return StageSpec{.name = "hold",
                     .legs = std::vector<Leg>(3, hold),
                     .friction = friction,
                     .output_interval = 25,
                     .resumed = resumed,
                     .adaptive_threads = false,
                     .progress_line = false,
                     .final_state = FinalStateFile{(dir.path() / final_state).string(), "test:hold"}};
  };
  CheckpointWatch watch(stage, kept, /*keep_at=*/61);
  const StageResult whole = run_stage({run, deck, options}, model, spec(false, "whole.state"), state, {&watch});
  EXPECT_EQ(whole.state.control.stage_steps, 120);
  EXPECT_EQ(watch.steps, (std::vector<std::int64_t>{20, 60, 100}));
  // Rows: 0, 25, 40 (leg 0's end), 50, 75, 80 (leg 1's end), 100, 120 (the end).
  ASSERT_EQ(whole.rows.size(), 8u);
  const std::string series = testing::read_bytes(stage / "series.csv");

  // The kill after step 61: its checkpoint (step 60) and the series as they stood then.
  for (const char* f : {"checkpoint.state", "series.csv"})
    fs::copy_file(kept / f, stage / f, fs::copy_options::overwrite_existing);
  State at_checkpoint = read_state((stage / "checkpoint.state").string());
  ASSERT_EQ(at_checkpoint.control.stage_steps, 60);
  CheckpointWatch again(stage, dir.path() / "unused", -1);
  const StageResult resumed =
      run_stage({run, deck, options}, model, spec(true, "resumed.state"), std::move(at_checkpoint), {&again});
  EXPECT_EQ(again.steps, (std::vector<std::int64_t>{100}));
  EXPECT_EQ(testing::read_bytes(stage / "series.csv"), series);
  EXPECT_EQ(testing::read_bytes(dir.path() / "resumed.state"), testing::read_bytes(dir.path() / "whole.state"));
}

// A stop requested at a leg's last step waits for the next step: its checkpoint is that step's, inside the next leg.
// One at the stage's last step lets the stage end (its outputs written; the next stage stops at its first step).
// (Each in a child process: the stop request cannot be withdrawn.)
TEST(StageRunner, AStopAtALegsEndCheckpointsTheNextStep) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  testing::TempDir dir;
  RunOptions options;
  HoldScene scene(dir.path(), options);
  auto& [deck, state, friction, model, hold] = scene;
  const auto stopped_at = [&](std::int64_t stop_at) {
    install_stop_handlers();
    options.out_dir = (dir.path() / ("run" + std::to_string(stop_at))).string();
    RunDirectory run(deck, options);
    CheckpointWatch watch(run.stage_dir("hold"), dir.path() / "unused", -1, stop_at);
    try {
      const StageResult r = run_stage({run, deck, options}, model,
                                      {.name = "hold",
                                       .legs = std::vector<Leg>(2, hold),
                                       .friction = friction,
                                       .output_interval = 25,
                                       .adaptive_threads = false,
                                       .progress_line = false},
                                      state, {&watch});
      std::cerr << "ended at step " << r.state.control.stage_steps << ", checkpoints";
    } catch (const Interrupted& e) {
      std::cerr << "interrupted: " << e.what() << "; checkpoint at step "
                << read_state(run.checkpoint("hold").string()).control.stage_steps << ", checkpoints";
    }
    for (const std::int64_t s : watch.steps) std::cerr << " " << s;
    std::error_code ignored;
    fs::remove_all(dir.path(), ignored);  // (exit skips the destructors)
    std::exit(0);
  };
  EXPECT_EXIT(
      stopped_at(40), ::testing::ExitedWithCode(0),
      "interrupted: stopped by a signal in stage 'hold' at step 41;.* checkpoint at step 41, checkpoints 20 41");
  EXPECT_EXIT(stopped_at(80), ::testing::ExitedWithCode(0), "ended at step 80, checkpoints 20 60$");
}

}  // namespace
}  // namespace celldem
