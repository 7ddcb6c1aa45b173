// celldem bench: shear-phase throughput on a prepared sample, optionally beside LAMMPS on the same scene
// and across particle counts (tiled copies of the sample).
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "app/commands.hpp"
#include "io/deck_reader.hpp"
#include "io/state_file.hpp"
#include "io/translate.hpp"
#include "run/bench.hpp"
#include "run/bench_lammps.hpp"

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

// The 1-minute load average: how busy the (shared) machine was, for reading the numbers.
double load_average() {
  double l[1] = {NAN};
  return getloadavg(l, 1) == 1 ? l[0] : NAN;
}

long max_rss_mib() {
  struct rusage u {};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024;
}

}  // namespace

Command add_bench_command(CLI::App& app) {
  struct Args {
    std::string deck = "inputs/paper.json", state = "results/paper/prepared.state", test, out = "results/bench";
    std::string threads = "1,2", ranks = "1,2", copies = "1,2,4,8,16";
    std::vector<std::string> extra_states;
    std::int64_t steps = 20000, warmup = 1000, process_steps = 10000;
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
    for (int k : copies)
      if (k > 125) throw CLI::ValidationError("--copies", "at most 125 copies (1,000,000 spheres of an 8000 sample)");
    if (a->whole_process && threads.size() != ranks.size())
      throw CLI::ValidationError("--whole-process", "pairs --threads with --ranks: give lists of the same length");
    const fs::path out(a->out);
    if (fs::exists(out / "bench.json") && !a->force)
      throw std::runtime_error((out / "bench.json").string() + " exists; use --force to overwrite it");
    fs::create_directories(out);
    const State state = read_state(a->state);
    const std::size_t n = state.particles.size();
    std::printf("celldem bench: test '%s' of %s on %zu spheres (%s), %lld steps after %lld warm-up, %d repeats\n",
                test->name.c_str(), a->deck.c_str(), n, a->state.c_str(), static_cast<long long>(a->steps),
                static_cast<long long>(a->warmup), a->repeats);

    const double load_at_start = load_average();
    std::map<std::string, std::vector<double>> samples;  // "celldem-t2", "lammps-np1", ...
    ShearTiming last{};
    LammpsScene scene, as_translated;
    Json lammps_settings;
    if (a->vs_lammps) {
      scene = prepare_lammps(deck, *test, state, a->warmup + a->steps, out / "lammps", &lammps_settings);
      if (a->lammps_as_translated)
        as_translated = prepare_lammps(deck, *test, state, a->warmup + a->steps, out / "lammps-as-translated", nullptr);
    }
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
          if (a->lammps_as_translated) {
            const double plain = run_lammps(as_translated, k);
            samples["lammps-as-translated-np" + std::to_string(k)].push_back(plain);
            std::printf("  repeat %d  LAMMPS %d rank%s, script as translated: %.3g particle-steps/s\n", r + 1, k,
                        k > 1 ? "s" : "", plain);
            std::fflush(stdout);
          }
        }
    }
    Json report = {{"deck", a->deck}, {"state", a->state}, {"test", test->name}, {"particles", n},
                   {"steps", a->steps}, {"warmup", a->warmup}, {"repeats", a->repeats},
                   {"bytes_per_particle", last.bytes_per_particle},
                   {"bytes_per_particle_breakdown", {{"particles", last.memory.particles},
                                                     {"pairs", last.memory.pairs},
                                                     {"model", last.memory.model}}},
                   {"row_seconds", last.row_seconds}, {"step_seconds", last.step_seconds},
                   {"pairs_per_particle", last.pairs_per_particle},
                   {"crossings_per_particle", last.crossings_per_particle},
                   {"contacts_per_particle", last.contacts_per_particle}, {"rebuilds", last.rebuilds}};
    std::printf("medians (particle-steps/s):\n");
    for (const auto& [name, v] : samples) {
      report["median_particle_steps_per_s"][name] = median(v);
      report["samples"][name] = v;
      std::printf("  %-12s %.4g\n", name.c_str(), median(v));
    }
    if (a->vs_lammps) {
      if (a->lammps_as_translated) {
        const std::string csv = series_file_name(*test, TargetCode::Lammps);
        const auto [diff, rows] = series_difference(scene.dir / csv, as_translated.dir / csv);
        lammps_settings["series_max_relative_difference_vs_as_translated"] = diff;
        lammps_settings["series_rows_compared"] = rows;
        std::printf("LAMMPS tuned vs as translated: series rows %zu, largest relative difference of s11, s22, s33, "
                    "contacts %.3g\n", rows, diff);
      }
      report["lammps_settings"] = lammps_settings;
      std::printf("LAMMPS settings (the bench's copy of the translated script): newton %s; neighbor %s; "
                  "neigh_modify %s; atom_modify %s; measurements: %s\n",
                  lammps_settings["newton"].get<std::string>().c_str(),
                  lammps_settings.value("neighbor", std::string("as translated")).c_str(),
                  lammps_settings["neigh_modify"].get<std::string>().c_str(),
                  lammps_settings["atom_modify"].get<std::string>().c_str(),
                  lammps_settings["measurements"].get<std::string>().c_str());
    }
    std::printf("memory: %.0f bytes per particle (particles %.0f, pairs %.0f, model %.0f); one series row costs "
                "%.3g s = %.1f steps\n", last.bytes_per_particle, last.memory.particles, last.memory.pairs,
                last.memory.model, last.row_seconds, last.row_seconds / last.step_seconds);
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
      // About the same particle-steps per point (fewer steps for larger samples, at least kMinSteps), the
      // samples made one at a time (1,000,000 spheres: about 1 GB, twice while a timing copies it).
      constexpr std::int64_t kMinSteps = 100;
      std::printf("scaling (about %lld particle-steps per point, at least %lld steps):\n",
                  static_cast<long long>(a->steps * n), static_cast<long long>(kMinSteps));
      std::vector<std::pair<std::string, int>> sources;  // (extra state, 0) or ("", copies)
      for (const std::string& path : a->extra_states) sources.emplace_back(path, 0);
      for (int k : copies) sources.emplace_back("", k);
      for (const auto& [path, k] : sources) {
        const State sample = path.empty() ? tile_state(state, k) : read_state(path);
        const std::size_t count = sample.particles.size();
        const auto steps = std::max<std::int64_t>(
            kMinSteps, std::llround(static_cast<double>(a->steps) * static_cast<double>(n) / static_cast<double>(count)));
        const std::int64_t warmup = std::min<std::int64_t>({a->warmup, 200, steps});
        for (int t : threads) {
          std::vector<double> v;
          ShearTiming s{};
          for (int r = 0; r < a->repeats; ++r) {
            s = time_shear(deck, *test, sample, t, steps, warmup);
            v.push_back(s.particle_steps_per_second);
          }
          const long rss = max_rss_mib();
          report["scaling"].push_back({{"particles", count}, {"threads", t}, {"steps", steps}, {"warmup", warmup},
                                       {"copies", k}, {"particle_steps_per_s", median(v)}, {"samples", v},
                                       {"bytes_per_particle", s.bytes_per_particle},
                                       {"bytes_per_particle_breakdown", {{"particles", s.memory.particles},
                                                                         {"pairs", s.memory.pairs},
                                                                         {"model", s.memory.model}}},
                                       {"pairs_per_particle", s.pairs_per_particle},
                                       {"crossings_per_particle", s.crossings_per_particle},
                                       {"seconds_per_run", static_cast<double>(count) * steps / median(v)},
                                       {"max_rss_mib", rss}});
          std::printf("  %8zu particles  %d thread%s  %5lld steps  %.4g particle-steps/s  %.0f bytes/particle  "
                      "peak RSS %ld MiB\n", count, t, t > 1 ? "s" : "", static_cast<long long>(steps), median(v),
                      s.bytes_per_particle, rss);
          std::fflush(stdout);
        }
      }
    }
    if (a->whole_process) {
      Json settings;
      const WholeProcess w = prepare_whole_process(a->deck, test->name, a->state, a->process_steps, out / "whole",
                                                   settings);
      std::printf("whole processes (%lld steps from the state; wall time, medians):\n",
                  static_cast<long long>(a->process_steps));
      std::map<std::string, std::vector<double>> secs;
      for (int r = 0; r < a->repeats; ++r)
        for (std::size_t q = 0; q < threads.size(); ++q) {  // alternated: celldem, LAMMPS, next pair
          const double c = run_celldem_process(w, threads[q]);
          const double l = run_lammps_process(w, ranks[q]);
          secs["celldem-t" + std::to_string(threads[q])].push_back(c);
          secs["lammps-np" + std::to_string(ranks[q])].push_back(l);
          std::printf("  repeat %d  celldem run %d thread%s %.3f s   lmp %d rank%s %.3f s\n", r + 1, threads[q],
                      threads[q] > 1 ? "s" : "", c, ranks[q], ranks[q] > 1 ? "s" : "", l);
          std::fflush(stdout);
        }
      Json& wp = report["whole_process"];
      wp = {{"steps", a->process_steps}, {"deck", (w.dir / "deck.json").string()}, {"lammps_settings", settings},
            {"celldem", "celldem run deck.json --threads K (governed, as by default) --quiet: reads the state, "
                        "writes series.csv, final.state, summary.json"},
            {"lammps", "lmp -in SCRIPT -log none -screen none (mpirun -np K for K > 1): reads state.data, "
                       "writes the series csv"}};
      for (std::size_t q = 0; q < threads.size(); ++q) {
        const std::string c = "celldem-t" + std::to_string(threads[q]), l = "lammps-np" + std::to_string(ranks[q]);
        const double cs = median(secs[c]), ls = median(secs[l]);
        wp["pairs"].push_back({{"threads", threads[q]}, {"ranks", ranks[q]}, {"celldem_seconds", cs},
                               {"lammps_seconds", ls}, {"ratio", ls / cs}, {"celldem_samples", secs[c]},
                               {"lammps_samples", secs[l]},
                               {"celldem_particle_steps_per_s", static_cast<double>(n) * a->process_steps / cs},
                               {"lammps_particle_steps_per_s", static_cast<double>(n) * a->process_steps / ls}});
        std::printf("  celldem run %d thread%s %.3f s, lmp %d rank%s %.3f s: ratio %.2f (LAMMPS time / celldem time)\n",
                    threads[q], threads[q] > 1 ? "s" : "", cs, ranks[q], ranks[q] > 1 ? "s" : "", ls, ls / cs);
      }
      std::fflush(stdout);
    }
    report["load_average"] = {{"start", load_at_start}, {"end", load_average()},
                              {"cores", static_cast<int>(std::thread::hardware_concurrency())}};
    std::printf("load average (1 min) %.2f at the start, %.2f at the end, on %u cores\n", load_at_start,
                load_average(), std::thread::hardware_concurrency());
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