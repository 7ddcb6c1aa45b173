// The one stage runner (run/stage_runner.hpp) and its observers (run/stage_observer.hpp): every hook is called where
// it says, and an observer that ends the stage at a leg's end leaves the stage there, its last row that leg's end.
#include <gtest/gtest.h>
#include <omp.h>

#include <filesystem>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "helpers.hpp"
#include "io/state_file.hpp"
#include "run/run_directory.hpp"
#include "run/run_options.hpp"
#include "run/runner.hpp"
#include "run/stage_runner.hpp"
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

TEST(StageRunner, ObserversSeeEveryHookAndMayEndTheStageAtALegsEnd) {
  testing::TempDir dir;
  // A quick preparation gives a packed state to hold.
  std::string deck_text = testing::small_deck_json(150, "[]", 5);
  const std::string loose = R"("equilibrium": {"pressure_tolerance": 0.9, "stress_tolerance": 0.9, "unbalanced_force_ratio": 1.0,
                                 "min_steps": 200, "check_interval": 200, "max_steps": 100000})";
  const auto at = deck_text.find("\"equilibrium\"");
  deck_text.replace(at, deck_text.find('}', at) + 1 - at, loose);
  testing::write_bytes(dir.path() / "deck.json", deck_text);
  const Deck deck = read_deck((dir.path() / "deck.json").string());
  RunOptions options;
  options.out_dir = (dir.path() / "prep").string();
  options.threads = 1;
  options.quiet = true;
  const int saved = omp_get_max_threads();
  run_deck(deck, options);
  omp_set_num_threads(saved);

  options.out_dir = (dir.path() / "run").string();
  RunDirectory run(deck, options);
  State state = read_state((dir.path() / "prep" / "prepared.state").string());
  begin_stage(state);
  const Model model = make_model(deck, state.particles.radius, deck.time_step);
  evaluate_forces(model, Friction{}, state);
  Leg hold;
  hold.end.kind = LegEndKind::Steps;
  hold.end.steps = 40;
  const Vec3 s = state.normal_stress();
  for (int k = 0; k < 3; ++k) hold.axes[static_cast<std::size_t>(k)] = AxisControl{AxisMode::Stress, s[k]};
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

}  // namespace
}  // namespace celldem
