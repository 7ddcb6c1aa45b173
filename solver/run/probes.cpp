#include "run/probes.hpp"
#include "run/probe_files.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <tuple>

#include <Eigen/Dense>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "io/files.hpp"
#include "measure/network_stiffness.hpp"
#include "neighbor/neighbor_list.hpp"
#include "io/series_file.hpp"
#include "io/state_file.hpp"
#include "run/preflight.hpp"
#include "run/program.hpp"
#include "run/progress.hpp"
#include "run/run_directory.hpp"
#include "run/errors.hpp"
#include "run/stage_runner.hpp"
#include "step.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;
using namespace probe_files;

namespace {

// One run of the probe set's work at a point: its rest, a probe of its elastic check (stress sets) or a probe.
enum class JobKind { Rest, Elastic, Probe };
struct Job {
  std::size_t point;
  ProbeDirection probe;
  JobKind kind = JobKind::Probe;
};

// The model a point's probes run under, from the point's state: the servo keeps the cap of the test's leg at the
// point, so that a probe's stress axes follow a sample that moves at the test's rate when the probe starts (the
// probe's own legs, driven by nothing, would get the smallest cap). The state's forces are computed: the same start
// whether the point was taken in this process or read back (a state file holds no forces or neighbour list).
Model probe_model(const Deck& deck, const TestDef& test, State& state) {
  Model model = make_model(deck, state.particles.radius, deck.stage_time_step(test));
  model.servo.max_strain_increment =
      servo_cap(deck.stage_servo(test), test.legs[static_cast<std::size_t>(state.control.leg)], model.dt);
  model.servo.max_strain_increment_given = true;
  evaluate_forces(model, test.stage_friction(), state);
  return model;
}

// The elastic check of a stress set: the six strain probes of target_strain from the same rested state.
ProbeDef elastic_check_def(const ProbeDef& def) {
  ProbeDef e = def;
  e.kind = ProbeKind::Strain;
  e.magnitudes = {def.target_strain};
  e.scaled = false;
  return e;
}

// Runs one probe of `def` from the state in `state_file` into the stage folder `stage` (its series.csv and
// result.json).
void run_probe(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
               const ProbeDef& def, const fs::path& state_file, const std::string& stage, const ProbeDirection& probe) {
  bool ran = false, controlled = true;
  std::string error;
  std::int64_t steps = 0;
  Json control_errors = Json::array();
  State state = read_state(state_file.string());
  const Model model = probe_model(deck, test, state);
  const std::vector<Leg> legs = probe_legs(def, probe, state.normal_stress(), model.dt);
  begin_leg(state, 0);
  const std::int64_t from_step = state.control.stage_steps;
  const std::int64_t total = 2 * (def.steps + def.hold_steps);
  const std::int64_t interval = std::max<std::int64_t>(1, def.steps / 10);
  // A folder a stopped run left (half-written, or whole) is run again: its old result goes first, so that a stop
  // now never leaves it beside a new, partial series.
  fs::remove(run.stage_dir(stage) / kProbeResultName);
  try {
    const StageResult result = run_stage(
        {run, deck, options}, model,
        {.name = stage,
         .legs = legs,
         .friction = test.stage_friction(),
         .equilibrium = &test.equilibrium,
         .planned_steps = from_step + total,
         .output_interval = interval,
         .branch = true,
         .adaptive_threads = false,
         .progress_line = false,  // one line for the whole set (run_test_probes)
         .control_failure = ControlFailure::Warn,  // recorded with the probe, not a stop of the run
         .print_control_warnings = false},
        std::move(state));
    ran = true;
    for (const ControlErrors& e : result.control_errors) {
      controlled &= std::none_of(e.failed.begin(), e.failed.end(), [](bool f) { return f; });
      control_errors.push_back(to_json(e));
    }
    steps = result.state.control.stage_steps - from_step;
  } catch (const RunError& e) {
    error = e.what();
  }
  // What the table needs besides the series: whether the probe ran, held its controls (each leg's errors, as a
  // test's summary holds them), or failed and why.
  const fs::path dir = run.stage_dir(stage);
  fs::create_directories(dir);
  write_file_atomic(dir / kProbeResultName, Json{{"ran", ran}, {"controlled", controlled}, {"error", error},
                                                 {"steps", steps}, {"control_errors", control_errors}}.dump(1));
}

// A point's rest, window by window (one leg each): the strain crept in each, and the rest ended at its goal or when
// the creep grows from window to window (twice running), which does not lead to rest: a state at its limit.
class RestWindows : public StageObserver {
 public:
  RestWindows(double goal, std::int64_t from_step) : goal_(goal), last_step_(from_step) {}
  void on_start(const State& state) override { before_ = component_strains(state); }
  // (the steps a rest that failed took: up to its last step's row)
  void on_row(const State& state, const SeriesRow&) override { last_step_ = state.control.stage_steps; }
  void on_step(const State& state) override { last_step_ = state.control.stage_steps; }
  bool on_leg_end(const State& state) override {
    const Vec6 now = component_strains(state);
    const double crept = (now - before_).norm();
    before_ = now;
    creep_.push_back(crept);
    if (crept < goal_) return reached_ = true;
    const std::size_t n = creep_.size();
    if (n >= 3 && crept > creep_[n - 2].get<double>() && creep_[n - 2].get<double>() > creep_[n - 3].get<double>()) {
      gave_up_ = "the creep grew in two windows running: the state flows at its stresses";
      return true;
    }
    return false;
  }
  bool reached() const { return reached_; }
  const Json& creep() const { return creep_; }
  const std::string& gave_up() const { return gave_up_; }
  std::int64_t last_step() const { return last_step_; }

 private:
  double goal_;
  std::int64_t last_step_;
  Vec6 before_ = Vec6::Zero();
  Json creep_ = Json::array();
  bool reached_ = false;
  std::string gave_up_;
};

// The point's rest before its probes (run/probes.hpp): from point.state, the normal stresses held at the point's
// and the tilts held, in windows of one probe's steps, until the strain crept in a window is below rest_fraction x
// target_strain or the budget (rest_max_steps) is spent. Writes <point>/rest/series.csv, its result.json (reached,
// the creep of each window) and rested.state, the state the point's probes start from.
void rest_point(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                const ProbePoints::Point& point) {
  const ProbeDef& def = *test.probes;
  const fs::path point_dir = run.stage_dir(test.name) / "probes" / point.name;
  const std::string stage = test.name + "/probes/" + point.name + "/" + kRestName;
  fs::remove(run.stage_dir(stage) / kProbeResultName);
  State state = read_state((point_dir / "point.state").string());
  const int point_leg = state.control.leg;
  const Model model = probe_model(deck, test, state);
  const std::int64_t window = 2 * (def.steps + def.hold_steps);
  const std::int64_t windows = (def.rest_max_steps + window - 1) / window;
  const double goal = def.rest_fraction * def.target_strain;
  bool controlled = true;
  std::string error;
  const std::int64_t from_step = state.control.stage_steps;
  RestWindows rest(goal, from_step);
  if (windows > 0) {
    Leg hold;
    hold.end.kind = LegEndKind::Steps;
    hold.end.steps = window;
    const Vec3 s = state.normal_stress();
    for (int k = 0; k < 3; ++k) hold.axes[static_cast<std::size_t>(k)] = AxisControl{AxisMode::Stress, s[k]};
    try {
      StageResult result = run_stage(
          {run, deck, options}, model,
          {.name = stage,
           .legs = std::vector<Leg>(static_cast<std::size_t>(windows), hold),  // a window a leg: it ends at its goal
           .friction = test.stage_friction(),
           .equilibrium = &test.equilibrium,
           .planned_steps = from_step + windows * window,
           .output_interval = std::max<std::int64_t>(1, window / 4),
           .branch = true,
           .adaptive_threads = false,
           .progress_line = false,
           .control_failure = ControlFailure::Warn,
           .print_control_warnings = false,
           .restart_legs = true},  // its first row: the point as the test took it
          state, {&rest});
      for (const ControlErrors& e : result.control_errors)
        controlled &= std::none_of(e.failed.begin(), e.failed.end(), [](bool f) { return f; });
      state = std::move(result.state);
    } catch (const RunError& e) {
      error = e.what();
    }
  }
  const bool reached = rest.reached();
  const Json& creep = rest.creep();
  const std::string& gave_up = rest.gave_up();
  const std::int64_t rested_steps = rest.last_step() - from_step;
  // A rest that did not reach its goal leaves the point as the test took it: probed as it stands, its drift judged.
  if (!reached) state = read_state((point_dir / "point.state").string());
  state.control.leg = point_leg;  // the probes' servo cap is the test's leg's at the point (probe_model)
  fs::create_directories(run.stage_dir(stage));
  write_state((run.stage_dir(stage) / kRestedStateName).string(), state,
              "probe point " + test.name + "/" + point.name + " at rest", state_physics(deck));
  write_file_atomic(run.stage_dir(stage) / kProbeResultName,
                    Json{{"reached", reached}, {"steps", rested_steps},
                         {"window_steps", window}, {"goal", goal}, {"creep", creep}, {"controlled", controlled},
                         {"gave_up", gave_up}, {"probed_from", reached ? "rest" : "point"},
                         {"error", error}}.dump(1));
}

}  // namespace

Json run_test_probes(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                     const ProbePoints& probe_points, bool peak_reached, const std::string& peak_evidence) {
  const ProbeDef& def = *test.probes;
  const std::vector<ProbePoints::Point> points = probe_points.points(peak_reached, peak_evidence);
  const std::vector<ProbeDirection> directions = probe_directions(def);
  const fs::path probes_dir = run.stage_dir(test.name) / "probes";
  // Each point's record and state, for the table (here or after a merge) and for probes run again elsewhere.
  for (const ProbePoints::Point& point : points) {
    const fs::path dir = probes_dir / point.name;
    fs::create_directories(dir);
    if (point.state)
      write_state((dir / "point.state").string(), *point.state, "probe point " + test.name + "/" + point.name,
                  state_physics(deck));
    write_file_atomic(dir / kPointRecordName,
                      Json{{"step", point.row.step}, {"e1", point.row.e1}, {"reached", point.state != nullptr},
                           {"reason", point.missing}}.dump(1));
  }
  // The probes this run runs: those of options.probes by their number (1-based over the deck's tests, then every
  // point of the set, reference excluded, in probes.csv's order: probe_number_offset), with their points' rests,
  // elastic checks and references.
  std::vector<std::vector<Job>> chosen(points.size());
  const std::int64_t per_point = static_cast<std::int64_t>(directions.size()) - 1;
  const std::int64_t offset = probe_number_offset(deck, test);  // one numbering over the deck's tests
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (!points[p].state) continue;
    for (std::size_t k = 1; k < directions.size(); ++k) {
      const std::int64_t number = offset + static_cast<std::int64_t>(p) * per_point + static_cast<std::int64_t>(k);
      if (number >= options.probes.first && number <= options.probes.last) chosen[p].push_back({p, directions[k]});
    }
    if (!chosen[p].empty()) chosen[p].insert(chosen[p].begin(), Job{p, directions[0]});
  }
  const ProbeDef check = elastic_check_def(def);
  const std::vector<ProbeDirection> check_directions = probe_directions(check);
  // Three rounds, each side by side over the test's threads, one job on one thread (its result does not depend on
  // the count): the points' rests, then the stress sets' elastic checks (which scale the stress probes), then the
  // probes.
  std::vector<Job> rests, checks, probes;
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (chosen[p].empty()) continue;
    rests.push_back({p, directions[0], JobKind::Rest});
    if (def.kind == ProbeKind::Stress)
      for (const ProbeDirection& d : check_directions) checks.push_back({p, d, JobKind::Elastic});
  }
  const std::int64_t steps_each = 2 * (def.steps + def.hold_steps);
  const std::int64_t all_steps = static_cast<std::int64_t>(rests.size()) * def.rest_max_steps +
      steps_each * static_cast<std::int64_t>(checks.size() + [&] {
        std::size_t n = 0;
        for (const auto& c : chosen) n += c.size();
        return n;
      }());
  std::atomic<std::int64_t> steps_done{0};
  std::mutex progress_mutex;
  Progress progress(test.name + " probes", options.progress, options.progress_interval);
  const auto run_jobs = [&](const std::vector<Job>& jobs) {
    const int workers = std::max(1, std::min<int>(omp_get_max_threads(), static_cast<int>(jobs.size())));
    std::atomic<std::size_t> next{0};
    std::vector<std::exception_ptr> errors(static_cast<std::size_t>(workers));
    const auto work = [&](int w) {
      omp_set_num_threads(1);
      try {
        for (std::size_t j; (j = next.fetch_add(1)) < jobs.size();) {
          const Job& job = jobs[j];
          const ProbePoints::Point& point = points[job.point];
          const fs::path dir = probes_dir / point.name;
          const fs::path rested = dir / kRestName / kRestedStateName;
          const std::string stage = test.name + "/probes/" + point.name + "/";
          std::int64_t done_steps = steps_each;
          if (job.kind == JobKind::Rest) {
            rest_point(run, deck, options, test, point);
            done_steps = def.rest_max_steps;
          } else if (job.kind == JobKind::Elastic) {
            run_probe(run, deck, options, test, check, rested, stage + kElasticPrefix + job.probe.name, job.probe);
          } else {
            run_probe(run, deck, options, test, def, rested, stage + job.probe.name, job.probe);
          }
          const std::int64_t done = steps_done += done_steps;
          const std::lock_guard<std::mutex> lock(progress_mutex);
          progress.update(done, static_cast<double>(done) / static_cast<double>(std::max<std::int64_t>(1, all_steps)));
        }
      } catch (...) {
        errors[static_cast<std::size_t>(w)] = std::current_exception();
        next = jobs.size();  // the others stop after their present job
      }
    };
    std::vector<std::thread> threads;
    for (int w = 1; w < workers; ++w) threads.emplace_back(work, w);
    work(0);
    for (std::thread& t : threads) t.join();
    for (const std::exception_ptr& e : errors)
      if (e) std::rethrow_exception(e);
  };
  run_jobs(rests);
  run_jobs(checks);
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (chosen[p].empty()) continue;
    double scale = 1.0;  // given magnitudes as they are
    if (def.kind == ProbeKind::Stress && def.scaled)
      scale = probe_scale(def, read_elastic_check(probes_dir / points[p].name, def),
                          path_tangent(run.stage_dir(test.name).parent_path(), test, points[p].row.step)).first;
    for (Job job : chosen[p]) {
      if (!std::isfinite(scale)) continue;  // no stiffness to size the probes by: the point says so (tabulate)
      if (def.kind == ProbeKind::Stress) job.probe.magnitude *= scale;
      probes.push_back(job);
    }
  }
  run_jobs(probes);
  progress.finish();
  return tabulate_probes(run.stage_dir(test.name).parent_path(), deck, test);
}

}  // namespace celldem
