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
#include "run/probes.hpp"
#include "run/program.hpp"
#include "run/run_directory.hpp"
#include "run/sample.hpp"
#include "run/stage_output.hpp"
#include "run/summary.hpp"
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
void run_preparation(RunDirectory& run, const Deck& deck, const RunOptions& options, State& state, bool resumed,
                     const std::vector<Leg>& legs) {
  const PrepareDef& prep = *deck.prepare;
  Model stage_model = make_model(deck, state.particles.radius, deck.stage_time_step(prep));
  stage_model.servo = deck.stage_servo(prep);
  const Model& model = stage_model;
  if (!resumed) evaluate_forces(model, prep.stage_friction(), state);
  StageOutput out(run, deck, options, model, "prepare", prep.output_interval, /*loading_test=*/false, prep.snapshots);
  if (!resumed && deck.initial_state) out.set_start_cause(loaded_overlap_cause(deck, state));
  out.open(state, resumed);
  Program program{legs, prep.stage_friction(), &prep.equilibrium};
  program.adaptive_threads = !options.fixed_threads;
  program.control_failure = deck.control_failure;
  run_program(model, program, state, out, out.control_errors());
  out.finish(state);
  write_state(run.prepared_state().string(), state, "prepared", state_physics(deck));
  const Json prepared = summarize_preparation(model, state, prep, out.elapsed());
  run.update_summary([&](Json& s) {
    const Json from = s.value("prepared", Json::object()).value("started_from", Json());
    s["prepared"] = prepared;
    if (!from.is_null()) s["prepared"]["started_from"] = from;
  });
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

// The state a test starts from: the prepared state (or the initial state without a preparation), its stage
// begun, the deck's skin, its forces evaluated (the first row: the state as loaded).
State test_start_state(const Deck& deck, const TestDef& test, const fs::path& prepared, const Model& model) {
  State state = deck.initial_state && !deck.prepare ? load_initial_state(deck) : read_state(prepared.string());
  begin_stage(state);
  state.pairs.skin = skin_length(deck);  // the deck's, not the preparing run's
  evaluate_forces(model, test.stage_friction(), state);
  return state;
}

// A loading test from the prepared state, or the initial state without a preparation (or from its own checkpoint).
void run_test(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
              const fs::path& prepared, bool resumed) {
  // With prepare, from the run's prepared state (also when the preparation started from initial_state).
  State state = resumed                              ? read_state(run.checkpoint(test.name).string())
                : deck.initial_state && !deck.prepare ? load_initial_state(deck)
                                                      : read_state(prepared.string());
  if (!resumed) begin_stage(state);
  const Model model = make_model(deck, state.particles.radius, deck.stage_time_step(test));
  state.pairs.skin = skin_length(deck);  // the deck's, not the preparing run's
  if (!resumed) evaluate_forces(model, test.stage_friction(), state);  // the first row: the state as loaded
  StageOutput out(run, deck, options, model, test.name, test.output_interval, /*loading_test=*/true, test.snapshots);
  if (!resumed && deck.initial_state && !deck.prepare)
    out.set_start_cause(loaded_overlap_cause(deck, state) + fast_loading_cause(deck, test));
  else
    out.set_start_cause(fast_loading_cause(deck, test));
  out.open(state, resumed);
  const std::optional<VerifyRateOptions> check = verify_rate_for(options.verify_rate, test);
  if (check && !options.quiet)  // its cost, before anything runs
    std::printf("%s: rate check after the test: %s\n", test.name.c_str(),
                rate_check_cost(deck, test, *check, 0.0).words().c_str());
  const ProbeDef no_probes;
  ProbePoints probe_points(test.probes ? *test.probes : no_probes);
  if (test.probes) {
    probe_points.keep_in(out.dir() / "probes", test.name, state_physics(deck));
    if (resumed) probe_points.resume(out.rows());
    else probe_points.on_row(state, out.rows().front());
    out.set_checkpoint_observer([&](const State& s) { probe_points.save(s); });
  }
  if (test.probes) out.set_row_observer([&](const State& s, const SeriesRow& row) { probe_points.on_row(s, row); });
  Program program{test.legs, test.stage_friction(), &test.equilibrium, plan_test(deck, test).steps};
  program.equilibrium_key = "tests[].equilibrium";
  program.adaptive_threads = !options.fixed_threads;
  program.kind = StageKind::Test;
  program.stage = test.name;
  program.control_failure = deck.control_failure;
  run_program(model, program, state, out, out.control_errors());
  out.finish(state);
  write_state((out.dir() / "final.state").string(), state, "test:" + test.name, state_physics(deck));
  std::vector<std::string> warnings;
  const Json result = summarize_test(deck, test, out.rows(), out.control_errors(), out.elapsed(),
                                     state.control.stage_steps, state.particles.size(), warnings);
  run.update_summary([&](Json& s) { s["tests"][test.name] = result; });
  for (const std::string& w : warnings) run.add_warning(w);
  if (test.probes) {
    probe_points.finish(state, out.rows().back());
    const Json probes = run_test_probes(run, deck, options, test, probe_points, result.value("peak_reached", true));
    run.update_summary([&](Json& s) { s["tests"][test.name]["probes"] = probes; });
    for (const auto& [point, p] : probes["points"].items())  // a point that could not be probed is a warning
      if (p.value("status", "") == "not run")
        run.add_warning(test.name + ": the probes at " + point + " were not run: " + p.value("reason", ""));
  }
  if (check) {
    if (!options.quiet)
      std::printf("%s: rate check: %s\n", test.name.c_str(),
                  rate_check_cost(deck, test, *check, result.value("particle_steps_per_s", 0.0)).words().c_str());
    const State start = test_start_state(deck, test, prepared, model);  // the test's own start, resumed or not
    const Json verified = verify_test_rate(run, deck, options, test, *check, start, result);
    run.update_summary([&](Json& s) { s["tests"][test.name]["verify_rate"] = verified; });
  }
}

// A rate check's verdict on the console: per quantity its error in floors and verdict, then the test's.
void print_rate_check(const std::string& name, const Json& v) {
  std::printf("%s: rate check at %g x the rate, tolerance %g floors (95 %%)\n", name.c_str(), v.value("rate_factor", 0.0),
              v.value("tolerance_floors", 0.0));
  if (v.contains("comparisons"))
    for (const auto& [q, c] : v["comparisons"].items()) {
      const bool has = c.contains("error_floors") && c["error_floors"].is_number();
      std::printf("%s:   %-20s error %+7.2f -+ %.2f floors (chaos: %s): %s\n", name.c_str(), q.c_str(),
                  has ? c["error_floors"].get<double>() : NAN, c.value("chaos_half_width_floors", NAN),
                  c.value("chaos_from", std::string("-")).c_str(), c.value("verdict", std::string()).c_str());
    }
  std::printf("%s: rate check: %s: %s\n", name.c_str(), v.value("verdict", std::string()).c_str(),
              v.value("reason", std::string()).c_str());
}

void print_test_done(const RunDirectory& run, const std::string& name) {
  const Json s = run.summary()["tests"][name];
  auto value = [&](const char* key) { return s[key].is_null() ? NAN : s[key].get<double>(); };
  std::printf("%s: done in %.1f s (%.3g particle-steps/s): peak s1/s3 %.4f at e1 %.4f\n", name.c_str(),
              value("wall_s"), value("particle_steps_per_s"), value("peak_ratio13"), value("e1_at_peak"));
  if (!s.value("peak_reached", true))
    std::printf("%s: no peak reached: %s is largest at the end of the test (its peak quantities are left "
                "out of ensemble statistics and fits)\n", name.c_str(), s.value("driven_measure", std::string("s11/s33")).c_str());
  if (s.contains("shear"))
    std::printf("%s: peak %s %.4f at %s %.4f\n", name.c_str(), s["shear"]["measure"].get<std::string>().c_str(),
                s["shear"]["peak_tau_over_sigma_n"].is_null() ? NAN : s["shear"]["peak_tau_over_sigma_n"].get<double>(),
                ("g" + s["shear"]["component"].get<std::string>().substr(1)).c_str(),
                s["shear"]["g_at_peak"].is_null() ? NAN : s["shear"]["g_at_peak"].get<double>());
  if (!s.value("controlled", true))
    std::printf("%s: uncontrolled: a control failed (summary.json control_failures; control_failure \"warn\")\n",
                name.c_str());
  if (s.contains("verify_rate")) print_rate_check(name, s["verify_rate"]);
  if (s.contains("probes"))  // a point whose probes did not all run and hold their controls is named with its reason
    for (const auto& [point, p] : s["probes"]["points"].items())
      if (p.value("status", "") != "ran")
        std::printf("%s: probes at %s: %s%s%s\n", name.c_str(), point.c_str(), p.value("status", "").c_str(),
                    p.contains("reason") ? ": " : "", p.value("reason", "").c_str());
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
      run_preparation(run, deck, options, state, resumed, legs);
      run.mark_done("prepare");
      if (!options.quiet) {
        const Json p = run.summary()["prepared"];
        std::printf("prepare: done in %lld steps, %.1f s: void ratio %.4f, Z %.3f\n",
                    static_cast<long long>(p["steps"].get<std::int64_t>()), p["wall_s"].get<double>(),
                    p["void_ratio"].get<double>(), p["Z"].get<double>());
      }
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
    run_test(run, deck, options, test, prepared, resumed);
    run.mark_done(test.name);
    if (!options.quiet) print_test_done(run, test.name);
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
