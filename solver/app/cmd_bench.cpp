// celldem bench: shear-phase throughput on a prepared sample, optionally beside LAMMPS on the same scene
// and across particle counts (tiled copies of the sample). The measurements are run/bench_suite's; this
// file reads the options, calls them and writes bench.json.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/commands.hpp"
#include "io/deck_reader.hpp"
#include "io/files.hpp"
#include "io/state_file.hpp"
#include "run/bench_suite.hpp"

namespace celldem::app {
namespace fs = std::filesystem;

namespace {

std::vector<int> parse_list(const std::string& text, const char* what) {
  std::vector<int> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    char* end = nullptr;
    const long v = std::strtol(item.c_str(), &end, 10);
    if (item.empty() || *end || v < 1 || v > 1024) throw CLI::ValidationError(what, "expected a list like 1,2");
    out.push_back(static_cast<int>(v));
  }
  return out;
}

}  // namespace

Command add_bench_command(CLI::App& app) {
  struct Args {
    std::string deck = "inputs/paper.json", state = "results/paper/prepared.state", test, out = "results/bench";
    std::string threads = "1,2", ranks = "1,2", copies = "1,2,4,8,16";
    std::vector<std::string> extra_states;
    std::int64_t steps = 20000, warmup = 1000, process_steps = 10000, tile_after = 10000;
    int repeats = 3;
    bool vs_lammps = false, scaling = false, laws = false, contention = false, force = false;
    bool lammps_as_translated = false, whole_process = false;
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("bench", "Time the shear phase of a test on a prepared sample (particle-steps/s)");
  cmd->add_option("--deck", a->deck, "Deck with the test to time")->capture_default_str()->check(CLI::ExistingFile);
  cmd->add_option("--state", a->state, "Prepared state to start from")->capture_default_str()->check(CLI::ExistingFile);
  cmd->add_option("--test", a->test, "Test of the deck to time (default: the first)");
  cmd->add_option("--steps", a->steps, "Timed steps per measurement")->capture_default_str()->check(CLI::Range(1, 100000000));
  cmd->add_option("--warmup", a->warmup, "Untimed steps before each measurement")->capture_default_str();
  cmd->add_option("--repeats", a->repeats, "Repeats (medians are reported)")->capture_default_str()->check(CLI::Range(1, 100));
  cmd->add_option("--threads", a->threads, "Thread counts to time")->capture_default_str();
  cmd->add_flag("--vs-lammps", a->vs_lammps, "Also run the scene in LAMMPS (mpirun -np each of --ranks), alternating");
  cmd->add_option("--ranks", a->ranks, "LAMMPS rank counts")->capture_default_str();
  cmd->add_flag("--lammps-as-translated", a->lammps_as_translated, "With --vs-lammps, also time the translator's own "
                "script (before the bench's tuning: newton on, measurements at output steps), alternated");
  cmd->add_flag("--whole-process", a->whole_process, "Also time whole processes, alternated: `celldem run` on a deck "
                "that starts from --state and runs the test for --process-steps steps (each of --threads) against "
                "`lmp` on its translated, tuned script (each of --ranks, paired in order); start-up, reading the "
                "state and writing results included");
  cmd->add_option("--process-steps", a->process_steps, "Steps of each --whole-process run")
      ->capture_default_str()->check(CLI::Range(1, 100000000));
  cmd->add_flag("--scaling", a->scaling, "Also time periodic copies of the sample (see --copies) and --extra-state samples");
  cmd->add_option("--copies", a->copies, "Copy counts for --scaling, up to 125 (16 copies of 8000 spheres = "
                  "128,000; 125 = 1,000,000: about 1 GB, larger samples run fewer steps)")
      ->capture_default_str();
  cmd->add_option("--tile-after", a->tile_after, "Steps of the test before the sample is tiled for --scaling, so that "
                  "the copies start with the list skin a long run adapts to (0: tile the state as given)")
      ->capture_default_str()->check(CLI::Range(0, 100000000));
  cmd->add_option("--extra-state", a->extra_states, "Other prepared samples to add to the scaling table (e.g. a "
                  "1000-sphere one)")->check(CLI::ExistingFile);
  cmd->add_flag("--laws", a->laws, "Also time the scene with each contact law (hertz, mindlin, rolling, twisting) "
                "against the deck's linear one, alternated, on the first of --threads");
  cmd->add_flag("--contention", a->contention, "Also time 1 thread, the largest of --threads fixed and the same governed "
                "(a run's default) while another CPU-bound process runs, alternated");
  cmd->add_option("--out", a->out, "Folder for bench.json (and the LAMMPS scene)")->capture_default_str();
  cmd->add_flag("--force", a->force, "Overwrite an earlier bench.json in --out");
  return [cmd, a]() -> int {
    if (!cmd->parsed()) return -1;
    const Deck deck = read_deck(a->deck);
    if (deck.tests.empty()) throw DeckError("tests: the deck has no test to time");
    const TestDef* test = &deck.tests[0];
    for (const TestDef& t : deck.tests) if (t.name == a->test) test = &t;
    if (!a->test.empty() && test->name != a->test) throw CLI::ValidationError("--test", "no test named " + a->test);
    BenchOptions o;
    o.deck_path = a->deck;
    o.state_path = a->state;
    o.out = a->out;
    o.threads = parse_list(a->threads, "--threads");
    o.ranks = parse_list(a->ranks, "--ranks");
    o.copies = parse_list(a->copies, "--copies");
    for (int k : o.copies)
      if (k > 125) throw CLI::ValidationError("--copies", "at most 125 copies (1,000,000 spheres of an 8000 sample)");
    if (a->whole_process && o.threads.size() != o.ranks.size())
      throw CLI::ValidationError("--whole-process", "pairs --threads with --ranks: give lists of the same length");
    o.extra_states = a->extra_states;
    o.steps = a->steps;
    o.warmup = a->warmup;
    o.process_steps = a->process_steps;
    o.tile_after = a->tile_after;
    o.repeats = a->repeats;
    o.vs_lammps = a->vs_lammps;
    o.lammps_as_translated = a->lammps_as_translated;
    o.laws = a->laws;
    o.contention = a->contention;
    o.scaling = a->scaling;
    o.whole_process = a->whole_process;
    const fs::path report_path = o.out / "bench.json";
    if (fs::exists(report_path) && !a->force)
      throw std::runtime_error(report_path.string() + " exists; use --force to overwrite it");
    fs::create_directories(o.out);
    const State state = read_state(a->state);
    std::printf("celldem bench: test '%s' of %s on %zu spheres (%s), %lld steps after %lld warm-up, %d repeats\n",
                test->name.c_str(), a->deck.c_str(), state.particles.size(), a->state.c_str(),
                static_cast<long long>(a->steps), static_cast<long long>(a->warmup), a->repeats);
    const nlohmann::json report = run_bench(deck, *test, state, o, stdout);
    write_file_atomic(report_path, report.dump(2) + "\n");
    if (report.contains("ratio")) std::printf("ratio: %.2f\n", report["ratio"].get<double>());
    return 0;
  };
}

}  // namespace celldem::app
