#include "run/probes.hpp"

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

namespace {

constexpr double kPi = 3.14159265358979323846;
using Row6 = std::array<double, 6>;
constexpr std::array<const char*, 6> kStressNames = {"s11", "s22", "s33", "s12", "s13", "s23"};
constexpr std::array<const char*, 6> kStrainNames = {"e1", "e2", "e3", "g12", "g13", "g23"};
constexpr std::array<const char*, 6> kStrainProbeNames = {"e11", "e22", "e33", "g12", "g13", "g23"};


Row6 stresses(const SeriesRow& r) { return {r.s11, r.s22, r.s33, r.s12, r.s13, r.s23}; }
Row6 strains(const SeriesRow& r) { return {r.e1, r.e2, r.e3, r.g12, r.g13, r.g23}; }
Row6 minus(const Row6& a, const Row6& b) {
  Row6 d;
  for (int k = 0; k < 6; ++k) d[k] = a[k] - b[k];
  return d;
}
double norm(const Row6& a) {
  double s = 0.0;
  for (double x : a) s += x * x;
  return std::sqrt(s);
}

// The stress direction cos a u1 + sin a u2 of a probe plane, given cos a and sin a. Rendulic: u1 = (1, 0, 0),
// u2 = (0, 1, 1)/sqrt 2; deviatoric: u1 = (2, -1, -1)/sqrt 6 (a = 0 is triaxial compression), u2 = (0, 1, -1)/sqrt 2.
std::array<double, 3> plane_direction(ProbePlane plane, double c, double s) {
  if (plane == ProbePlane::Rendulic) return {c, s / std::sqrt(2.0), s / std::sqrt(2.0)};
  return {2.0 * c / std::sqrt(6.0), -c / std::sqrt(6.0) + s / std::sqrt(2.0), -c / std::sqrt(6.0) - s / std::sqrt(2.0)};
}

// Whether a row has reached an e1 point: past it in the direction of its sign.
bool reaches(const SeriesRow& row, double target) { return target >= 0.0 ? row.e1 >= target : row.e1 <= target; }

}  // namespace

std::pair<std::array<double, 3>, std::array<double, 3>> plane_basis(ProbePlane plane) {
  return {plane_direction(plane, 1.0, 0.0), plane_direction(plane, 0.0, 1.0)};
}

ProbeSelection parse_probe_selection(const std::string& text) {
  ProbeSelection s;
  const std::size_t dash = text.find('-');
  try {
    std::size_t used = 0;
    s.first = std::stoll(text.substr(0, dash), &used);
    if (used != (dash == std::string::npos ? text.size() : dash)) throw std::invalid_argument("");
    s.last = s.first;
    if (dash != std::string::npos) {
      s.last = std::stoll(text.substr(dash + 1), &used);
      if (used != text.size() - dash - 1) throw std::invalid_argument("");
    }
  } catch (const std::logic_error&) {
    throw std::invalid_argument("expected K or K-L (probe numbers from 1), got \"" + text + "\"");
  }
  if (s.first < 1 || s.last < s.first)
    throw std::invalid_argument("expected K or K-L with 1 <= K <= L, got \"" + text + "\"");
  return s;
}

namespace {
std::int64_t probes_of(const TestDef& test) {  // references not counted
  const ProbePlan p = plan_probes(test);
  return p.points * std::max<std::int64_t>(0, p.probes_per_point - 1);
}
}  // namespace

std::int64_t probe_number_offset(const Deck& deck, const TestDef& test) {
  std::int64_t offset = 0;
  for (const TestDef& t : deck.tests) {
    if (t.name == test.name) break;
    offset += probes_of(t);
  }
  return offset;
}

std::int64_t probe_count(const Deck& deck) {
  std::int64_t n = 0;
  for (const TestDef& t : deck.tests) n += probes_of(t);
  return n;
}

std::vector<std::string> probe_point_names(const ProbeDef& def) {
  std::vector<std::string> names;
  for (const double e1 : def.at_e1) names.push_back("e1_" + fmt10(e1));
  names.insert(names.end(), def.at.begin(), def.at.end());
  return names;
}

ProbePoints::ProbePoints(const ProbeDef& def, TestMeasure measure) : def_(def), peak_tracker_(measure) {
  const std::vector<std::string> names = probe_point_names(def);
  for (std::size_t k = 0; k < def.at_e1.size(); ++k) {
    Point p;
    p.name = names[k];
    p.missing = "the test ended before e1 reached " + fmt10(def.at_e1[k]);
    e1_.push_back(p);
  }
  peak_.name = "peak";
  end_.name = "end";
}

void ProbePoints::on_row(const State& state, const SeriesRow& row) {
  std::shared_ptr<const State> copy;  // one copy for every point this row is
  const auto keep = [&](Point& p) {
    if (!copy) copy = std::make_shared<const State>(state);
    p.state = copy;
    p.row = row;
    p.missing.clear();
  };
  for (std::size_t k = 0; k < e1_.size(); ++k) {
    const double target = def_.at_e1[k];
    if (reaches(row, target) && !e1_[k].state && !e1_[k].lost) {
      keep(e1_[k]);
      write_point(e1_[k]);
    }
  }
  const bool wants_peak = std::find(def_.at.begin(), def_.at.end(), "peak") != def_.at.end();
  // The summary's peak: the first row of the largest value of the test's measure (after a resume, above every row
  // read back too: the state is this run's own).
  if (peak_tracker_.offer(row) && wants_peak) keep(peak_), peak_unsaved_ = true;
}

void ProbePoints::keep_in(const fs::path& dir, const std::string& label, const std::string& physics) {
  dir_ = dir;
  label_ = label;
  physics_ = physics;
}

void ProbePoints::write_point(const Point& p) const {
  if (dir_.empty() || !p.state) return;
  fs::create_directories(dir_ / p.name);
  write_state((dir_ / p.name / "point.state").string(), *p.state, "probe point " + label_ + "/" + p.name, physics_);
}

void ProbePoints::save(const State&) {
  if (!peak_unsaved_) return;
  write_point(peak_);  // (a new peak at every row of the rising part: written once per checkpoint, not per row)
  peak_unsaved_ = false;
}

void ProbePoints::resume(const std::vector<SeriesRow>& rows) {
  const std::string lost = "the test was resumed after this point (the states kept before are lost with the run "
                           "that was stopped; --force runs it again whole)";
  // The state a stopped run kept of a point, if it is that of one of these rows (a later one is taken again).
  const auto kept = [&](Point& p) {
    const fs::path file = dir_ / p.name / "point.state";
    if (dir_.empty() || !fs::exists(file)) return false;
    State state = read_state(file.string());
    const auto row = std::find_if(rows.begin(), rows.end(), [&](const SeriesRow& r) {
      return r.step == static_cast<double>(state.control.stage_steps);
    });
    if (row == rows.end()) return false;
    p.state = std::make_shared<const State>(std::move(state));
    p.row = *row;
    p.missing.clear();
    return true;
  };
  peak_tracker_.seen(rows);
  for (std::size_t k = 0; k < e1_.size(); ++k) {
    const double target = def_.at_e1[k];
    const auto first = std::find_if(rows.begin(), rows.end(), [&](const SeriesRow& r) { return reaches(r, target); });
    if (first == rows.end()) continue;
    if (!kept(e1_[k]) || e1_[k].row.step != first->step) e1_[k] = Point{e1_[k].name, nullptr, {}, lost, true};
  }
  // The peak: the first row of the largest value of the measure among those read back.
  const auto peak = rows.empty() ? rows.end() : rows.begin() + static_cast<std::ptrdiff_t>(peak_row(peak_tracker_.measure(), rows));
  const bool wants_peak = std::find(def_.at.begin(), def_.at.end(), "peak") != def_.at.end();
  if (!wants_peak || peak == rows.end() || !kept(peak_) || peak_.row.step != peak->step)
    peak_ = Point{"peak", nullptr, {}, lost, false};
}

void ProbePoints::finish(const State& state, const SeriesRow& row) {
  end_.state = std::make_shared<const State>(state);
  end_.row = row;
}

std::vector<ProbePoints::Point> ProbePoints::points(bool peak_reached) const {
  std::vector<Point> out = e1_;
  for (const std::string& name : def_.at) {
    Point p = name == "peak" ? peak_ : end_;
    if (name == "peak" && !peak_reached) {
      p.state.reset();
      p.missing = "no peak reached: " + measure_name(peak_tracker_.measure()) +
                  " is largest at the end of the test (summary.json peak_reached)";
    }
    out.push_back(p);
  }
  return out;
}

std::vector<ProbeDirection> probe_directions(const ProbeDef& def) {
  std::vector<ProbeDirection> out;
  out.push_back({"reference", 0.0, 0.0, {}});
  for (std::size_t m = 0; m < def.magnitudes.size(); ++m) {
    std::string prefix;
    if (def.magnitudes.size() > 1) prefix.append("m").append(std::to_string(m + 1)).append("-");
    if (def.kind == ProbeKind::Strain) {
      for (int k = 0; k < 6; ++k) {
        ProbeDirection p{prefix + kStrainProbeNames[k], def.magnitudes[m], 0.0, {}};
        p.direction[k] = 1.0;
        out.push_back(p);
      }
      continue;
    }
    const int n = def.plane == ProbePlane::List ? static_cast<int>(def.list.size()) : def.directions;
    for (int i = 0; i < n; ++i) {
      char name[16];
      std::snprintf(name, sizeof name, "d%02d", i);
      ProbeDirection p{prefix + name, def.magnitudes[m], 0.0, {}};
      if (def.plane == ProbePlane::List) {
        for (int k = 0; k < 3; ++k) p.direction[k] = def.list[static_cast<std::size_t>(i)][k];
      } else {
        const double a = 2.0 * kPi * i / n;
        p.angle_deg = 360.0 * i / n;
        const std::array<double, 3> d = plane_direction(def.plane, std::cos(a), std::sin(a));
        p.direction = {d[0], d[1], d[2], 0, 0, 0};
      }
      out.push_back(p);
    }
  }
  return out;
}

std::vector<Leg> probe_legs(const ProbeDef& def, const ProbeDirection& probe, const Vec3& s, double time_step) {
  const auto ends_after = [](std::int64_t steps) {
    LegEnd e;
    e.kind = LegEndKind::Steps;
    e.steps = steps;
    return e;
  };
  std::vector<Leg> legs(4);
  const double ramp_time = static_cast<double>(def.steps) * time_step;
  for (int phase = 0; phase < 4; ++phase) {  // load, hold, unload, hold
    Leg& leg = legs[static_cast<std::size_t>(phase)];
    leg.end = ends_after(phase % 2 == 0 ? def.steps : def.hold_steps);
    const double sign = phase == 0 ? 1.0 : phase == 2 ? -1.0 : 0.0;  // the ramps' direction
    const bool loaded = phase == 1 || phase == 2;                    // the phase starts at the loaded point
    if (def.kind == ProbeKind::Stress) {
      for (int k = 0; k < 3; ++k) {
        const double increment = probe.magnitude * probe.direction[static_cast<std::size_t>(k)];
        const double from = s[k] + (loaded ? increment : 0.0);
        leg.axes[static_cast<std::size_t>(k)] =
            sign != 0.0 ? AxisControl{AxisMode::StressRamp, from, sign * increment / ramp_time}
                        : AxisControl{AxisMode::Stress, from};
      }
      continue;  // the shear axes are held (no shear axis named: the tilts stay as they stand)
    }
    const double per_step = sign * probe.magnitude / static_cast<double>(def.steps);
    for (int k = 0; k < 3; ++k)
      leg.axes[static_cast<std::size_t>(k)] = {AxisMode::StrainIncrement, per_step * probe.direction[static_cast<std::size_t>(k)]};
    for (int a = 0; a < 3; ++a)
      if (probe.direction[static_cast<std::size_t>(3 + a)] != 0.0)
        leg.axes[static_cast<std::size_t>(3 + a)] = AxisControl{AxisMode::StrainIncrement, per_step};
  }
  return legs;
}

namespace {

// What one probe did: its rows at the end of the loaded hold and of the unloaded hold.
struct ProbeResult {
  bool ran = false;
  bool controlled = true;
  std::string error;   // the probe failed (a RunError), else empty
  SeriesRow start, loaded, unloaded;
};

// One run of the probe set's work at a point: its rest, a probe of its elastic check (stress sets) or a probe.
enum class JobKind { Rest, Elastic, Probe };
struct Job {
  std::size_t point;
  ProbeDirection probe;
  JobKind kind = JobKind::Probe;
};

constexpr const char* kProbeResultName = "result.json";
constexpr const char* kPointRecordName = "point.json";

constexpr const char* kRestName = "rest";            // <point>/rest: the rest before probing
constexpr const char* kRestedStateName = "rested.state";
constexpr const char* kElasticPrefix = "elastic-";   // <point>/elastic-<probe>: a stress set's elastic check

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

// A probe's record as its folder holds it (run_probe wrote it, in this run or in another job's: --probes);
// nullopt when the folder has none.
std::optional<ProbeResult> read_probe_result(const fs::path& dir) {
  if (!fs::exists(dir / kProbeResultName)) return std::nullopt;
  const Json j = Json::parse(read_file((dir / kProbeResultName).string()));
  ProbeResult r;
  r.ran = j.at("ran").get<bool>();
  r.controlled = j.at("controlled").get<bool>();
  r.error = j.at("error").get<std::string>();
  if (r.ran) {
    const std::vector<SeriesRow> rows = read_series_file(dir / "series.csv");
    const auto loaded = std::find_if(rows.rbegin(), rows.rend(), [](const SeriesRow& row) { return row.leg == 1.0; });
    if (loaded == rows.rend() || rows.back().leg != 3.0)
      throw RunError((dir / "series.csv").string() + ": no row at the end of the loaded hold (leg 1) or of the "
                     "unloaded hold (leg 3): not a finished probe's series");
    r.start = rows.front();
    r.loaded = *loaded;
    r.unloaded = rows.back();
  }
  return r;
}

Json matrix_json(const Eigen::Matrix<double, 6, 6>& m) {
  Json rows = Json::array();
  for (int i = 0; i < 6; ++i) {
    Json row = Json::array();
    for (int j = 0; j < 6; ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return rows;
}

struct PlanePoint {
  double angle;  // [rad] the stress probe's direction in the plane
  double p1, p2; // its plastic strain increment's coordinates in the plane
};

double degrees_in_circle(double radians) {
  const double d = std::fmod(radians * 180.0 / kPi, 360.0);
  return d < 0.0 ? d + 360.0 : d;
}

// What the plastic responses of one probe set in a plane say, as an elastoplastic model reads them. With one
// plastic mechanism every plastic increment has the same direction (the flow direction), and its size grows
// with the loading direction's projection on the loading surface's normal n: |dep| = c max(0, cos(a - a_n)).
// The flow direction is the principal axis of the increments' scatter (its concentration
// lambda_max / (lambda_max + lambda_min) is 1 when all are parallel, 0.5 when they point anywhere), oriented
// as the increments of the directions that load; the normal is the a_n of the least-squares fit of that law over a 0.1 deg grid. Their angle is
// the non-associativity (0: associated flow).
Json plastic_response(const std::vector<PlanePoint>& points, double magnitude) {
  double sxx = 0.0, sxy = 0.0, syy = 0.0;
  for (const PlanePoint& q : points) sxx += q.p1 * q.p1, sxy += q.p1 * q.p2, syy += q.p2 * q.p2;
  if (points.empty() || sxx + syy == 0.0) return Json();
  const double half_trace = 0.5 * (sxx + syy), root = std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
  const double lambda_max = half_trace + root, lambda_min = half_trace - root;
  double flow = 0.5 * std::atan2(2.0 * sxy, sxx - syy);
  double best = INFINITY, normal = 0.0, scale = 0.0;
  for (int k = 0; k < 3600; ++k) {
    const double a = 2.0 * kPi * k / 3600.0;
    double gg = 0.0, gp = 0.0;
    for (const PlanePoint& q : points) {
      const double g = std::max(0.0, std::cos(q.angle - a));
      gg += g * g, gp += g * std::hypot(q.p1, q.p2);
    }
    if (gg == 0.0) continue;
    const double c = gp / gg;
    double misfit = 0.0;
    for (const PlanePoint& q : points) {
      const double r = std::hypot(q.p1, q.p2) - c * std::max(0.0, std::cos(q.angle - a));
      misfit += r * r;
    }
    if (misfit < best) best = misfit, normal = a, scale = c;
  }
  // Oriented as the plastic increments of the loading directions (those the fit loads: cos(a - normal) > 0).
  double along = 0.0;
  for (const PlanePoint& q : points)
    if (std::cos(q.angle - normal) > 0.0) along += std::cos(flow) * q.p1 + std::sin(flow) * q.p2;
  if (along < 0.0) flow += kPi;
  double between = std::abs(degrees_in_circle(flow) - degrees_in_circle(normal));
  if (between > 180.0) between = 360.0 - between;
  double total = 0.0;
  for (const PlanePoint& q : points) total += q.p1 * q.p1 + q.p2 * q.p2;
  return {{"magnitude", magnitude},
          {"flow_direction_deg", degrees_in_circle(flow)},
          {"flow_concentration", lambda_max / (lambda_max + lambda_min)},
          {"loading_normal_deg", degrees_in_circle(normal)},
          {"plastic_per_magnitude", scale / magnitude},
          {"fit_explains", total > 0.0 ? 1.0 - best / total : NAN},
          {"non_associativity_deg", between},
          {"meaning", "in the probes' plane (angles as the directions'): the plastic increments' principal direction "
                      "(flow) and how nearly parallel they are (concentration, 1: one mechanism), the loading "
                      "surface's normal from |de_plastic| = c max(0, cos(a - normal)) fitted over the directions "
                      "(plastic_per_magnitude = c / M, fit_explains: the share of the squared plastic response it "
                      "fits), and the angle between flow and normal (0: associated flow)"}};
}

// ||A - A^T|| / ||A|| (Frobenius): 0 for a symmetric matrix.
double asymmetry(const Eigen::Matrix<double, 6, 6>& a) {
  const double n = a.norm();
  return n > 0.0 ? (a - a.transpose()).norm() / n : NAN;
}

// The stiffness of the point's contact network (measure/network_stiffness.hpp: sticking tangential springs
// when the test has friction, normal springs only without), as a strain probe measures it: celldem's shear axes
// g_ij also turn the stress the sample carries (simple_shear_rotation), which the probes' g columns include.
// With the probes' elastic stiffness: ||C_elastic - C_network|| / ||C_network|| (Frobenius). An estimate the law
// or the network cannot give is recorded with its reason.
Json network_estimate(const Deck& deck, const TestDef& test, const State& point, const Eigen::Matrix<double, 6, 6>& elastic) {
  const bool tangential = test.friction > 0.0;
  Json out = {{"tangential_springs", tangential}};
  try {
    State state = point;
    const Model model = make_model(deck, state.particles.radius, deck.stage_time_step(test));
    state.pairs.skin = skin_length(deck);
    rebuild_pairs(model, state);  // a state read back holds its contacts' history, not a built list
    const NetworkStiffness n = network_stiffness(model, state, tangential);
    Mat3 stress;
    const auto& s = state.stress;
    stress << s[0], s[3], s[4], s[3], s[1], s[5], s[4], s[5], s[2];
    Stiffness6 probed = n.relaxed;
    for (int a = 0; a < 3; ++a) {
      Vec3 g = Vec3::Zero();
      g[a] = 1.0;
      probed.col(3 + a) += voigt_of_stress(simple_shear_rotation(stress, g));
    }
    out["affine"] = matrix_json(n.affine);
    out["relaxed"] = matrix_json(n.relaxed);
    out["affine_asymmetry"] = asymmetry(n.affine);
    out["relaxed_asymmetry"] = asymmetry(n.relaxed);
    out["relaxed_as_probed"] = matrix_json(probed);
    out["contacts"] = n.contacts;
    out["rattlers"] = n.rattlers;
    out["solver_residual"] = n.solver_residual;
    out["elastic_vs_network"] = (elastic - probed).norm() / probed.norm();
  } catch (const std::exception& e) {  // another law, or a network with no stable relaxed state
    out["error"] = e.what();
  }
  return out;
}

// The smallest eigenvalue of the symmetric part of `a` [its unit]; NaN for a matrix with a non-finite entry.
double min_symmetric_eigenvalue(const Eigen::Matrix<double, 6, 6>& a) {
  if (!a.allFinite()) return NAN;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> solver(0.5 * (a + a.transpose()));
  return solver.eigenvalues().minCoeff();
}

// The rest before a point's probes, as its folder holds it (rest_point); nullopt when there is none.
struct RestRecord {
  bool reached = false, controlled = true;
  std::int64_t steps = 0;
  double goal = NAN, last_creep = NAN;
  std::string error, gave_up;
  Json json;
};
std::optional<RestRecord> read_rest(const fs::path& point_dir) {
  const fs::path file = point_dir / kRestName / kProbeResultName;
  if (!fs::exists(file)) return std::nullopt;
  RestRecord r;
  r.json = Json::parse(read_file(file.string()));
  r.reached = r.json.at("reached").get<bool>();
  r.controlled = r.json.at("controlled").get<bool>();
  r.steps = r.json.at("steps").get<std::int64_t>();
  r.goal = r.json.at("goal").get<double>();
  r.error = r.json.at("error").get<std::string>();
  if (!r.json.at("creep").empty()) r.last_creep = r.json.at("creep").back().get<double>();
  r.gave_up = r.json.value("gave_up", std::string());
  return r;
}

// A stress set's elastic check at a point (its six strain probes net of their reference, which holds the strains):
// the tangent and elastic stiffness, the reference's stress drift and the smallest probe response |ds|.
struct ElasticCheck {
  bool whole = false;  // every probe and the reference ran and held their controls
  std::string reason;  // why not
  Eigen::Matrix<double, 6, 6> tangent = Eigen::Matrix<double, 6, 6>::Zero(), elastic = tangent;
  double drift = NAN, smallest_response = NAN;  // [Pa]
};

// Strain probes net of their reference (`probes` in kStrainProbeNames order, each from the same start): the
// columns of the tangent stiffness (the loaded stress increments per unit strain) and of its elastic part (those
// recovered on unloading). With the reference's drift |ds| over the probe and the smallest |ds| response.
ElasticCheck strain_stiffness(const ProbeResult& reference, const std::vector<std::optional<ProbeResult>>& probes,
                              double magnitude) {
  ElasticCheck c;
  c.whole = reference.ran && reference.controlled;
  c.drift = std::max(norm(minus(stresses(reference.loaded), stresses(reference.start))),
                     norm(minus(stresses(reference.unloaded), stresses(reference.start))));
  c.smallest_response = INFINITY;
  for (std::size_t column = 0; column < probes.size(); ++column) {
    if (!probes[column] || !probes[column]->ran || !probes[column]->controlled) {
      c.whole = false;
      c.reason = std::string("the elastic check's probe ") + kStrainProbeNames[column] + " did not run or hold its control";
      continue;
    }
    const ProbeResult& r = *probes[column];
    const Row6 ds = minus(stresses(r.loaded), stresses(reference.loaded));
    const Row6 ds_residual = minus(stresses(r.unloaded), stresses(reference.unloaded));
    c.smallest_response = std::min(c.smallest_response, norm(ds));
    for (std::size_t i = 0; i < 6; ++i) {
      c.tangent(static_cast<int>(i), static_cast<int>(column)) = ds[i] / magnitude;
      c.elastic(static_cast<int>(i), static_cast<int>(column)) = (ds[i] - ds_residual[i]) / magnitude;
    }
  }
  return c;
}

ElasticCheck read_elastic_check(const fs::path& point_dir, const ProbeDef& def) {
  const std::optional<ProbeResult> reference = read_probe_result(point_dir / (std::string(kElasticPrefix) + "reference"));
  if (!reference || !reference->ran) {
    ElasticCheck c;
    c.reason = "the elastic check's reference did not run";
    return c;
  }
  std::vector<std::optional<ProbeResult>> probes;
  for (const char* name : kStrainProbeNames) probes.push_back(read_probe_result(point_dir / (std::string(kElasticPrefix) + name)));
  ElasticCheck c = strain_stiffness(*reference, probes, def.target_strain);
  if (!reference->controlled) c.reason = "the elastic check's reference lost its control";
  return c;
}

// A scaled stress set's magnitude at a point [Pa]: target_strain over the largest compliance |C^-1 d| of the set's
// directions, C the tangent stiffness where its symmetric part is positive definite, else the elastic one; with
// what it came from. NaN where neither gives a finite positive size.
std::pair<double, std::string> stiffness_scale(const ProbeDef& def, const ElasticCheck& check) {
  const std::vector<ProbeDirection> directions = probe_directions(def);
  for (const auto& [c, from] : {std::pair{check.tangent, "tangent"}, std::pair{check.elastic, "elastic"}}) {
    if (!(min_symmetric_eigenvalue(c) > 0.0)) continue;
    const Eigen::Matrix<double, 6, 6> compliance = c.inverse();
    double largest = 0.0;
    for (std::size_t k = 1; k < directions.size(); ++k) {
      Eigen::Matrix<double, 6, 1> d;
      for (int i = 0; i < 6; ++i) d(i) = directions[k].direction[static_cast<std::size_t>(i)];
      largest = std::max(largest, (compliance * d).norm());
    }
    const double m = def.target_strain / largest;
    if (std::isfinite(m) && m > 0.0) return {m, from};
  }
  return {NAN, "none"};
}

// A scaled stress set's magnitude at a point [Pa], and what it came from: stiffness_scale, capped by the test's path.
std::pair<double, std::string> probe_scale(const ProbeDef& def, const ElasticCheck& check, double path_tangent) {
  std::pair<double, std::string> sized = stiffness_scale(def, check);
  // A strain probe holds the other strains and so blocks the mechanism that a stress probe frees: the test's own
  // path (which loads at its stresses) is softer in the loading cone. The smaller size of the two, not below a
  // hundredth of the elastic one (at a limit state the path's tangent vanishes).
  const double path = def.target_strain * path_tangent;
  if (std::isfinite(sized.first) && std::isfinite(path) && path < sized.first)
    sized = {std::max(path, 0.01 * sized.first), path >= 0.01 * sized.first ? "path" : "path, floored"};
  return sized;
}

// The test's tangent along its own path at a point [Pa]: |ds| / |de| (six components each) between the point's row
// of the test's series and the row before it; NaN where there is none.
double path_tangent(const fs::path& run_dir, const TestDef& test, double point_step) {
  const fs::path file = run_dir / test.name / "series.csv";
  if (!fs::exists(file)) return NAN;
  const std::vector<SeriesRow> rows = read_series_file(file);
  const auto at = std::find_if(rows.begin(), rows.end(), [&](const SeriesRow& r) { return r.step == point_step; });
  if (at == rows.end() || at == rows.begin()) return NAN;
  const double de = norm(minus(strains(*at), strains(*(at - 1))));
  return de > 0.0 ? norm(minus(stresses(*at), stresses(*(at - 1)))) / de : NAN;
}

}  // namespace

ProbeVerdict judge_probe_point(const ProbeDef& def, const ProbeEvidence& e) {
  ProbeVerdict v;
  const auto fail = [&](std::string_view check, const std::string& why) {
    v.failed.emplace_back(check);
    if (!v.reason.empty()) v.reason += "; ";
    v.reason.append(check).append(": ").append(why);
  };
  const double drift_ratio = e.drift / e.smallest_response;
  if (std::isfinite(e.smallest_response) && !(e.smallest_response > 0.0))  // no ratio to print: say what it means
    fail(kProbeCheckNames[0], "the smallest response is " + fmt10(e.smallest_response) +
                                  ": the probe moved nothing it can be judged on (magnitudes too small to measure)");
  else if (std::isfinite(e.drift) && std::isfinite(e.smallest_response) && !(drift_ratio <= def.drift_limit))
    fail(kProbeCheckNames[0], "the reference drifts " + fmt10(e.drift) + " over a probe, " + fmt10(drift_ratio) +
                                  " of the smallest response " + fmt10(e.smallest_response) + " (limit " +
                                  fmt10(def.drift_limit) + ")");
  if (!e.rest_reached && std::isnan(e.rest_creep))
    fail(kProbeCheckNames[1], "the point was not rested (rest_max_steps " + std::to_string(def.rest_max_steps) +
                                  "); probed as the test took it");
  else if (!e.rest_reached)
    fail(kProbeCheckNames[1], "the rest's last window crept " + fmt10(e.rest_creep) + " (goal " +
                                  fmt10(def.rest_fraction * def.target_strain) + ") when " +
                                  (e.rest_gave_up.empty() ? "its budget of " + std::to_string(def.rest_max_steps) +
                                                                " steps was spent"
                                                          : e.rest_gave_up) +
                                  "; probed as the test took it");
  if (std::isfinite(e.elastic_asymmetry) || !std::isnan(e.elastic_min_eigenvalue)) {
    if (!(e.elastic_min_eigenvalue > 0.0))
      fail(kProbeCheckNames[2], "the elastic stiffness's symmetric part has the eigenvalue " +
                                    fmt10(e.elastic_min_eigenvalue) + " Pa");
    if (!(e.elastic_asymmetry <= def.asymmetry_limit))
      fail(kProbeCheckNames[3], "|C - C^T| / |C| = " + fmt10(e.elastic_asymmetry) + " (limit " +
                                    fmt10(def.asymmetry_limit) + ")");
  }
  if (!e.elastic_check_missing.empty())
    fail(kProbeCheckNames[4], "no elastic part to compare with: " + e.elastic_check_missing);
  else if (!std::isnan(e.elastic_factor) && !(e.elastic_factor <= def.elastic_factor))
    fail(kProbeCheckNames[4], (e.elastic_worst_probe.empty() ? "a probe" : e.elastic_worst_probe) + "'s recovered strain is " +
                                  (std::isfinite(e.elastic_factor) ? fmt10(e.elastic_factor) + " times"
                                                                   : std::string("more than 60 deg from")) +
                                  " C_elastic^-1 ds (limit " + fmt10(def.elastic_factor) + "x)");
  return v;
}

double elastic_agreement(const std::array<double, 6>& measured, const std::array<double, 6>& predicted) {
  const double a = norm(measured), p = norm(predicted);
  if (!(a > 0.0) || !(p > 0.0)) return INFINITY;
  double dot = 0.0;
  for (std::size_t k = 0; k < 6; ++k) dot += measured[k] * predicted[k];
  if (!(dot / (a * p) >= 0.5)) return INFINITY;  // more than 60 deg apart (or NaN)
  return std::max(a / p, p / a);
}

int probe_cone(const std::array<double, 6>& d, const Vec3& s) {
  const double change = d[0] * s[2] - s[0] * d[2];  // s33^2 d(s11/s33)
  const double scale = std::abs(s[0]) + std::abs(s[2]);
  if (!(std::abs(change) > 1e-9 * scale)) return 0;
  return change > 0.0 ? 1 : -1;
}

Json run_test_probes(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                     const ProbePoints& probe_points, bool peak_reached) {
  const ProbeDef& def = *test.probes;
  const std::vector<ProbePoints::Point> points = probe_points.points(peak_reached);
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

Json tabulate_probes(const fs::path& run_dir, const Deck& deck, const TestDef& test) {
  const ProbeDef& def = *test.probes;
  const std::vector<ProbeDirection> directions = probe_directions(def);
  const fs::path probes_dir = run_dir / test.name / "probes";
  const bool stress_set = def.kind == ProbeKind::Stress;
  // probes.csv: each probe's response net of its point's reference, at the loaded and the unloaded ends; beside it
  // the reference's own drift over the probe, and (stress sets) the elastic prediction and the loading cone.
  std::string csv = "point,point_step,point_e1,kind,probe,magnitude,angle_deg,d11,d22,d33,d12,d13,d23";
  const auto add_columns = [&](const std::array<const char*, 6>& names, const char* suffix) {
    for (const char* name : names) csv.append(",d").append(name).append(suffix);
  };
  add_columns(kStressNames, "");
  add_columns(kStrainNames, "");
  add_columns(kStrainNames, "_plastic");
  add_columns(kStrainNames, "_elastic");
  add_columns(kStressNames, "_residual");
  csv += ",response,reference_drift,elastic_predicted,elastic_factor,cone,controlled,status\n";
  Json summary = {{"kind", std::string(name_of(def.kind, kProbeKindNames))}, {"steps", def.steps},
                  {"hold_steps", def.hold_steps}, {"magnitudes", def.magnitudes}, {"points", Json::object()},
                  {"table", (fs::path(test.name) / "probes" / "probes.csv").string()},
                  {"target_strain", def.target_strain},
                  {"rules", {{"rest_fraction", def.rest_fraction}, {"rest_max_steps", def.rest_max_steps},
                             {"drift_limit", def.drift_limit}, {"asymmetry_limit", def.asymmetry_limit}}}};
  if (stress_set) summary["rules"]["elastic_factor"] = def.elastic_factor;
  if (def.scaled && stress_set) {
    summary["magnitudes"] = Json::array();  // per point (points.<p>.magnitudes)
    summary["magnitude_factors"] = def.magnitudes;
  }
  if (stress_set) summary["plane"] = std::string(name_of(def.plane, kProbePlaneNames));
  Json stiffness = {{"voigt_order", {"11", "22", "33", "12", "13", "23"}},
                    {"units", "Pa per unit strain; engineering shear strains g_ij; compression +"},
                    {"points", Json::object()}};
  for (const std::string& name : probe_point_names(def)) {
    const fs::path point_dir = probes_dir / name;
    if (!fs::exists(point_dir / kPointRecordName))
      throw RunError(point_dir.string() + ": no " + kPointRecordName + " (not a probed run folder)");
    const Json record = Json::parse(read_file((point_dir / kPointRecordName).string()));
    const double point_step = record.at("step").get<double>(), point_e1 = record.at("e1").get<double>();
    Json entry = {{"step", point_step}, {"e1", point_e1}};
    // A point that ends here: its status and why, in the summary.
    const auto settle = [&](const char* status, const std::string& reason) {
      entry["status"] = status;
      entry["reason"] = reason;
      summary["points"][name] = entry;
    };
    const auto left_to_other_jobs = [&] {
      entry["missing"] = static_cast<std::int64_t>(directions.size()) - 1;
      settle("not run here", "its probes were left to other jobs (--probes); `celldem merge` gathers them");
    };
    if (!record.at("reached").get<bool>()) {
      settle("not run", record.at("reason").get<std::string>());
      continue;
    }
    entry["state"] = (fs::path(test.name) / "probes" / name / "point.state").string();
    const std::optional<ProbeResult> reference_record = read_probe_result(point_dir / "reference");
    const std::optional<RestRecord> rest = read_rest(point_dir);
    if (!rest) {
      left_to_other_jobs();
      continue;
    }
    entry["rest"] = {{"reached", rest->reached}, {"steps", rest->steps}, {"goal", rest->goal},
                     {"last_window_creep", rest->last_creep}, {"window_steps", rest->json.at("window_steps")},
                     {"controlled", rest->controlled}, {"probed_from", rest->reached ? "rest" : "point"},
                     {"folder", (fs::path(test.name) / "probes" / name / kRestName).string()}};
    if (!rest->gave_up.empty()) entry["rest"]["gave_up"] = rest->gave_up;
    if (!rest->error.empty()) {
      settle("failed", "the rest before the probes failed: " + rest->error);
      continue;
    }
    ProbeEvidence evidence;
    evidence.rest_reached = rest->reached;
    evidence.rest_creep = rest->last_creep;
    evidence.rest_gave_up = rest->gave_up;
    // A stress set's elastic check: C_elastic at the same rested state, and the probes' size where it is scaled.
    ElasticCheck check;
    double scale = 1.0;
    std::string scale_from = "given";
    if (stress_set) {
      check = read_elastic_check(point_dir, def);
      Json e = {{"target_strain", def.target_strain}, {"whole", check.whole}};
      if (!check.whole) e["reason"] = check.reason;
      e["elastic"] = matrix_json(check.elastic);
      e["tangent"] = matrix_json(check.tangent);
      const double asymmetry_of_elastic = asymmetry(check.elastic);
      const double min_eigenvalue_of_elastic = min_symmetric_eigenvalue(check.elastic);
      e["elastic_asymmetry"] = asymmetry_of_elastic;
      e["elastic_min_eigenvalue"] = min_eigenvalue_of_elastic;
      e["reference_drift_stress"] = check.drift;
      entry["elastic_check"] = e;
      if (!check.whole) evidence.elastic_check_missing = check.reason;
      if (check.whole) {
        evidence.elastic_asymmetry = asymmetry_of_elastic;
        evidence.elastic_min_eigenvalue = min_eigenvalue_of_elastic;
      }
      if (def.scaled) {
        std::tie(scale, scale_from) = probe_scale(def, check, path_tangent(run_dir, test, point_step));
        Json m = Json::array();
        for (double f : def.magnitudes) m.push_back(f * scale);
        entry["magnitudes"] = m;
        entry["magnitude_from"] = scale_from;
        if (!std::isfinite(scale)) {  // its probes were not run (run_test_probes)
          const ProbeVerdict v = judge_probe_point(def, evidence);
          entry["checks_failed"] = v.failed;
          settle("failed", "no stiffness to size the probes by: the elastic check's tangent and elastic stiffness "
                           "are both not positive definite (elastic_check)" + (v.reason.empty() ? "" : "; " + v.reason));
          continue;
        }
      }
    }
    if (!reference_record) {
      left_to_other_jobs();
      continue;
    }
    const ProbeResult& reference = *reference_record;
    if (!reference.ran) {
      settle("failed", "the reference probe failed: " + reference.error);
      continue;
    }
    const Vec3 s{reference.start.s11, reference.start.s22, reference.start.s33};
    int ran = 0, controlled = 0, failed = 0;
    // Strain probes: per magnitude, the columns of the tangent and elastic stiffness.
    std::vector<Eigen::Matrix<double, 6, 6>> tangent(def.magnitudes.size(), Eigen::Matrix<double, 6, 6>::Zero()),
        elastic = tangent;
    // Stress probes: the strain response's length per direction and magnitude (linearity across magnitudes).
    std::vector<std::vector<double>> response(def.magnitudes.size());
    std::vector<std::vector<int>> cones(def.magnitudes.size());
    std::vector<std::vector<PlanePoint>> plastic(def.magnitudes.size());  // stress probes in a plane
    // The reference's drift over a probe: its strains (stress sets: it holds the stresses) or its stresses (strain
    // sets: it holds the strains) from its start to the ends of the loaded and the unloaded holds.
    const double drift = stress_set ? std::max(norm(minus(strains(reference.loaded), strains(reference.start))),
                                               norm(minus(strains(reference.unloaded), strains(reference.start))))
                                    : std::max(norm(minus(stresses(reference.loaded), stresses(reference.start))),
                                               norm(minus(stresses(reference.unloaded), stresses(reference.start))));
    double smallest = INFINITY, worst_factor = 0.0;
    std::string worst_probe;
    std::vector<double> factors;
    int missing = 0;
    for (std::size_t k = 1; k < directions.size(); ++k) {
      const ProbeDirection& d = directions[k];
      const std::optional<ProbeResult> record = read_probe_result(point_dir / d.name);
      if (!record) {  // another job's (--probes), not merged
        ++missing;
        continue;
      }
      const ProbeResult& r = *record;
      const std::size_t m = static_cast<std::size_t>(std::find(def.magnitudes.begin(), def.magnitudes.end(), d.magnitude) - def.magnitudes.begin());
      const double magnitude = stress_set ? d.magnitude * scale : d.magnitude;
      csv.append(name).append(",").append(fmt10(point_step)).append(",").append(fmt10(point_e1));
      csv.append(",").append(name_of(def.kind, kProbeKindNames)).append(",").append(d.name);
      csv.append(",").append(fmt10(magnitude)).append(",").append(fmt10(d.angle_deg));
      for (double x : d.direction) csv.append(",").append(fmt10(x));
      if (!r.ran) {
        ++failed;
        for (int c = 0; c < 35; ++c) csv += ",";
        std::string why = r.error;
        std::replace(why.begin(), why.end(), ',', ';');
        std::replace(why.begin(), why.end(), '\n', ' ');
        csv.append(",false,failed: ").append(why).append("\n");
        continue;
      }
      ++ran;
      controlled += r.controlled;
      const Row6 ds = minus(stresses(r.loaded), stresses(reference.loaded));
      const Row6 de = minus(strains(r.loaded), strains(reference.loaded));
      const Row6 de_plastic = minus(strains(r.unloaded), strains(reference.unloaded));
      const Row6 ds_residual = minus(stresses(r.unloaded), stresses(reference.unloaded));
      const Row6 de_elastic = minus(de, de_plastic);
      for (const Row6* v : {&ds, &de, &de_plastic, &de_elastic, &ds_residual})
        for (double x : *v) csv.append(",").append(fmt10(x));
      const double size = stress_set ? norm(de) : norm(ds);
      smallest = std::min(smallest, size);
      double predicted = NAN, factor = NAN;
      int cone = 0;
      if (stress_set) {
        cone = probe_cone(d.direction, s);
        if (check.whole) {  // C_elastic^-1 of the recovered stress increment
          Eigen::Matrix<double, 6, 1> recovered;
          for (int i = 0; i < 6; ++i) recovered(i) = ds[static_cast<std::size_t>(i)] - ds_residual[static_cast<std::size_t>(i)];
          const Eigen::Matrix<double, 6, 1> p = check.elastic.fullPivLu().solve(recovered);
          Row6 prediction;
          for (int i = 0; i < 6; ++i) prediction[static_cast<std::size_t>(i)] = p(i);
          predicted = norm(prediction);
          factor = elastic_agreement(de_elastic, prediction);
          factors.push_back(factor);
          if (!(factor <= worst_factor)) worst_probe = d.name;
          worst_factor = std::max(worst_factor, factor);
        }
      }
      csv.append(",").append(fmt10(size)).append(",").append(fmt10(drift)).append(",").append(fmt10(predicted));
      csv.append(",").append(fmt10(factor)).append(",").append(stress_set ? (cone > 0 ? "loading" : cone < 0 ? "unloading" : "neutral") : "");
      csv.append(r.controlled ? ",true,ok\n" : ",false,ok\n");
      if (!stress_set) {
        const int column = static_cast<int>(std::max_element(d.direction.begin(), d.direction.end()) - d.direction.begin());
        for (int i = 0; i < 6; ++i) {
          tangent[m](i, column) = ds[static_cast<std::size_t>(i)] / d.magnitude;
          elastic[m](i, column) = (ds[static_cast<std::size_t>(i)] - ds_residual[static_cast<std::size_t>(i)]) / d.magnitude;
        }
      } else {
        response[m].push_back(norm(de));
        cones[m].push_back(cone);
        if (def.plane != ProbePlane::List) {
          const auto [u1, u2] = plane_basis(def.plane);
          double p1 = 0.0, p2 = 0.0;
          for (int c = 0; c < 3; ++c) p1 += u1[c] * de_plastic[c], p2 += u2[c] * de_plastic[c];
          plastic[m].push_back({d.angle_deg * kPi / 180.0, p1, p2});
        }
      }
    }
    // What the set says (stiffness, linearity, the plastic reading) only from a whole set that held its controls:
    // a probe whose stress or strain left its target did not probe the direction it names.
    const bool whole = failed == 0 && missing == 0 && controlled == ran;
    entry["status"] = missing > 0 ? "partly run" : failed > 0 ? "ran with failures" : whole ? "ran" : "ran with uncontrolled probes";
    if (entry["status"] == "ran with uncontrolled probes")
      entry["reason"] = std::to_string(ran - controlled) + " probes lost their control (result.json control_errors): "
                        "the set's stiffness, linearity and plastic reading are not given";
    entry["probes"] = ran + failed;
    entry["failed"] = failed;
    if (missing > 0) {
      entry["missing"] = missing;
      entry["reason"] = std::to_string(missing) + " probes were left to other jobs (--probes); `celldem merge` gathers them";
    }
    entry["controlled"] = controlled;
    entry["folder"] = (fs::path(test.name) / "probes" / name).string();
    if (ran > 0) {
      evidence.drift = drift;
      evidence.smallest_response = smallest;
      entry["drift"] = {{"reference", drift}, {"smallest_response", smallest}, {"ratio", drift / smallest},
                        {"unit", stress_set ? "strain |de|" : "stress |ds| [Pa]"}};
    }
    if (!factors.empty()) {
      evidence.elastic_factor = worst_factor;
      evidence.elastic_worst_probe = worst_probe;
      std::vector<double> sorted = factors;
      std::sort(sorted.begin(), sorted.end());
      entry["elastic_check"]["agreement"] = {
          {"worst_factor", worst_factor},  // null when a probe's is infinite (turned)
          {"worst_probe", worst_probe},
          {"turned", std::count_if(factors.begin(), factors.end(), [](double f) { return std::isinf(f); })},
          {"median_factor", sorted[sorted.size() / 2]},
          {"within_limit", std::count_if(factors.begin(), factors.end(), [&](double f) { return f <= def.elastic_factor; })},
          {"probes", factors.size()},
          {"meaning", "per probe, its recovered strain against C_elastic^-1 ds (elastic_agreement): the ratio of "
                      "lengths taken >= 1, infinite where they are more than 60 deg apart"}};
    }
    if (def.kind == ProbeKind::Strain && whole) {
      Json per_magnitude = Json::array();
      for (std::size_t m = 0; m < def.magnitudes.size(); ++m)
        per_magnitude.push_back({{"magnitude", def.magnitudes[m]}, {"tangent", matrix_json(tangent[m])},
                                 {"elastic", matrix_json(elastic[m])}, {"elastic_asymmetry", asymmetry(elastic[m])},
                                 {"elastic_min_eigenvalue", min_symmetric_eigenvalue(elastic[m])},
                                 {"tangent_asymmetry", asymmetry(tangent[m])}});
      stiffness["points"][name] = {{"step", point_step}, {"e1", point_e1}, {"magnitudes", per_magnitude}};
      entry["elastic_asymmetry"] = per_magnitude[0]["elastic_asymmetry"];
      entry["elastic_min_eigenvalue"] = per_magnitude[0]["elastic_min_eigenvalue"];
      evidence.elastic_asymmetry = asymmetry(elastic.front());
      evidence.elastic_min_eigenvalue = min_symmetric_eigenvalue(elastic.front());
      const Json network = network_estimate(deck, test, read_state((point_dir / "point.state").string()), elastic.front());
      stiffness["points"][name]["network"] = network;
      if (network.contains("elastic_vs_network")) entry["elastic_vs_network"] = network["elastic_vs_network"];
    }
    // The point's judgement (judge_probe_point): a status naming the first check failed, every failed check with
    // its numbers, and the readings that rest on them withheld.
    const ProbeVerdict verdict = judge_probe_point(def, evidence);
    entry["checks_failed"] = verdict.failed;
    const bool trusted = verdict.failed.empty();
    if (whole && !trusted) {
      entry["status"] = verdict.failed.front();
      entry["reason"] = verdict.reason;
    } else if (!trusted) {
      entry["checks_reason"] = verdict.reason;
    }
    const std::string withheld = "withheld: " + verdict.reason;
    if (stress_set && def.magnitudes.size() > 1 && whole) {
      // Linear response scales with the magnitude: per direction |de(M_last)| / |de(M_first)| / (M_last / M_first)
      // is 1 in the linear range; given per cone (loading: the probe raises s11/s33), whose responses differ.
      const std::size_t last = def.magnitudes.size() - 1;
      std::vector<double> all;
      std::vector<double> by_cone[2];
      for (std::size_t i = 0; i < response[0].size() && i < response[last].size(); ++i) {
        const double ratio = response[last][i] / response[0][i] / (def.magnitudes[last] / def.magnitudes[0]);
        all.push_back(ratio);
        if (cones[0][i] != 0) by_cone[cones[0][i] > 0 ? 0 : 1].push_back(ratio);
      }
      const auto describe = [](std::vector<double> r) {
        if (r.empty()) return Json();
        std::sort(r.begin(), r.end());
        return Json{{"directions", r.size()}, {"median_ratio", r[r.size() / 2]}, {"min_ratio", r.front()},
                    {"max_ratio", r.back()}};
      };
      if (!all.empty()) {
        Json linearity = describe(all);
        linearity["loading"] = describe(by_cone[0]);
        linearity["unloading"] = describe(by_cone[1]);
        linearity["meaning"] = "per direction |de| at the largest magnitude over |de| at the smallest, divided by the "
                               "magnitudes' ratio (1 where the response is linear): over all directions, and per cone "
                               "(loading: the probe raises s11/s33; unloading: it lowers it)";
        const bool drifting = std::find(verdict.failed.begin(), verdict.failed.end(), kProbeCheckNames[0]) != verdict.failed.end();
        if (drifting) {
          entry["linearity"] = nullptr;
          entry["linearity_withheld"] = withheld;
        } else {
          entry["linearity"] = linearity;
        }
      }
    }
    if (stress_set && def.plane != ProbePlane::List && whole) {
      if (trusted) {
        entry["plastic"] = plastic_response(plastic.back(), def.magnitudes.back() * scale);
      } else {  // the split into elastic and plastic parts, and so flow, normal and concentration, rests on the checks
        entry["plastic"] = nullptr;
        entry["plastic_withheld"] = withheld;
      }
    }
    summary["points"][name] = entry;
  }
  write_file_atomic(probes_dir / "probes.csv", csv);
  if (def.kind == ProbeKind::Strain) {
    write_file_atomic(probes_dir / "stiffness.json", stiffness.dump(1));
    summary["stiffness"] = (fs::path(test.name) / "probes" / "stiffness.json").string();
  }
  return summary;
}

}  // namespace celldem
