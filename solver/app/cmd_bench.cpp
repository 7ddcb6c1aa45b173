// celldem bench: shear-phase throughput on a prepared sample, optionally beside LAMMPS on the same scene
// and across particle counts (tiled copies of the sample).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "app/commands.hpp"
#include "io/deck_reader.hpp"
#include "io/state_file.hpp"
#include "io/translate.hpp"
#include "run/bench.hpp"

namespace celldem::app {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? NAN : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

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

// The same scene in LAMMPS: translated data and script, `steps` steps, timed by LAMMPS's own "Loop time".
struct LammpsScene {
  fs::path dir;
  std::string script;
  std::int64_t steps = 0;
};

LammpsScene prepare_lammps(const Deck& deck, const TestDef& test, const State& state, std::int64_t steps,
                           const fs::path& dir) {
  fs::create_directories(dir);
  const std::vector<std::string> diffs = state_differences(state, TargetCode::Lammps);
  std::ofstream(dir / kTranslatedDataName) << translate_data(deck, state, TargetCode::Lammps, "bench", diffs);
  const std::string script = script_file_name(test, TargetCode::Lammps);
  std::ofstream(dir / script) << translate_test(deck, test, TargetCode::Lammps);
  return {dir, script, steps};
}

double run_lammps(const LammpsScene& scene, int ranks) {
  const std::string log = "bench-np" + std::to_string(ranks) + ".log";
  const std::string cmd = "cd '" + scene.dir.string() +
                          "' && OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1 "
                          "mpirun --oversubscribe -np " + std::to_string(ranks) + " lmp -in " + scene.script +
                          " -var steps " + std::to_string(scene.steps) +
                          " -log " + log + " -screen none > /dev/null 2>&1";
  if (std::system(cmd.c_str()) != 0) throw std::runtime_error("LAMMPS failed: " + cmd);
  std::ifstream in(scene.dir / log);
  const std::regex loop(R"(Loop time of ([0-9.eE+-]+) on \d+ procs for (\d+) steps with (\d+) atoms)");
  std::smatch m;
  for (std::string line; std::getline(in, line);)
    if (std::regex_search(line, m, loop))
      return std::stod(m[3]) * std::stod(m[2]) / std::stod(m[1]);
  throw std::runtime_error("no 'Loop time' line in " + (scene.dir / log).string());
}

}  // namespace

Command add_bench_command(CLI::App& app) {
  struct Args {
    std::string deck = "inputs/paper.json", state = "results/paper/prepared.state", test, out = "results/bench";
    std::string threads = "1,2", ranks = "1,2", copies = "1,2,4,8,16";
    std::vector<std::string> extra_states;
    std::int64_t steps = 20000, warmup = 1000;
    int repeats = 3;
    bool vs_lammps = false, scaling = false, laws = false, contention = false, force = false;
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
  cmd->add_flag("--scaling", a->scaling, "Also time periodic copies of the sample (see --copies) and --extra-state samples");
  cmd->add_option("--copies", a->copies, "Copy counts for --scaling (16 copies of 8000 spheres = 128,000)")
      ->capture_default_str();
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
    const std::vector<int> threads = parse_list(a->threads, "--threads");
    const std::vector<int> ranks = parse_list(a->ranks, "--ranks");
    const std::vector<int> copies = parse_list(a->copies, "--copies");
    const fs::path out(a->out);
    if (fs::exists(out / "bench.json") && !a->force)
      throw std::runtime_error((out / "bench.json").string() + " exists; use --force to overwrite it");
    fs::create_directories(out);
    const State state = read_state(a->state);
    const std::size_t n = state.particles.size();
    std::printf("celldem bench: test '%s' of %s on %zu spheres (%s), %lld steps after %lld warm-up, %d repeats\n",
                test->name.c_str(), a->deck.c_str(), n, a->state.c_str(), static_cast<long long>(a->steps),
                static_cast<long long>(a->warmup), a->repeats);

    std::map<std::string, std::vector<double>> samples;  // "celldem-t2", "lammps-np1", ...
    ShearTiming last{};
    LammpsScene scene;
    if (a->vs_lammps) scene = prepare_lammps(deck, *test, state, a->warmup + a->steps, out / "lammps");
    for (int r = 0; r < a->repeats; ++r) {
      for (int t : threads) {  // alternate celldem and LAMMPS so both see the same machine load
        last = time_shear(deck, *test, state, t, a->steps, a->warmup);
        samples["celldem-t" + std::to_string(t)].push_back(last.particle_steps_per_second);
        std::printf("  repeat %d  celldem %d thread%s: %.3g particle-steps/s\n", r + 1, t, t > 1 ? "s" : "",
                    last.particle_steps_per_second);
        std::fflush(stdout);
      }
      if (a->vs_lammps)
        for (int k : ranks) {
          const double pss = run_lammps(scene, k);
          samples["lammps-np" + std::to_string(k)].push_back(pss);
          std::printf("  repeat %d  LAMMPS %d rank%s: %.3g particle-steps/s\n", r + 1, k, k > 1 ? "s" : "", pss);
          std::fflush(stdout);
        }
    }
    Json report = {{"deck", a->deck}, {"state", a->state}, {"test", test->name}, {"particles", n},
                   {"steps", a->steps}, {"warmup", a->warmup}, {"repeats", a->repeats},
                   {"bytes_per_particle", last.bytes_per_particle},
                   {"row_seconds", last.row_seconds}, {"step_seconds", last.step_seconds},
                   {"pairs_per_particle", last.pairs_per_particle},
                   {"contacts_per_particle", last.contacts_per_particle}, {"rebuilds", last.rebuilds}};
    std::printf("medians (particle-steps/s):\n");
    for (const auto& [name, v] : samples) {
      report["median_particle_steps_per_s"][name] = median(v);
      report["samples"][name] = v;
      std::printf("  %-12s %.4g\n", name.c_str(), median(v));
    }
    std::printf("memory: %.0f bytes per particle; one series row costs %.3g s = %.1f steps\n",
                last.bytes_per_particle, last.row_seconds, last.row_seconds / last.step_seconds);
    std::printf("per particle: %.2f listed pairs, %.2f contacts; %lld neighbour-list rebuilds in %lld steps\n",
                last.pairs_per_particle, last.contacts_per_particle, static_cast<long long>(last.rebuilds),
                static_cast<long long>(a->steps));

    if (a->laws) {
      const auto variants = contact_law_variants(deck);
      std::map<std::string, std::vector<double>> law_samples;
      for (int r = 0; r < a->repeats; ++r)
        for (const auto& [name, variant] : variants)  // alternated, so that every law sees the same load
          law_samples[name].push_back(
              time_shear(variant, variant.tests[static_cast<std::size_t>(test - deck.tests.data())], state,
                         threads.front(), a->steps, a->warmup).particle_steps_per_second);
      const double linear = median(law_samples["linear"]);
      std::printf("contact laws (%d thread%s, medians; cost relative to linear):\n", threads.front(),
                  threads.front() > 1 ? "s" : "");
      for (const auto& [name, variant] : variants) {
        const double pss = median(law_samples[name]);
        report["laws"][name] = {{"particle_steps_per_s", pss}, {"cost_relative_to_linear", linear / pss},
                                {"samples", law_samples[name]}};
        std::printf("  %-32s %.4g particle-steps/s  cost %.2f x linear\n", name.c_str(), pss, linear / pss);
        std::fflush(stdout);
      }
    }
    if (a->contention) {
      const int many = *std::max_element(threads.begin(), threads.end());
      const std::vector<std::pair<std::string, std::pair<int, bool>>> cases = {
          {"1 thread", {1, false}},
          {std::to_string(many) + " threads fixed", {many, false}},
          {std::to_string(many) + " threads governed", {many, true}}};
      std::map<std::string, std::vector<double>> busy;
      {
        const BusyProcess other;  // another job on one of the cores
        for (int r = 0; r < a->repeats; ++r)
          for (const auto& [name, how] : cases)
            busy[name].push_back(
                time_shear(deck, *test, state, how.first, a->steps, a->warmup, how.second).particle_steps_per_second);
      }
      std::printf("under contention (another busy process; medians):\n");
      for (const auto& [name, how] : cases) {
        report["contention"][name] = {{"particle_steps_per_s", median(busy[name])}, {"samples", busy[name]}};
        std::printf("  %-24s %.4g particle-steps/s\n", name.c_str(), median(busy[name]));
      }
      std::fflush(stdout);
    }
    if (a->scaling) {
      std::printf("scaling (about %lld particle-steps per point):\n", static_cast<long long>(a->steps * n));
      std::vector<State> samples_to_time;
      for (const std::string& path : a->extra_states) samples_to_time.push_back(read_state(path));
      for (int k : copies) samples_to_time.push_back(tile_state(state, k));
      for (const State& sample : samples_to_time) {
        const std::size_t count = sample.particles.size();
        const auto steps = std::max<std::int64_t>(
            200, std::llround(static_cast<double>(a->steps) * static_cast<double>(n) / static_cast<double>(count)));
        for (int t : threads) {
          std::vector<double> v;
          ShearTiming s{};
          for (int r = 0; r < a->repeats; ++r) {
            s = time_shear(deck, *test, sample, t, steps, std::min<std::int64_t>(a->warmup, 200));
            v.push_back(s.particle_steps_per_second);
          }
          report["scaling"].push_back({{"particles", count}, {"threads", t}, {"steps", steps},
                                       {"particle_steps_per_s", median(v)},
                                       {"bytes_per_particle", s.bytes_per_particle},
                                       {"pairs_per_particle", s.pairs_per_particle}});
          std::printf("  %8zu particles  %d thread%s  %.4g particle-steps/s  %.0f bytes/particle\n", count, t,
                      t > 1 ? "s" : "", median(v), s.bytes_per_particle);
          std::fflush(stdout);
        }
      }
    }
    if (a->vs_lammps) {
      const std::string mine = "celldem-t" + std::to_string(threads.back());
      const std::string theirs = "lammps-np" + std::to_string(ranks.back());
      const double ratio = report["median_particle_steps_per_s"][mine].get<double>() /
                           report["median_particle_steps_per_s"][theirs].get<double>();
      report["ratio"] = ratio;
      std::ofstream(out / "bench.json") << report.dump(2) << "\n";
      std::printf("ratio: %.2f\n", ratio);
    } else {
      std::ofstream(out / "bench.json") << report.dump(2) << "\n";
    }
    return 0;
  };
}

}  // namespace celldem::app
