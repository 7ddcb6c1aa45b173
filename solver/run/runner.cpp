#include "run/runner.hpp"

#include <omp.h>

#include <cmath>
#include <cstdio>
#include <thread>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "core/plan.hpp"
#include "io/state_file.hpp"
#include "measure/micro.hpp"
#include "measure/quasi_static.hpp"
#include "run/health.hpp"
#include "run/preflight.hpp"
#include "run/run_directory.hpp"
#include "run/sample.hpp"
#include "run/stage_runner.hpp"
#include "run/summary.hpp"
#include "run/test_observers.hpp"
#include "step.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// A stage from a loaded state whose overlaps are well above a packing's (its pairs listed): what a runaway
// should name before the time step; empty otherwise.
std::string loaded_overlap_cause(const Deck& deck, const State& state) {
  const Overlaps o = overlaps(state, kLoadedOverlapNote);
  if (o.worst <= kLoadedOverlapNote) return "";
  char buf[320];
  std::snprintf(buf, sizeof buf, "likely cause: the stage started from %s, whose %lld pairs overlapping by more than "
                "%.3g of the smaller radius (the deepest %.3g) release their energy at once (a preparation from it with "
                "prepare.relax_overlaps dilates them away); otherwise ", initial_state_path(deck).c_str(),
                static_cast<long long>(o.deep), kLoadedOverlapNote, o.worst);
  return buf;
}

// The preparation: its load program (by default fast compression, then the servo to equilibrium), from a
// generated sample or (initial_state) from a loaded one, whose program may leave the fast leg out.
PreparationSummary run_preparation(const RunContext& context, State state, bool resumed, const std::vector<Leg>& legs) {
  const Deck& deck = context.deck;
  const PrepareDef& prep = *deck.prepare;
  Model stage_model = make_model(deck, state.particles.radius, deck.stage_time_step(prep));
  stage_model.servo = deck.stage_servo(prep);
  const Model& model = stage_model;
  if (!resumed) evaluate_forces(model, prep.stage_friction(), state);
  const StageObservers observers = preparation_observers(context, prep, model);
  const StageResult result = run_stage(
      context, model,
      {.name = "prepare",
       .kind = StageKind::Preparation,
       .legs = legs,
       .friction = prep.stage_friction(),
       .equilibrium = &prep.equilibrium,
       .equilibrium_key = "prepare.equilibrium",
       .output_interval = prep.output_interval,
       .resumed = resumed,
       .adaptive_threads = !context.options.fixed_threads,
       .control_failure = deck.control_failure,
       .start_cause = !resumed && deck.initial_state ? loaded_overlap_cause(deck, state) : "",
       .final_state = FinalStateFile{context.run.prepared_state().string(), "prepared"}},
      std::move(state), observers.list());
  const PreparationSummary prepared = summarize_preparation(model, result.state, prep, result.elapsed);
  context.run.update_summary([&](Json& s) {  // (a preparation from initial_state: its started_from kept beside)
    Json written = prepared;
    written["network_time_step"] = result.network_time_step;
    if (s.contains("prepared") && s["prepared"].contains("started_from"))
      written["started_from"] = s["prepared"]["started_from"];
    s["prepared"] = written;
  });
  return prepared;
}

Json overlaps_json(const Overlaps& o, const std::vector<std::int64_t>& atom_ids) {
  const auto id = [&](Index i) { return atom_ids.empty() ? static_cast<std::int64_t>(i) : atom_ids[i]; };
  Json j = {{"touching_pairs", o.count}, {"deep_pairs", o.deep}, {"worst", o.worst}};
  if (o.count > 0) j["worst_pair"] = {id(o.worst_i), id(o.worst_j)};
  return j;
}

// What the summary records of a preparation from initial_state: the file, its solid fraction as the
// preparation starts, the overlaps and their relaxation, and a fast leg left out.
Json started_from(const Deck& deck, const PreparationStart& start, int skipped) {
  const OverlapRelaxation& r = start.relaxation;
  Json j = {{"initial_state", initial_state_path(deck)},
            {"solid_fraction", start.solid_fraction},
            {"overlaps", overlaps_json(r.before, start.atom_ids)}};
  if (r.max_overlap > 0.0)
    j["relax_overlaps"] = {{"max_overlap", r.max_overlap}, {"dilation", r.factor},
                           {"overlaps_after", overlaps_json(r.after, start.atom_ids)}};
  if (skipped > 0) j["skipped"] = skipped_fast_leg_note(deck, start.solid_fraction);
  return j;
}

// A finished test: its summary and its observers' results.
struct TestOutcome {
  TestSummary summary;
  std::vector<ObserverReport> reports;
};

// A loading test from the prepared state, or the initial state without a preparation (or from its own checkpoint),
// with its observers (observers_for: snapshots, the peak contacts, probes, the rate check), each of whose results
// after the test goes into its summary.
TestOutcome run_test(const RunContext& context, const TestDef& test, const fs::path& prepared, bool resumed) {
  const Deck& deck = context.deck;
  RunDirectory& run = context.run;
  // With prepare, from the run's prepared state (also when the preparation started from initial_state).
  State state = resumed                              ? read_state(run.checkpoint(test.name).string())
                : deck.initial_state && !deck.prepare ? load_initial_state(deck)
                                                      : read_state(prepared.string());
  if (!resumed) begin_stage(state);
  const Model model = make_model(deck, state.particles.radius, deck.stage_time_step(test));
  state.pairs.skin = skin_length(deck);  // the deck's, not the preparing run's
  if (!resumed) evaluate_forces(model, test.stage_friction(), state);  // the first row: the state as loaded
  const bool loaded = !resumed && deck.initial_state && !deck.prepare;
  const std::string start_cause = (loaded ? loaded_overlap_cause(deck, state) : "") + fast_loading_cause(deck, test);
  const StageObservers observers = observers_for(context, test, {model, prepared, resumed});
  const StageResult result = run_stage(
      context, model,
      {.name = test.name,
       .legs = test.legs,
       .friction = test.stage_friction(),
       .equilibrium = &test.equilibrium,
       .planned_steps = plan_test(deck, test).steps,
       .output_interval = test.output_interval,
       .resumed = resumed,
       .adaptive_threads = !context.options.fixed_threads,
       .control_failure = deck.control_failure,
       .start_cause = start_cause,
       .final_state = FinalStateFile{(run.stage_dir(test.name) / "final.state").string(), "test:" + test.name}},
      std::move(state), observers.list());
  std::vector<std::string> warnings;
  TestOutcome done{summarize_finished_test(deck, test, result, warnings), {}};
  run.update_summary([&](Json& s) {  // (the network's judgement beside the typed summary: run_stage's own)
    Json written = done.summary;
    written["network_time_step"] = result.network_time_step;
    s["tests"][test.name] = written;
  });
  for (const std::string& w : warnings) run.add_warning(w);
  for (StageObserver* o : observers.list())
    if (std::optional<ObserverReport> report = o->after_test({test, result, done.summary})) {
      run.update_summary([&](Json& s) { s["tests"][test.name][report->key] = report->value; });
      for (const std::string& w : report->warnings) run.add_warning(w);
      done.reports.push_back(std::move(*report));
    }
  return done;
}

// A finished test on the console: its time and speed, the peak of its driven measure (or why none was reached),
// whether its controls held, then what its observers say of their results (the probes, the rate check).
void print_test_done(const TestDef& test, const TestOutcome& done) {
  const TestSummary& t = done.summary;
  const char* name = test.name.c_str();
  const TestMeasure& m = t.measure;
  std::printf("%s: done in %.1f s (%.3g particle-steps/s)", name, t.wall_s, t.particle_steps_per_s);
  if (m.kind == TestMeasure::Kind::Shear || m.kind == TestMeasure::Kind::Extension)
    std::printf(": peak %s %.4f at %s %.4f\n", measure_name(m).c_str(), t.peak.value, strain_name(m).c_str(), t.peak.strain);
  else  // s11/s33 (also followed by a test with no peak to reach)
    std::printf(": peak s1/s3 %.4f at e1 %.4f\n", t.peak.value, t.peak.strain);
  if (!t.peak_reached)
    std::printf("%s: no peak reached: %s (its peak quantities are left out of ensemble statistics and fits)\n", name,
                t.peak.evidence.c_str());
  if (!t.controlled)
    std::printf("%s: uncontrolled: a control failed (summary.json control_failures; control_failure \"warn\")\n", name);
  for (const ObserverReport& report : done.reports)
    for (const std::string& line : report.console) std::printf("%s: %s\n", name, line.c_str());
}

}  // namespace

void run_deck(const Deck& deck, const RunOptions& options) {
  if (options.threads > 0) omp_set_num_threads(options.threads);
  const int threads = omp_get_max_threads();
  const std::vector<std::string> warnings = preflight(deck);  // before the run directory is touched
  RunDirectory run(deck, options);

  std::vector<std::string> stages;
  if (deck.prepare) stages.push_back("prepare");
  for (const TestDef& t : deck.tests) stages.push_back(t.name);
  if (options.resume && std::all_of(stages.begin(), stages.end(), [&](const auto& s) { return run.completed(s); })) {
    std::printf("%s: the run is complete; nothing to resume (use --force to run it again)\n",
                options.out_dir.c_str());
    return;
  }
  for (const std::string& w : warnings) run.add_warning(w);
  run.update_summary([&](Json& s) {
    s["celldem_version"] = CELLDEM_VERSION;
    s["deck"] = deck.source;
    s["settings"] = run_settings(deck, threads);
    if (!options.tolerance_prediction.empty()) s["tolerance"] = Json::parse(options.tolerance_prediction);
    if (deck.sample.grading) s["grading"] = grading_json(*deck.sample.grading, run_sample_diameters(deck));
  });

  fs::path prepared;
  if (deck.prepare) {
    prepared = run.prepared_state();
    if (!run.completed("prepare")) {
      const bool resumed = run.resumes("prepare");
      State state;
      std::vector<Leg> legs = deck.prepare->legs;
      if (deck.initial_state) {
        // Loaded (and relaxed) again on a resume too: the program it implies must be the same.
        PreparationStart start = preparation_start(deck);
        const PreparationProgram program = preparation_program(*deck.prepare, start.solid_fraction);
        legs = program.legs;
        run.update_summary([&](Json& s) { s["prepared"] = {{"started_from", started_from(deck, start, program.skipped)}}; });
        if (!options.quiet && !resumed)
          std::printf("%s\n", describe_preparation_start(deck, start, program.skipped).c_str());
        state = resumed ? read_state(run.checkpoint("prepare").string()) : std::move(start.state);
      } else {
        state = resumed ? read_state(run.checkpoint("prepare").string()) : make_grid_sample(deck.sample, skin_length(deck));
      }
      if (!options.quiet)
        std::printf("prepare: %d spheres, isotropic compression to %g Pa\n", deck.sample.count,
                    deck.prepare->target_pressure);
      const PreparationSummary p = run_preparation({run, deck, options}, std::move(state), resumed, legs);
      run.mark_done("prepare");
      if (!options.quiet)
        std::printf("prepare: done in %lld steps, %.1f s: void ratio %.4f, Z %.3f\n", static_cast<long long>(p.steps),
                    p.wall_s, p.void_ratio, p.Z);
    }
  } else {
    prepared = initial_state_path(deck);
    run.update_summary([&](Json& s) { s["initial_state"] = prepared.string(); });
  }

  // The tests start from the same prepared state and do not depend on each other: with more threads than
  // one, several run side by side, each with its share of the threads (one thread per test on two cores
  // does more work than two threads per test, one after the other). Results do not depend on the thread
  // count, so they are the same bytes either way.
  std::vector<const TestDef*> pending;
  for (const TestDef& test : deck.tests)
    if (!run.completed(test.name)) pending.push_back(&test);
  const std::size_t side_by_side = std::max<std::size_t>(1, std::min<std::size_t>(pending.size(), threads));
  auto run_one = [&](const TestDef& test, int test_threads) {
    omp_set_num_threads(test_threads);
    const bool resumed = run.resumes(test.name);
    if (!options.quiet)
      std::printf("%s: %s (%d thread%s)\n", test.name.c_str(), resumed ? "resuming" : "starting", test_threads,
                  test_threads > 1 ? "s" : "");
    const TestOutcome done = run_test({run, deck, options}, test, prepared, resumed);
    run.mark_done(test.name);
    if (!options.quiet) print_test_done(test, done);
  };
  for (std::size_t first = 0; first < pending.size(); first += side_by_side) {
    const std::size_t group = std::min(side_by_side, pending.size() - first);
    // One std::thread per test, each its own OpenMP team. A failure or a stop request in one does not
    // cut the others short: each finishes or checkpoints, then the first error is reported.
    std::vector<std::exception_ptr> errors(group);
    std::vector<std::thread> workers;
    for (std::size_t k = 0; k < group; ++k) {
      const int test_threads =
          threads / static_cast<int>(group) + (static_cast<int>(k) < threads % static_cast<int>(group));
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
  run.write_summary();
}

}  // namespace celldem
