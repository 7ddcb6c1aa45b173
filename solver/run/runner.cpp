#include "run/runner.hpp"

#include <omp.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "core/model.hpp"
#include "io/state_file.hpp"
#include "measure/micro.hpp"
#include "measure/series_row.hpp"
#include "run/progress.hpp"
#include "run/sample.hpp"
#include "step.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

volatile std::sig_atomic_t g_stop_requested = 0;
void on_stop_signal(int) { g_stop_requested = 1; }

constexpr double kDilatancyWindow = 0.0025;  // DI fitted over the last 0.25 % of e1
constexpr double kMaxStepMotion = 0.05;       // runaway: a particle moving 5 % of its radius in one step
constexpr double kMaxKineticToElastic = 0.5;  // runaway in a test: kinetic energy above half the elastic
constexpr double kQuasiStaticInertia = 1e-3;  // inertial number above which a test is not quasi-static
constexpr double kServoTolerance = 0.005;     // stress-controlled axes should stay within 0.5 % of target
constexpr double kStableTimeStepFraction = 0.5;  // of sqrt(m_min/kn): measured stable limit ~0.55
constexpr const char* kCheckpoint = "checkpoint.state";  // in the stage's folder
constexpr const char* kPrepared = "prepared.state";
constexpr const char* kProgress = "progress.json";
constexpr const char* kSummary = "summary.json";

void write_text_atomic(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out.flush()) throw RunError(tmp.string() + ": cannot write");
  }
  fs::rename(tmp, path);
}

Json read_json(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw RunError(path.string() + ": cannot read");
  try {
    return Json::parse(in);
  } catch (const Json::exception& e) {
    throw RunError(path.string() + ": not valid JSON (" + e.what() + ")");
  }
}

// Tests may run side by side (see run_deck): the summary and progress.json are shared between them, so
// every read-modify-write of either holds this lock.
std::mutex g_run_files;

// Prints a warning and records it in the summary, once: a resumed run reloads the summary it had written.
void add_warning(Json& summary, const std::string& w) {
  const std::lock_guard<std::mutex> lock(g_run_files);
  std::fprintf(stderr, "celldem: warning: %s\n", w.c_str());
  for (const auto& known : summary["warnings"])
    if (known == w) return;
  summary["warnings"].push_back(w);
}

// Reads a series.csv into its header and rows of numbers (for summaries and for resuming).
struct SeriesTable {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  int column(const std::string& name) const {
    for (std::size_t k = 0; k < columns.size(); ++k)
      if (columns[k] == name) return static_cast<int>(k);
    throw RunError("series has no column " + name);
  }
};

// Keeps only complete rows (a row cut by a kill is dropped) with step <= max_step.
SeriesTable read_series(const fs::path& path, std::int64_t max_step, std::string* kept_text = nullptr) {
  SeriesTable t;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw RunError(path.string() + ": cannot read");
  std::string line;
  if (!std::getline(in, line) || in.eof()) throw RunError(path.string() + ": no header");
  {
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) t.columns.push_back(c);
  }
  if (kept_text) *kept_text = line + "\n";
  while (std::getline(in, line)) {
    if (in.eof()) break;  // no newline: the row was cut short
    std::vector<double> row;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) row.push_back(std::strtod(c.c_str(), nullptr));
    if (row.size() != t.columns.size() || row[0] > static_cast<double>(max_step)) break;
    t.rows.push_back(std::move(row));
    if (kept_text) *kept_text += line + "\n";
  }
  return t;
}

// One stage's files and bookkeeping: series rows, checkpoints, stop requests, progress.
class StageOutput {
 public:
  StageOutput(const Deck& deck, const RunOptions& options, const Model& model, const std::string& stage,
              std::int64_t output_interval, double elapsed_before, bool check_energy = false)
      : check_energy_(check_energy), deck_(deck), options_(options), model_(model), stage_(stage), dir_(fs::path(options.out_dir) / stage),
        output_interval_(output_interval), di_(kDilatancyWindow),
        progress_(stage, options.progress), elapsed_before_(elapsed_before),
        start_(std::chrono::steady_clock::now()) {}

  ~StageOutput() {
    if (series_) std::fclose(series_);
  }

  // Fresh stage: new series with its first row. Resumed: keep the rows up to the checkpoint.
  void open(const State& state, bool resumed) {
    fs::create_directories(dir_);
    const fs::path path = dir_ / "series.csv";
    if (resumed && fs::exists(path)) {
      std::string kept;
      const SeriesTable t = read_series(path, state.control.stage_step, &kept);
      write_text_atomic(path, kept);
      const int e1 = t.column("e1"), ev = t.column("ev");
      for (const auto& row : t.rows) di_.add(row[e1], row[ev]);
      series_ = std::fopen(path.c_str(), "ab");
    } else {
      series_ = std::fopen(path.c_str(), "wb");
      if (series_) std::fputs(series_header().c_str(), series_);
    }
    if (!series_) throw RunError(path.string() + ": cannot write");
    start_step_ = state.control.stage_step;
    if (!resumed) write_row(state);
  }

  // After every step. Returns true when the next step must rebuild the neighbour list (after a checkpoint,
  // so that a resumed run does the same). Throws Interrupted after a stop request, once checkpointed.
  bool after_step(const State& state, double fraction, const std::string& extra = "") {
    const std::int64_t s = state.control.stage_step;
    if (!std::isfinite(state.normal_stress.sum()) || !std::isfinite(state.cell.h.sum()))  // cheap, every step
      throw RunError("non-finite stress or cell in stage '" + stage_ + "' at step " + std::to_string(s) +
                     " (time step too large or loading too fast?); the last checkpoint holds the last good state");
    if (s % output_interval_ == 0) write_row(state);
    progress_.update(s, fraction, extra);
    if (g_stop_requested) {
      checkpoint(state);
      progress_.finish();
      throw Interrupted("stopped by a signal in stage '" + stage_ + "' at step " + std::to_string(s) +
                        "; a checkpoint was written. Continue with: celldem run " + deck_.source + " --out " +
                        options_.out_dir + " --resume");
    }
    if (s % deck_.checkpoint_interval == 0) {
      checkpoint(state);
      return true;
    }
    return false;
  }

  void finish(const State& state) {
    if (state.control.stage_step % output_interval_ != 0) write_row(state);
    std::fflush(series_);
    progress_.finish();
  }

  double elapsed() const {
    return elapsed_before_ + std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  std::int64_t steps_this_segment(const State& state) const { return state.control.stage_step - start_step_; }
  const fs::path& dir() const { return dir_; }

 private:
  void write_row(const State& state) {
    check_motion(state);
    const std::vector<double> row = measure_series_row(model_, state, di_);
    for (int k : {6, 7, 8, 20})  // stresses and Zm: trouble shows here first
      if (!std::isfinite(row[k]))
        throw RunError("non-finite values in stage '" + stage_ + "' at step " +
                       std::to_string(state.control.stage_step) +
                       " (unstable time step or loading?); the last checkpoint holds the last good state");
    const std::string line = format_series_row(row);
    std::fwrite(line.data(), 1, line.size(), series_);
  }

  // An explicit scheme has left its stable range when a particle moves a sizeable part of its radius in a
  // single step (quasi-static motion is orders of magnitude below this).
  void check_motion(const State& state) {
    const Particles& p = state.particles;
    double worst = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i)
      worst = std::max(worst, p.velocity[i].norm() * model_.dt / p.radius[i]);
    if (check_energy_) {
      // In a quasi-static test the packing's motion carries far less energy than its springs store (about
      // 1e-5 of it at the paper's settings). More kinetic than elastic energy means the scheme is unstable
      // or the loading is dynamic: the packing boils instead of deforming.
      // Only growth counts: a test may start from a packing that is still settling (kinetic energy decays).
      const double ke = kinetic_energy(model_, state), ee = elastic_energy(model_, state);
      const bool growing = previous_kinetic_energy_ >= 0.0 && ke > 2.0 * previous_kinetic_energy_;
      previous_kinetic_energy_ = ke;
      if (growing && !(ke <= kMaxKineticToElastic * ee)) {
        char buf[128];
        std::snprintf(buf, sizeof buf, "kinetic energy %.3g J exceeds %.3g x the elastic energy %.3g J", ke,
                      kMaxKineticToElastic, ee);
        throw RunError("runaway kinetic energy in stage '" + stage_ + "' at step " +
                       std::to_string(state.control.stage_step) + ": " + buf +
                       " - time step too large (try <= 0.3 sqrt(m_min/kn)), damping too low or loading too fast; "
                       "the last checkpoint holds the last good state");
      }
    }
    if (!(worst <= kMaxStepMotion)) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "a particle moves %.3g of its radius per step (limit %.3g)", worst, kMaxStepMotion);
      throw RunError("runaway motion in stage '" + stage_ + "' at step " + std::to_string(state.control.stage_step) +
                     ": " + buf + " - time step too large, damping too low or loading too fast; the last "
                     "checkpoint holds the last good state");
    }
  }

  void checkpoint(const State& state) {
    std::fflush(series_);
    write_state((dir_ / kCheckpoint).string(), state, "stage:" + stage_);
    const std::lock_guard<std::mutex> lock(g_run_files);
    Json progress = fs::exists(fs::path(options_.out_dir) / kProgress)
                        ? read_json(fs::path(options_.out_dir) / kProgress) : Json::object();
    progress["elapsed"][stage_] = elapsed();
    write_text_atomic(fs::path(options_.out_dir) / kProgress, progress.dump(2));
  }

  bool check_energy_;  // loading tests only: a preparation starts as a gas
  double previous_kinetic_energy_ = -1.0;  // at the last row; negative: no row yet
  const Deck& deck_;
  const RunOptions& options_;
  const Model& model_;
  std::string stage_;
  fs::path dir_;
  std::int64_t output_interval_;
  DilatancyWindow di_;
  Progress progress_;
  double elapsed_before_;
  std::chrono::steady_clock::time_point start_;
  std::int64_t start_step_ = 0;
  std::FILE* series_ = nullptr;
};

// ---- preparation: fast strain-controlled compression, then the stress servo to equilibrium ----

Loading isotropic_strain(double increment, double friction) {
  AxisControl a{AxisMode::StrainIncrement, increment};
  return {{a, a, a}, friction};
}

Loading isotropic_stress(double pressure, double friction) {
  AxisControl a{AxisMode::Stress, pressure};
  return {{a, a, a}, friction};
}

bool in_equilibrium(const Model& model, const State& state, const PrepareDef& prep, std::string* why) {
  const EquilibriumDef& eq = prep.equilibrium;
  const double p = state.normal_stress.sum() / 3.0;
  const double p_err = std::abs(p - prep.target_pressure) / prep.target_pressure;
  double s_err = 0.0;
  for (int k = 0; k < 3; ++k) s_err = std::max(s_err, std::abs(state.normal_stress[k] - prep.target_pressure) / prep.target_pressure);
  const double ufr = state.touching ? unbalanced_force_ratio(model, state) : 1.0;
  char buf[160];
  std::snprintf(buf, sizeof buf, "p %.1f kPa  |dp| %.2g  max|ds| %.2g  unbalanced %.2g", p / 1e3, p_err, s_err, ufr);
  *why = buf;
  return state.touching > 0 && p_err <= eq.pressure_tolerance && s_err <= eq.stress_tolerance &&
         ufr <= eq.unbalanced_force_ratio;
}

void run_preparation(const Deck& deck, const RunOptions& options, Json& summary, State& state,
                     bool resumed, double elapsed_before) {
  const PrepareDef& prep = *deck.prepare;
  const Model model = make_model(deck, state.particles.radius);
  if (!resumed) {
    evaluate_forces(model, prep.friction, state);
  }
  StageOutput out(deck, options, model, "prepare", prep.output_interval, elapsed_before);
  out.open(state, resumed);
  const Loading fast = isotropic_strain(prep.fast_strain_increment, prep.friction);
  const Loading servo = isotropic_stress(prep.target_pressure, prep.friction);
  bool rebuild = true;
  std::string status = "fast compression";
  for (;;) {
    ControlState& c = state.control;
    if (c.phase == 0 && model.solid_volume / state.cell.volume() >= prep.fast_solid_fraction) {
      c.phase = 1;  // the servo takes over; strains stay relative to the stage start
      c.step = 0;
    }
    step(model, c.phase == 0 ? fast : servo, state, rebuild);
    ++c.stage_step;
    if (c.phase == 1 && c.step % prep.equilibrium.check_interval == 0) {
      const bool done = in_equilibrium(model, state, prep, &status) && c.step >= prep.equilibrium.min_steps;
      if (done) break;
      if (c.step >= prep.equilibrium.max_steps)
        throw RunError("preparation did not reach equilibrium in " + std::to_string(c.step) +
                       " servo steps (" + status + "); raise prepare.equilibrium.max_steps or relax its tolerances");
    }
    rebuild = out.after_step(state, -1.0, status);
  }
  out.finish(state);
  write_state((fs::path(options.out_dir) / kPrepared).string(), state, "prepared");

  const Coordination z = coordination(state);
  const double wall = out.elapsed();
  summary["prepared"] = {{"void_ratio", void_ratio(model, state)},
                         {"Z", z.z},
                         {"Zm", z.z_mechanical},
                         {"rattlers", z.rattlers},
                         {"p", state.normal_stress.sum() / 3.0},
                         {"s11", state.normal_stress[0]},
                         {"s22", state.normal_stress[1]},
                         {"s33", state.normal_stress[2]},
                         {"unbalanced_force", unbalanced_force_ratio(model, state)},
                         {"steps", state.control.stage_step},
                         {"wall_s", wall},
                         {"particle_steps_per_s",
                          wall > 0 ? static_cast<double>(state.particles.size()) * state.control.stage_step / wall : 0.0},
                         {"equilibrium_criterion",
                          "every " + std::to_string(prep.equilibrium.check_interval) +
                              " servo steps after at least " + std::to_string(prep.equilibrium.min_steps) +
                              ": |p - target|/target <= " + std::to_string(prep.equilibrium.pressure_tolerance) +
                              ", each |s_kk - target|/target <= " + std::to_string(prep.equilibrium.stress_tolerance) +
                              ", mean |net contact force| / mean normal force <= " +
                              std::to_string(prep.equilibrium.unbalanced_force_ratio)}};
}

// ---- loading tests ----

std::int64_t test_steps(const Deck& deck, const TestDef& t) {
  const AxisControl& a = t.axes[t.end_axis];
  const double per_step = a.mode == AxisMode::StrainRate ? a.value * deck.time_step : a.value;
  const auto n = static_cast<std::int64_t>(std::llround(t.end_strain / per_step));
  return t.max_steps > 0 ? std::min(n, t.max_steps) : n;
}

// Inertial number I = rate d_mean sqrt(rho / p) of the fastest strain-driven axis at the target or
// current mean stress: above ~1e-3 a test is no longer quasi-static.
double inertial_number(const Deck& deck, const TestDef& test, double mean_stress) {
  double rate = 0.0;
  for (const AxisControl& a : test.axes) {
    if (a.mode == AxisMode::StrainIncrement) rate = std::max(rate, std::abs(a.value) / deck.time_step);
    if (a.mode == AxisMode::StrainRate) rate = std::max(rate, std::abs(a.value));
  }
  double d_mean = 0.0;
  for (double d : deck.sample.diameters) d_mean += d / deck.sample.diameters.size();
  return mean_stress > 0.0 ? rate * d_mean * std::sqrt(deck.sample.density / mean_stress) : INFINITY;
}

Json test_summary(const Deck& deck, const TestDef& test, const fs::path& series, double wall, std::int64_t steps,
                  std::size_t particles, std::vector<std::string>& warnings) {
  const SeriesTable t = read_series(series, INT64_MAX);
  const int ratio = t.column("ratio13"), e1 = t.column("e1"), b = t.column("b"), p = t.column("p");
  std::size_t peak = 0;
  for (std::size_t r = 0; r < t.rows.size(); ++r)
    if (t.rows[r][ratio] > t.rows[peak][ratio]) peak = r;
  auto num = [](double x) { return std::isfinite(x) ? Json(x) : Json(nullptr); };
  // How well the servo held its targets: the largest relative error over the rows after the first 2 %.
  double servo_error = 0.0;
  const char* stress_columns[3] = {"s11", "s22", "s33"};
  for (int k = 0; k < 3; ++k) {
    if (test.axes[k].mode != AxisMode::Stress) continue;
    const int c = t.column(stress_columns[k]);
    for (std::size_t r = t.rows.size() / 50 + 1; r < t.rows.size(); ++r)
      servo_error = std::max(servo_error, std::abs(t.rows[r][c] / test.axes[k].value - 1.0));
  }
  double mean_p = 0.0;
  for (const auto& row : t.rows) mean_p += row[p] / t.rows.size();
  const double inertia = inertial_number(deck, test, mean_p);
  if (servo_error > kServoTolerance)
    warnings.push_back("test '" + test.name + "': the servo missed its target by up to " +
                       std::to_string(100 * servo_error) + " % (tolerance 0.5 %): lower the strain rate or raise "
                       "servo.gain / servo.integral_gain");
  if (inertia > kQuasiStaticInertia)
    warnings.push_back("test '" + test.name + "': inertial number " + std::to_string(inertia) +
                       " exceeds the quasi-static limit 1e-3: results depend on the loading rate");
  return {{"peak_ratio13", num(t.rows[peak][ratio])},
          {"servo_max_error", servo_error},
          {"inertial_number", inertia},
          {"e1_at_peak", num(t.rows[peak][e1])},
          {"b_at_peak", num(t.rows[peak][b])},
          {"b_final", num(t.rows.back()[b])},
          {"final_e1", num(t.rows.back()[e1])},
          {"steps", steps},
          {"wall_s", wall},
          {"particle_steps_per_s", wall > 0 ? static_cast<double>(particles) * steps / wall : 0.0}};
}

void run_test(const Deck& deck, const RunOptions& options, const TestDef& test, const fs::path& prepared,
              Json& summary, bool resumed, double elapsed_before) {
  State state;
  if (resumed) {
    state = read_state((fs::path(options.out_dir) / test.name / kCheckpoint).string());
  } else {
    state = read_state(prepared.string());
    state.control = ControlState{};
    state.control.reference_lengths = state.cell.h.diagonal();
    state.control.reference_volume = state.cell.volume();
  }
  const Model model = make_model(deck, state.particles.radius);
  state.pairs.skin = skin_length(deck);  // the deck's, not the preparing run's
  const Loading loading{test.axes, test.friction};
  if (!resumed) {  // the stage's first row measures the state as loaded, with this test's friction
    evaluate_forces(model, test.friction, state);
  }
  const std::int64_t total = test_steps(deck, test);
  StageOutput out(deck, options, model, test.name, test.output_interval, elapsed_before, /*check_energy=*/true);
  out.open(state, resumed);
  bool rebuild = true;
  while (state.control.stage_step < total) {
    step(model, loading, state, rebuild);
    ++state.control.stage_step;
    rebuild = out.after_step(state, static_cast<double>(state.control.stage_step) / total);
  }
  out.finish(state);
  write_state((out.dir() / "final.state").string(), state, "test:" + test.name);
  std::vector<std::string> warnings;
  const Json result =
      test_summary(deck, test, out.dir() / "series.csv", out.elapsed(), total, state.particles.size(), warnings);
  {
    const std::lock_guard<std::mutex> lock(g_run_files);
    summary["tests"][test.name] = result;
  }
  for (const std::string& w : warnings) add_warning(summary, w);
}

// ---- the run directory ----

bool holds_results(const fs::path& dir, const Deck& deck) {
  for (const char* name : {kSummary, kProgress, kPrepared})
    if (fs::exists(dir / name)) return true;
  if (fs::exists(dir / "prepare")) return true;
  for (const TestDef& t : deck.tests)
    if (fs::exists(dir / t.name)) return true;
  return false;
}

void clear_results(const fs::path& dir, const Deck& deck) {
  for (const char* name : {kSummary, kProgress, kPrepared}) fs::remove(dir / name);
  fs::remove_all(dir / "prepare");
  for (const TestDef& t : deck.tests) fs::remove_all(dir / t.name);
}

Json settings_of(const Deck& deck, int threads) {
  return {{"deck", deck.source},
          {"particles", deck.sample.count},
          {"diameters_m", deck.sample.diameters},
          {"density", deck.sample.density},
          {"seed", deck.sample.seed},
          {"time_step", deck.time_step},
          {"kn", deck.contact.kn},
          {"kt", deck.contact.kt},
          {"tangential_rotation", deck.contact.rotation == TangentialRotation::Rotate ? "rotate" : "project"},
          {"moment_arm", deck.contact.moment_arm == MomentArm::ContactPoint ? "contact_point" : "radius"},
          {"kinematics", deck.kinematics == Kinematics::Affine ? "affine" : "lammps"},
          {"damping_translational", deck.damping.translational},
          {"damping_rotational", deck.damping.rotational},
          {"servo_gain", deck.servo.gain},
          {"servo_integral_gain", deck.servo.integral_gain},
          {"servo_max_strain_increment", deck.servo.max_strain_increment},
          {"threads", threads}};
}

}  // namespace

void install_stop_handlers() {
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
}

void run_deck(const Deck& deck, const RunOptions& options) {
  const fs::path dir(options.out_dir);
  if (options.threads > 0) omp_set_num_threads(options.threads);
  const int threads = omp_get_max_threads();

  Json progress = Json::object();
  Json summary;
  if (options.resume) {
    if (!fs::exists(dir / kProgress))
      throw RunError(dir.string() + " holds no interrupted run to resume (no " + kProgress + ")");
    progress = read_json(dir / kProgress);
    if (progress.value("deck", std::string()) != deck.canonical)
      throw RunError("--resume: the deck differs from the one this run was started with");
    summary = fs::exists(dir / kSummary) ? read_json(dir / kSummary) : Json::object();
  } else {
    if (fs::exists(dir) && holds_results(dir, deck)) {
      if (!options.force)
        throw RunError(dir.string() + " already holds results; use --force to overwrite them or --resume to "
                       "continue an interrupted run");
      clear_results(dir, deck);
    }
    fs::create_directories(dir);
    progress = {{"deck", deck.canonical}, {"completed", Json::array()}, {"elapsed", Json::object()}};
    write_text_atomic(dir / kProgress, progress.dump(2));
  }
  // Validation refuses dt above sqrt(m_min/kn); below it, the measured stability map (results/study) shows
  // results drifting from about 0.55 of it and boiling from 0.65 (tangential and rotational modes with
  // kt ~ kn), so a warning names the risk before any work.
  const double dt_ratio = deck.time_step / critical_time_step(deck.sample, deck.contact.kn);
  if (dt_ratio > kStableTimeStepFraction) {
    const std::string w = "time_step is " + std::to_string(dt_ratio) + " of sqrt(m_min/kn); results drift above "
                          "about 0.55 of it and the packing boils above 0.65 (measured): use <= 0.5";
    add_warning(summary, w);
  }
  summary["celldem_version"] = "0.1.0";
  summary["deck"] = deck.source;
  summary["settings"] = settings_of(deck, threads);

  // Each stage checkpoints into its own folder; an unfinished stage with a checkpoint resumes from it.
  auto resumes = [&](const std::string& stage) { return options.resume && fs::exists(dir / stage / kCheckpoint); };
  auto completed = [&](const std::string& stage) {
    for (const auto& s : progress["completed"]) if (s == stage) return true;
    return false;
  };
  // Order matters for a kill at any moment: the summary first, then the stage marked complete, then its
  // checkpoint removed. Killed in between, a resume re-runs the stage's tail from the checkpoint.
  auto mark_done = [&](const std::string& stage) {
    const std::lock_guard<std::mutex> lock(g_run_files);
    write_text_atomic(dir / kSummary, summary.dump(2));
    progress = read_json(dir / kProgress);
    progress["completed"].push_back(stage);
    write_text_atomic(dir / kProgress, progress.dump(2));
    fs::remove(dir / stage / kCheckpoint);
  };
  auto elapsed_of = [&](const std::string& stage) {
    const std::lock_guard<std::mutex> lock(g_run_files);
    const Json p = read_json(dir / kProgress);
    return p["elapsed"].value(stage, 0.0);
  };

  const double skin = skin_length(deck);
  fs::path prepared;
  if (deck.prepare) {
    prepared = dir / kPrepared;
    if (!completed("prepare")) {
      const bool resumed = resumes("prepare");
      State state = resumed ? read_state((dir / "prepare" / kCheckpoint).string()) : make_grid_sample(deck.sample, skin);
      if (!options.quiet) std::printf("prepare: %d spheres, isotropic compression to %g Pa\n", deck.sample.count,
                                      deck.prepare->target_pressure);
      run_preparation(deck, options, summary, state, resumed, resumed ? elapsed_of("prepare") : 0.0);
      mark_done("prepare");
      if (!options.quiet)
        std::printf("prepare: done in %lld steps, %.1f s: void ratio %.4f, Z %.3f\n",
                    static_cast<long long>(summary["prepared"]["steps"].get<std::int64_t>()),
                    summary["prepared"]["wall_s"].get<double>(), summary["prepared"]["void_ratio"].get<double>(),
                    summary["prepared"]["Z"].get<double>());
    }
  } else {
    prepared = fs::path(deck.source).parent_path() / *deck.initial_state;
    if (!fs::exists(prepared)) throw DeckError("initial_state: no such file " + prepared.string());
    summary["initial_state"] = prepared.string();
  }

  // The tests start from the same prepared state and do not depend on each other: with more threads than
  // one, several run side by side, each with its share of the threads (one thread per test on two cores
  // does more work than two threads per test, one after the other). Results do not depend on the thread
  // count, so they are the same bytes either way.
  std::vector<const TestDef*> pending;
  for (const TestDef& test : deck.tests)
    if (!completed(test.name)) pending.push_back(&test);
  const std::size_t side_by_side = std::max<std::size_t>(1, std::min<std::size_t>(pending.size(), threads));
  auto run_one = [&](const TestDef& test, int test_threads) {
    omp_set_num_threads(test_threads);
    const bool resumed = resumes(test.name);
    if (!options.quiet) std::printf("%s: %s (%d thread%s)\n", test.name.c_str(), resumed ? "resuming" : "starting",
                                    test_threads, test_threads > 1 ? "s" : "");
    run_test(deck, options, test, prepared, summary, resumed, resumed ? elapsed_of(test.name) : 0.0);
    mark_done(test.name);
    if (!options.quiet) {
      const std::lock_guard<std::mutex> lock(g_run_files);
      const Json& s = summary["tests"][test.name];
      std::printf("%s: done in %.1f s (%.3g particle-steps/s): peak s1/s3 %.4f at e1 %.4f\n", test.name.c_str(),
                  s["wall_s"].get<double>(), s["particle_steps_per_s"].get<double>(),
                  s["peak_ratio13"].is_null() ? NAN : s["peak_ratio13"].get<double>(),
                  s["e1_at_peak"].is_null() ? NAN : s["e1_at_peak"].get<double>());
    }
  };
  for (std::size_t first = 0; first < pending.size(); first += side_by_side) {
    const std::size_t group = std::min(side_by_side, pending.size() - first);
    // One std::thread per test, each its own OpenMP team. A failure or a stop request in one does not
    // cut the others short: each finishes or checkpoints, then the first error is reported.
    std::vector<std::exception_ptr> errors(group);
    std::vector<std::thread> workers;
    for (std::size_t k = 0; k < group; ++k) {
      const int test_threads = threads / static_cast<int>(group) + (static_cast<int>(k) < threads % static_cast<int>(group));
      workers.emplace_back([&, k, test_threads] {
        try {
          run_one(*pending[first + k], test_threads);
        } catch (...) {
          errors[k] = std::current_exception();
        }
      });
    }
    for (std::thread& w : workers) w.join();
    for (const std::exception_ptr& e : errors)
      if (e) std::rethrow_exception(e);
  }
  write_text_atomic(dir / kSummary, summary.dump(2));
}

}  // namespace celldem
