#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "app/commands.hpp"
#include "core/plan.hpp"
#include "io/deck_reader.hpp"
#include "run/ensemble.hpp"
#include "run/preflight.hpp"
#include "run/progress.hpp"
#include "run/runner.hpp"
#include "run/sample.hpp"

namespace celldem::app {

std::string describe_estimate(const Deck& deck, double start_solid_fraction) {
  // "x", "x to y" or "x or more" (high < 0: unknown), each number as printf's format gives it.
  const auto span = [](double low, double high, const char* format) {
    char a[64], b[64];
    std::snprintf(a, sizeof a, format, low);
    std::snprintf(b, sizeof b, format, high);
    return high < 0 ? std::string(a) + " or more" : high > low ? std::string(a) + " to " + b : std::string(a);
  };
  const RunEstimate e = estimate_run(deck, start_solid_fraction);
  const double to_hours = 1.0 / (kParticleStepsPerCoreSecond * 3600.0);
  char rate[32];
  std::snprintf(rate, sizeof rate, "%.3g", kParticleStepsPerCoreSecond);
  return "estimate: about " + span(e.bytes / 1e6, e.bytes / 1e6, "%.3g") + " MB of memory; " +
         span(e.preparation.low, e.preparation.high, "%.0f") + " preparation steps and " +
         span(e.tests.low, e.tests.high, "%.0f") + " test steps" +
         (e.probe_steps > 0 ? " and " + span(static_cast<double>(e.probe_steps), static_cast<double>(e.probe_steps), "%.0f") +
                                  " probe steps at most"
                            : std::string()) + ", " +
         span(e.particle_steps_low, e.particle_steps_high, "%.3g") + " particle-steps: about " +
         span(e.particle_steps_low * to_hours, e.particle_steps_high < 0 ? -1.0 : e.particle_steps_high * to_hours,
              "%.2g") +
         " core-hours at " + rate + " particle-steps/s per core (measured on a 2-core development machine; tests "
         "run side by side on spare cores)";
}

// A word as a POSIX shell reads it back: quoted when it holds anything but safe characters.
std::string shell_word(const std::string& word) {
  const bool safe = !word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                                            "0123456789_-+=./:,@%") == std::string::npos;
  if (safe) return word;
  std::string quoted(1, '\'');
  for (const char c : word) {
    if (c == '\'') quoted.append("'\\''");  // close the quote, an escaped quote, open it again
    else quoted.push_back(c);
  }
  quoted.push_back('\'');
  return quoted;
}

// `celldem run` as this command line gave it, with --force dropped and --resume added: what continues it after a
// stop, every other option (--tolerance, --seeds, --probes, --verify-rate ...) kept as given.
std::string continue_command(const CLI::App& cmd) {
  std::string line = "celldem run";
  for (const CLI::Option* option : cmd.get_options()) {
    if (option->count() == 0 || option->get_name() == "--force" || option->get_name() == "--resume" ||
        option->get_name() == "--help")
      continue;
    const bool positional = option->get_name().rfind("-", 0) != 0;
    if (!positional) line.append(" ").append(option->get_name());
    if (option->get_expected_min() == 0) continue;  // a flag
    for (const std::string& value : option->results()) line.append(" ").append(shell_word(value));
  }
  return line.append(" --resume");
}

namespace {
// What `celldem run` parses.
struct RunArgs {
  std::string deck, seeds, probes;
  RunOptions options;
  bool include_uncontrolled = false;
  bool no_twin = false;      // --no-verify-twin
  std::string rungs;         // --verify-rate-rungs
  double rate_factor = 0.5;  // --verify-rate-factor
  std::optional<double> tolerance;
};

// The rate check's options, settled against each other and the deck: refused where they exclude each other or
// where no test is checked, and a floors file that cannot serve refused before any work.
void settle_verify_rate(const CLI::App& cmd, RunArgs& args, const Deck& deck) {
  VerifyRateOptions& verify = args.options.verify_rate;
  const bool rungs = cmd.count("--verify-rate-rungs") > 0, factor = cmd.count("--verify-rate-factor") > 0;
  const bool twins = cmd.count("--verify-twins") > 0;
  if (rungs && factor) throw CLI::ValidationError("--verify-rate-rungs and --verify-rate-factor exclude each other");
  if (twins && args.no_twin) throw CLI::ValidationError("--verify-twins and --no-verify-twin exclude each other");
  try {
    if (rungs) verify.rungs = parse_rungs(args.rungs);
  } catch (const std::invalid_argument& e) {
    throw CLI::ValidationError(std::string("--verify-rate-rungs: ") + e.what());
  }
  if (factor) verify.rungs = rungs_of_factor(args.rate_factor);
  verify.rungs_given = rungs || factor;
  verify.twins_given = twins || args.no_twin;
  if (args.no_twin) verify.twins = 0;
  const bool checked = verify.enabled || std::any_of(deck.tests.begin(), deck.tests.end(),
                                                     [](const TestDef& t) { return t.verify_rate.has_value(); });
  if ((verify.rungs_given || verify.twins_given || !verify.floors_path.empty()) && !checked)
    throw CLI::ValidationError(
        "--verify-rate-rungs, --verify-rate-factor, --verify-twins, --no-verify-twin and "
        "--floors need --verify-rate (or a test's verify_rate key)");
  for (const TestDef& test : deck.tests)
    if (verify_rate_for(verify, test)) noise_floors(verify.floors_path, test.name, deck.sample.count);
}
}  // namespace

Command add_run_command(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  CLI::App* cmd = app.add_subcommand("run", "Run a deck: prepare a sample (or load one) and run its tests");
  cmd->add_option("deck", args->deck, "Deck file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", args->options.out_dir, "Run directory for results")->required();
  cmd->add_option("--threads", args->options.threads, "Worker threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  cmd->add_flag("--fixed-threads", args->options.fixed_threads,
                "Keep the thread count: no trials of one thread (by default a stage times one thread against its "
                "count now and then and keeps the faster: same results, faster under contention)");
  cmd->add_option("--tolerance", args->tolerance,
                  "A mean over seeds within T seed-to-seed noise floors (of this deck's size) of the quasi-static "
                  "answer (I -> 0), whatever rate the deck is written at: strain-driven legs at the inertial number "
                  "where the rate bias laws fitted on a rate ladder reach T floors at their 95 % upper bound (a deck "
                  "written faster is slowed, and says so); I is the cell's actual one, predicted from the imposed "
                  "rates by the leg's path and measured after each test (summary.json tests.<test>.tolerance says "
                  "whether T was kept); time steps, the preparation's schedule and output "
                  "intervals by the rules (io/time_to_answer_rules.json). One run adds its own scatter, one floor "
                  "(a standard deviation). `celldem plan --tolerance T` shows how far the deck as written is from "
                  "I -> 0 and what T costs; overrides the deck's `tolerance`");
  cmd->add_flag("--force", args->options.force, "Overwrite results already in the run directory");
  cmd->add_flag("--resume", args->options.resume, "Continue an interrupted run from its last checkpoint");
  cmd->add_flag("--quiet", args->options.quiet, "No progress or stage messages");
  cmd->add_option("--seeds", args->seeds,
                  "A seed ensemble: prepare one sample per seed (e.g. 1-8) into DIR/seed-<k>/ and write "
                  "DIR/ensemble.json (mean, std, 95 % intervals of the mean and of one more sample of every summary "
                  "quantity); one seed (e.g. 3) is a job array's share, gathered by `celldem merge`");
  cmd->add_flag("--include-uncontrolled", args->include_uncontrolled,
                "With --seeds: keep tests whose control failed in the ensemble statistics (left out by default)");
  VerifyRateOptions& verify = args->options.verify_rate;  // NOLINT: lives as long as args
  cmd->add_flag("--verify-rate", verify.enabled,
                "Each test checks its own convergence by a ladder of rates: it runs again from the same starting "
                "state over its whole path at each slower rung (--verify-rate-rungs) and as twins at 1.001, 1.002 ... "
                "times its rate (the chaos of one run); each summary quantity is fitted as Q0 + C r^p over the rates "
                "(the order p fitted) and its distance C from I -> 0 is judged in noise floors at 95 % (summary.json "
                "verify_rate; <test>/verify/rung-<k>/, <test>/verify/twin-<k>/; each run's cost is printed before "
                "it runs)");
  cmd->add_option("--verify-rate-rungs", args->rungs,
                  "With --verify-rate: the slower rungs' rates over the test's, e.g. 0.5,0.25 (the default; at least "
                  "two, each in [0.001, 0.999]); a rung at f costs 1/f times the test's steps")
      ->type_name("LIST");
  cmd->add_option("--verify-rate-factor", args->rate_factor,
                  "With --verify-rate: shorthand for --verify-rate-rungs f,f^2")
      ->check(CLI::Range(std::sqrt(kMinRung), kMaxRung));
  cmd->add_option("--verify-twins", verify.twins,
                  "With --verify-rate: the twins (2 by default), whose spread with the test is one run's chaos")
      ->check(CLI::Range(2, kMaxTwins));
  cmd->add_flag("--no-verify-twin", args->no_twin,
                "With --verify-rate: no twins (a third less cost at the default rungs); one run's chaos is then "
                "unknown and a single run's check is unresolved: the seeds of an ensemble judge the mean");
  cmd->add_option("--floors", verify.floors_path,
                  "With --verify-rate: the noise floors, an ensemble.json of this deck or a JSON of seed-to-seed stds "
                  "{\"ratio13\", \"ev\", \"Z\"} (optionally under tests.<name>); default: the reference ensemble's, "
                  "scaled to the deck's particle count (docs/outputs.md)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--probes", args->probes,
                  "Run only the tests' probes numbered K-L (from 1, point by point in probes.csv's order) with their "
                  "points' references: a share of a job array, gathered by `celldem merge` (docs/outputs.md#probes)");
  cmd->add_option("--progress-interval", args->options.progress_interval,
                  "Seconds between progress lines when stderr is not a terminal (a log file)")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 1e6));
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    if (args->options.force && args->options.resume)
      throw CLI::ValidationError("--force and --resume exclude each other");
    const Deck deck = read_deck(args->deck, args->tolerance);
    settle_verify_rate(*cmd, *args, deck);
    if (!args->probes.empty()) {
      if (std::none_of(deck.tests.begin(), deck.tests.end(), [](const TestDef& t) { return t.probes.has_value(); }))
        throw CLI::ValidationError("--probes: the deck's tests have no probes (tests[].probes)");
      try {
        args->options.probes = parse_probe_selection(args->probes);
      } catch (const std::invalid_argument& e) {
        throw CLI::ValidationError(std::string("--probes: ") + e.what());
      }
      if (const std::int64_t n = probe_count(deck); args->options.probes.first > n)
        throw CLI::ValidationError("--probes " + args->probes + ": the deck has " + std::to_string(n) +
                                   " probes, numbered 1-" + std::to_string(n) + " over its tests (`celldem plan` "
                                   "gives each test's numbers): this range holds none");
    }
    args->options.progress = args->options.quiet     ? ProgressMode::Off
                             : stderr_is_terminal() ? ProgressMode::Terminal
                                                    : ProgressMode::Log;
    if (deck.tolerance) {  // what the rules did and what they save, on the console and in summary.json
      const nlohmann::json t = tolerance_json(read_deck_as_written(args->deck), deck);
      args->options.tolerance_prediction = t.dump();
      if (!args->options.quiet) std::printf("%s\n", describe_tolerance(t).c_str());
    }
    args->options.continue_command = continue_command(*cmd);
    install_stop_handlers();
    if (args->seeds.empty()) run_deck(deck, args->options);
    else run_ensemble(deck, args->options, parse_seed_list(args->seeds, /*allow_one=*/true), args->include_uncontrolled);
    return 0;
  };
}

Command add_check_command(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("check", "Validate a deck without running it");
  cmd->add_option("deck", *path, "Deck file (JSON)")->required()->check(CLI::ExistingFile);
  return [cmd, path]() -> int {
    if (!cmd->parsed()) return -1;
    const Deck deck = read_deck(*path);
    for (const std::string& w : preflight(deck)) std::fprintf(stderr, "celldem: warning: %s\n", w.c_str());
    const CriticalTimeStep limit = critical_time_steps(deck.sample, deck.contact);
    double start_fraction = -1.0;
    if (deck.prepare && deck.initial_state) {  // where the preparation starts, as the run will print it
      const PreparationStart start = preparation_start(deck);
      start_fraction = start.solid_fraction;
      const int skipped = preparation_program(*deck.prepare, start_fraction).skipped;
      std::printf("%s\n", describe_preparation_start(deck, start, skipped).c_str());
    } else if (deck.initial_state) {  // what the tests start from (preflight warns of a loose one)
      std::printf("%s\n", describe_test_start(deck, preparation_start(deck)).c_str());
    }
    std::printf("%s: valid (%d particles, %zu tests, critical time step %.3g s, %s mode)\n%s\n", path->c_str(),
                deck.sample.count, deck.tests.size(), limit.value(), limit.limiting().name,
                describe_estimate(deck, start_fraction).c_str());
    if (const std::string steps = describe_stage_time_steps(deck); !steps.empty()) std::printf("%s\n", steps.c_str());
    if (const std::string servo = describe_servo_caps(deck); !servo.empty()) std::printf("%s\n", servo.c_str());
    if (const std::string legs = describe_ramps_and_holds(deck); !legs.empty()) std::printf("%s\n", legs.c_str());
    return 0;
  };
}

}  // namespace celldem::app
