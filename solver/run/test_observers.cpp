#include "run/test_observers.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <thread>

#include "cell/control.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "io/files.hpp"
#include "io/snapshot.hpp"
#include "io/state_file.hpp"
#include "io/tolerance.hpp"
#include "measure/micro.hpp"
#include "run/driven_measure.hpp"
#include "run/energy_report.hpp"
#include "run/preflight.hpp"
#include "run/probes.hpp"
#include "run/run_directory.hpp"
#include "run/run_options.hpp"
#include "run/summary.hpp"
#include "run/verify_rate.hpp"
#include "step.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

std::vector<StageObserver*> StageObservers::list() const {
  std::vector<StageObserver*> out;
  for (const std::unique_ptr<StageObserver>& o : owned_) out.push_back(o.get());
  return out;
}

namespace {

// Snapshots at the stage's start, every `interval` steps, at each strain e1 of the list (the first step reaching
// it: e1 >= a strain >= 0, e1 <= a negative one, as the probes' at_e1 points) and at its end.
class Snapshots : public StageObserver {
 public:
  Snapshots(const fs::path& stage_dir, const std::string& stage, const SnapshotDef& plan, double dt)
      : plan_(plan), dt_(dt), writer_(stage_dir / "snapshots", stage, plan.format), taken_(plan.e1.size(), false) {}
  void on_start(const State& state) override { write_if_due(state, /*force=*/true); }
  // Strain snapshots already passed at the checkpoint are not repeated: judged on the checkpoint's own strain (as
  // write_if_due judges it) and on its rows', not on its last row's alone, which may lie before the snapshot's step.
  void on_resume(const State& state, const std::vector<SeriesRow>& rows) override {
    take_reached(strain1(state));
    for (const SeriesRow& row : rows) take_reached(row.e1);
  }
  void on_step(const State& state) override { write_if_due(state, false); }
  void on_finish(const State& state, const std::vector<SeriesRow>&) override {
    writer_.write(state, state.control.stage_steps, state.control.stage_steps * dt_);
  }

 private:
  static double strain1(const State& state) { return 1.0 - state.cell.h(0, 0) / state.control.reference[0]; }
  // Marks the strains e1 reaches that were not yet taken; whether there was one.
  bool take_reached(double e1) {
    bool any = false;
    for (std::size_t k = 0; k < plan_.e1.size(); ++k) {
      const double target = plan_.e1[k];
      if (!taken_[k] && (target >= 0.0 ? e1 >= target : e1 <= target)) taken_[k] = true, any = true;
    }
    return any;
  }
  void write_if_due(const State& state, bool force) {
    const std::int64_t s = state.control.stage_steps;
    bool due = force || (plan_.interval > 0 && s % plan_.interval == 0);
    if (take_reached(strain1(state))) due = true;
    if (due) writer_.write(state, s, static_cast<double>(s) * dt_);
  }

  SnapshotDef plan_;
  double dt_;
  SnapshotWriter writer_;
  std::vector<bool> taken_;  // per strain of plan_.e1: its snapshot was written
};

// The contact network of the row with the largest value of the test's driven measure so far (the peak so far), for
// the report's force-chain picture: kept in memory and written (peak_contacts.csv and .json) at the next checkpoint
// or when the stage ends: a test's rising part makes a new peak at every row, and formatting each one's contacts
// cost about a tenth of a short run's time.
class PeakContacts : public StageObserver {
 public:
  PeakContacts(const fs::path& stage_dir, TestMeasure measure) : dir_(stage_dir), peak_(measure) {}
  void on_resume(const State&, const std::vector<SeriesRow>& rows) override { peak_.seen(rows); }
  void on_row(const State& state, const SeriesRow& row) override {
    if (peak_.offer(row)) keep(state, row);
  }
  void on_checkpoint(const State&) override { write(); }
  void on_finish(const State&, const std::vector<SeriesRow>&) override { write(); }

 private:
  struct Network {
    std::vector<std::array<double, 7>> rows;  // x_i, y_i, z_i, x_j, y_j, z_j, normal force
    std::vector<char> sliding;
    Json meta;
  };
  void keep(const State& state, const SeriesRow& row);
  void write();

  fs::path dir_;
  PeakTracker peak_;
  std::optional<Network> unwritten_;  // kept since the last write
};

void PeakContacts::keep(const State& state, const SeriesRow& row) {
  Network peak;
  for (const ContactSnapshot& c : touching_contacts(state)) {
    const Vec3 a = wrapped_position(state.cell, state.particles.scaled[c.i]), b = a + c.branch;
    peak.rows.push_back({a[0], a[1], a[2], b[0], b[1], b[2], c.normal_force});
    peak.sliding.push_back(c.sliding ? 1 : 0);
  }
  const Mat3& h = state.cell.h;
  peak.meta = {{"step", state.control.stage_steps}, {"e1", row.e1}, {"ratio13", row.ratio13},
               {"cell", {{h(0, 0), h(0, 1), h(0, 2)}, {h(1, 0), h(1, 1), h(1, 2)}, {h(2, 0), h(2, 1), h(2, 2)}}},
               {"columns", "contact from the wrapped centre of i to the image of j; normal force [N]"}};
  const TestMeasure& m = peak_.measure();
  if (m.kind == TestMeasure::Kind::Extension || m.kind == TestMeasure::Kind::Shear) {  // (s11/s33: ratio13 says it)
    peak.meta["measure"] = measure_name(m);
    peak.meta["value"] = driven_value(m, row);
    peak.meta[strain_name(m)] = driven_strain(m, row);
  }
  unwritten_ = std::move(peak);
}

void PeakContacts::write() {
  if (!unwritten_) return;
  std::string text = "x_i,y_i,z_i,x_j,y_j,z_j,normal_force,sliding\n";
  char buf[256];
  for (std::size_t k = 0; k < unwritten_->rows.size(); ++k) {
    const std::array<double, 7>& r = unwritten_->rows[k];
    std::snprintf(buf, sizeof buf, "%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%d\n", r[0], r[1], r[2], r[3], r[4], r[5],
                  r[6], unwritten_->sliding[k]);
    text += buf;
  }
  write_file_atomic(dir_ / "peak_contacts.csv", text);
  write_file_atomic(dir_ / "peak_contacts.json", unwritten_->meta.dump(1));
  unwritten_.reset();
}

// A test's probes (run/probes.hpp): its points' states kept as it runs (ProbePoints), then after the test each point
// rested and probed; the result is summary.json's probes of the test, a point that could not be probed a warning.
class Probes : public StageObserver {
 public:
  Probes(const RunContext& context, const TestDef& test)
      : context_(context), test_(test), points_(*test.probes, driven_measure(test)) {
    points_.keep_in(context.run.stage_dir(test.name) / "probes", test.name, state_physics(context.deck));
  }
  void on_resume(const State&, const std::vector<SeriesRow>& rows) override { points_.resume(rows); }
  void on_row(const State& state, const SeriesRow& row) override { points_.on_row(state, row); }
  void on_checkpoint(const State& state) override { points_.save(state); }
  void on_finish(const State& state, const std::vector<SeriesRow>& rows) override { points_.finish(state, rows.back()); }
  std::optional<ObserverReport> after_test(const FinishedTest& done) override {
    ObserverReport report{"probes",
                          run_test_probes(context_.run, context_.deck, context_.options, test_, points_,
                                          done.summary.peak_reached, done.summary.peak.evidence),
                          {},
                          {}};
    for (const auto& [point, p] : report.value["points"].items()) {
      if (p.value("status", "") == "not run")  // a point that could not be probed is a warning
        report.warnings.push_back(test_.name + ": the probes at " + point + " were not run: " + p.value("reason", ""));
      if (p.value("status", "") != "ran")  // named with its reason
        report.console.push_back("probes at " + point + ": " + p.value("status", "") + (p.contains("reason") ? ": " : "") +
                                 p.value("reason", ""));
    }
    return report;
  }

 private:
  RunContext context_;
  const TestDef& test_;
  ProbePoints points_;
};

// A rate check's verdict for the console: per quantity its distance from I -> 0 in floors with its bounds, the
// fitted order, and its verdict; then the test's.
std::vector<std::string> rate_check_lines(const RateCheckResult& r) {
  std::vector<std::string> lines;
  char buf[512];
  std::string rungs;
  for (const double f : r.rungs) rungs += (rungs.empty() ? "" : ", ") + fmt3(f);
  std::snprintf(buf, sizeof buf, "rate check by a ladder (rungs %s x the rate, %d twins), tolerance %g floors (95 %%)",
                rungs.c_str(), r.twins, r.tolerance);
  lines.push_back(buf);
  for (const QuantityLadder& l : r.quantities) {
    if (l.verdict == "not compared") {
      lines.push_back("  " + l.path + ": not compared (" + l.reason + ")");
      continue;
    }
    std::snprintf(
        buf, sizeof buf, "  %-20s distance from I -> 0 %+7.2f floors [%+.2f, %+.2f], order %.2f [%.2f, %.2f]: %s",
        l.path.c_str(), l.error_floors, l.lo_floors, l.hi_floors, l.order, l.order_lo, l.order_hi, l.verdict.c_str());
    lines.push_back(buf);
  }
  lines.push_back("rate check: " + r.verdict + ": " + r.reason);
  return lines;
}

// The rate check (run/verify_rate.hpp): after the test, the same test from its own start at a slower rate and a twin.
class RateCheck : public StageObserver {
 public:
  RateCheck(const RunContext& context, const TestDef& test, const TestStart& start, const VerifyRateOptions& check)
      : context_(context), test_(test), start_(start), check_(check) {
    if (!context.options.quiet) {  // its cost, before anything runs, at the plan's speed on the run's threads
      const int threads = context.options.threads > 0
                              ? context.options.threads
                              : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
      const double speed = kParticleStepsPerCoreSecond * threads;
      std::printf("%s: rate check after the test, by a ladder of rates (estimated at %.3g particle-steps/s):\n",
                  test.name.c_str(), speed);
      for (const std::string& line : rate_check_cost(context.deck, test, check, speed).lines())
        std::printf("%s\n", line.c_str());
    }
  }
  std::optional<ObserverReport> after_test(const FinishedTest& done) override;

 private:
  RunContext context_;
  const TestDef& test_;
  TestStart start_;
  VerifyRateOptions check_;
};

std::optional<ObserverReport> RateCheck::after_test(const FinishedTest& done) {
  const Deck& deck = context_.deck;
  if (!context_.options.quiet) {  // again at the test's own speed
    std::printf("%s: rate check, at the test's speed:\n", test_.name.c_str());
    for (const std::string& line : rate_check_cost(deck, test_, check_, done.summary.particle_steps_per_s).lines())
      std::printf("%s\n", line.c_str());
  }
  // The test's own start, resumed or not: the prepared state (or the initial state without a preparation), its
  // stage begun, the deck's skin, its forces evaluated (the first row: the state as loaded).
  State state = deck.initial_state && !deck.prepare ? load_initial_state(deck) : read_state(start_.prepared.string());
  begin_stage(state);
  state.pairs.skin = skin_length(deck);  // the deck's, not the preparing run's
  evaluate_forces(start_.model, test_.stage_friction(), state);
  const RateCheckResult result =
      verify_test_rate(context_.run, deck, context_.options, test_, check_, state, done.summary);
  ObserverReport report{"verify_rate", result.to_json(), {}, {}};
  report.console = rate_check_lines(result);
  return report;
}

}  // namespace

namespace {
// The test's energy budget (the deck's energy_budget): its totals, per leg, the worst closure error and damping's
// share, from the rows once the test is done (run/energy_report.hpp). The step keeps the totals (State::energy).
class EnergyBudgetReport : public StageObserver {
 public:
  EnergyBudgetReport(std::string test, double dt) : test_(std::move(test)), dt_(dt) {}
  std::optional<ObserverReport> after_test(const FinishedTest& done) override {
    EnergyReport r = energy_report(test_, done.stage.rows, dt_);
    if (r.json.is_null()) return std::nullopt;
    return ObserverReport{"energy", std::move(r.json), std::move(r.warnings), std::move(r.console)};
  }

 private:
  std::string test_;
  double dt_;
};

// --tolerance's promise checked against what the test did: the rules chose its rate from an actual inertial number
// they predicted (io/tolerance actual_to_imposed); the rows measure it (io/tolerance check_tolerance).
class ToleranceReport : public StageObserver {
 public:
  ToleranceReport(std::string test, double tolerance, double particles)
      : test_(std::move(test)), tolerance_(tolerance), particles_(particles) {}
  std::optional<ObserverReport> after_test(const FinishedTest& done) override {
    double actual = 0.0, imposed = 0.0;
    int n = 0;
    for (const SeriesRow& r : done.stage.rows)
      if (r.step > 0 && r.imposed_inertial_number > 0.0)
        actual += r.inertial_number, imposed += r.imposed_inertial_number, ++n;
    ObserverReport out{"tolerance", nullptr, {}, {}};
    if (n == 0) {
      out.value = {{"tolerance", tolerance_}, {"kept", nullptr}, {"reason", "no strain-driven rows to measure"}};
      out.console.push_back("tolerance not checked: no strain-driven rows");
      return out;
    }
    const RateBiasModel& model = time_to_answer_rules().rate_bias;
    const ToleranceCheck c = check_tolerance(model, tolerance_, particles_, actual / n, imposed / n);
    out.value = c.to_json();
    const auto worst = std::max_element(c.distances.begin(), c.distances.end(),
                                        [](const auto& a, const auto& b) { return a.upper < b.upper; });
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "tolerance %g floors %s: the cell's actual inertial number %.3g (the rules allowed %.3g; %.3g times "
                  "the imposed), %s up to %.3g floors from I -> 0",
                  tolerance_, c.kept ? "kept" : "NOT kept", c.inertial_number, c.inertial_number_allowed,
                  c.inertial_number / c.imposed_inertial_number, worst->quantity.c_str(), worst->upper);
    out.console.push_back(buf);
    if (!c.kept)
      out.warnings.push_back(
          "test '" + test_ + "': " + buf +
          ": it ran above the inertial number T allows (its path's actual-to-imposed ratio above the rules' "
          "prediction, or an adaptive rate above its ceiling: summary.json tests." +
          test_ + ".tolerance, tolerance.stages)");
    return out;
  }

 private:
  std::string test_;
  double tolerance_, particles_;
};

}  // namespace

StageObservers observers_for(const RunContext& context, const TestDef& test, const TestStart& start) {
  StageObservers observers;
  const fs::path dir = context.run.stage_dir(test.name);
  observers.add(std::make_unique<PeakContacts>(dir, driven_measure(test)));
  if (test.snapshots.any())
    observers.add(std::make_unique<Snapshots>(dir, test.name, test.snapshots, start.model.dt));
  if (test.probes) observers.add(std::make_unique<Probes>(context, test));
  if (const std::optional<VerifyRateOptions> check = verify_rate_for(context.options.verify_rate, test))
    observers.add(std::make_unique<RateCheck>(context, test, start, *check));
  if (context.deck.energy_budget) observers.add(std::make_unique<EnergyBudgetReport>(test.name, start.model.dt));
  if (context.deck.tolerance)
    observers.add(std::make_unique<ToleranceReport>(test.name, *context.deck.tolerance, context.deck.sample.count));
  return observers;
}

StageObservers preparation_observers(const RunContext& context, const PrepareDef& prepare, const Model& model) {
  StageObservers observers;
  if (prepare.snapshots.any())
    observers.add(std::make_unique<Snapshots>(context.run.stage_dir("prepare"), "prepare", prepare.snapshots, model.dt));
  return observers;
}

}  // namespace celldem
