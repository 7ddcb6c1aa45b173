#include "run/bench_suite.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <thread>
#include <utility>

#include "io/state_file.hpp"
#include "io/translate.hpp"
#include "run/bench.hpp"
#include "run/bench_lammps.hpp"

namespace celldem {
namespace {
using Json = nlohmann::json;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? NAN : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
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

const char* plural(int count) { return count > 1 ? "s" : ""; }

// The shear phase per thread count, and per rank count in LAMMPS (its scene translated into out/lammps),
// alternated: the report's medians and samples, the last timing's memory and list statistics and the LAMMPS
// settings.
Json time_threads(const Deck& deck, const TestDef& test, const State& state, const BenchOptions& o,
                  std::FILE* progress) {
  std::map<std::string, std::vector<double>> samples;  // "celldem-t2", "lammps-np1", ...
  ShearTiming last{};
  LammpsScene scene, as_translated, bare;
  Json lammps_settings;
  if (o.vs_lammps) {
    scene = prepare_lammps(deck, test, state, o.warmup + o.steps, o.out / "lammps", &lammps_settings);
    bare = prepare_lammps(deck, test, state, o.warmup + o.steps, o.out / "lammps-bare", nullptr, true);
    if (o.lammps_as_translated)
      as_translated = prepare_lammps(deck, test, state, o.warmup + o.steps, o.out / "lammps-as-translated", nullptr);
  }
  for (int r = 0; r < o.repeats; ++r) {
    for (int t : o.threads) {  // alternate celldem and LAMMPS so both see the same machine load
      last = time_shear(deck, test, state, t, o.steps, o.warmup);
      samples["celldem-t" + std::to_string(t)].push_back(last.particle_steps_per_second);
      std::fprintf(progress, "  repeat %d  celldem %d thread%s: %.3g particle-steps/s\n", r + 1, t, plural(t),
                   last.particle_steps_per_second);
      std::fflush(progress);
    }
    if (o.vs_lammps)
      for (int k : o.ranks) {
        const double pss = run_lammps(scene, k);
        samples["lammps-np" + std::to_string(k)].push_back(pss);
        std::fprintf(progress, "  repeat %d  LAMMPS %d rank%s: %.3g particle-steps/s\n", r + 1, k, plural(k), pss);
        const double kernel = run_lammps(bare, k);
        samples["lammps-bare-np" + std::to_string(k)].push_back(kernel);
        std::fprintf(progress, "  repeat %d  LAMMPS %d rank%s, bare kernel (pair + nve/sphere): %.3g particle-steps/s\n",
                     r + 1, k, plural(k), kernel);
        std::fflush(progress);
        if (o.lammps_as_translated) {
          const double plain = run_lammps(as_translated, k);
          samples["lammps-as-translated-np" + std::to_string(k)].push_back(plain);
          std::fprintf(progress, "  repeat %d  LAMMPS %d rank%s, script as translated: %.3g particle-steps/s\n",
                       r + 1, k, plural(k), plain);
          std::fflush(progress);
        }
      }
  }
  Json report = {{"deck", o.deck_path}, {"state", o.state_path}, {"test", test.name},
                 {"particles", state.particles.size()}, {"steps", o.steps}, {"warmup", o.warmup},
                 {"repeats", o.repeats}, {"bytes_per_particle", last.bytes_per_particle},
                 {"bytes_per_particle_breakdown", {{"particles", last.memory.particles},
                                                   {"pairs", last.memory.pairs},
                                                   {"model", last.memory.model}}},
                 {"row_seconds", last.row_seconds}, {"step_seconds", last.step_seconds},
                 {"pairs_per_particle", last.pairs_per_particle},
                 {"crossings_per_particle", last.crossings_per_particle},
                 {"contacts_per_particle", last.contacts_per_particle}, {"rebuilds", last.rebuilds}};
  std::fprintf(progress, "medians (particle-steps/s):\n");
  for (const auto& [name, v] : samples) {
    report["median_particle_steps_per_s"][name] = median(v);
    report["samples"][name] = v;
    std::fprintf(progress, "  %-12s %.4g\n", name.c_str(), median(v));
  }
  if (o.vs_lammps) {
    if (o.lammps_as_translated) {
      const std::string csv = series_file_name(test, TargetCode::Lammps);
      const auto [diff, rows] = series_difference(scene.dir / csv, as_translated.dir / csv);
      lammps_settings["series_max_relative_difference_vs_as_translated"] = diff;
      lammps_settings["series_rows_compared"] = rows;
      std::fprintf(progress, "LAMMPS tuned vs as translated: series rows %zu, largest relative difference of s11, "
                   "s22, s33, contacts %.3g\n", rows, diff);
    }
    report["lammps_settings"] = lammps_settings;
    std::fprintf(progress, "LAMMPS settings (the bench's copy of the translated script): newton %s; neighbor %s; "
                 "neigh_modify %s; atom_modify %s; measurements: %s\n",
                 lammps_settings["newton"].get<std::string>().c_str(),
                 lammps_settings.value("neighbor", std::string("as translated")).c_str(),
                 lammps_settings["neigh_modify"].get<std::string>().c_str(),
                 lammps_settings["atom_modify"].get<std::string>().c_str(),
                 lammps_settings["measurements"].get<std::string>().c_str());
  }
  std::fprintf(progress, "memory: %.0f bytes per particle (particles %.0f, pairs %.0f, model %.0f); one series row "
               "costs %.3g s = %.1f steps\n", last.bytes_per_particle, last.memory.particles, last.memory.pairs,
               last.memory.model, last.row_seconds, last.row_seconds / last.step_seconds);
  std::fprintf(progress, "per particle: %.2f listed pairs, %.2f contacts; %lld neighbour-list rebuilds in %lld steps\n",
               last.pairs_per_particle, last.contacts_per_particle, static_cast<long long>(last.rebuilds),
               static_cast<long long>(o.steps));
  return report;
}

// Each contact law against the deck's linear one (contact_law_variants), alternated, on the first thread count.
Json time_laws(const Deck& deck, std::size_t test_index, const State& state, const BenchOptions& o,
               std::FILE* progress) {
  const auto variants = contact_law_variants(deck);
  const int threads = o.threads.front();
  std::map<std::string, std::vector<double>> law_samples;
  for (int r = 0; r < o.repeats; ++r)
    for (const auto& [name, variant] : variants)  // alternated, so that every law sees the same load
      law_samples[name].push_back(
          time_shear(variant, variant.tests[test_index], state, threads, o.steps, o.warmup).particle_steps_per_second);
  const double linear = median(law_samples["linear"]);
  std::fprintf(progress, "contact laws (%d thread%s, medians; cost relative to linear):\n", threads, plural(threads));
  Json laws;
  for (const auto& [name, variant] : variants) {
    const double pss = median(law_samples[name]);
    laws[name] = {{"particle_steps_per_s", pss}, {"cost_relative_to_linear", linear / pss},
                  {"samples", law_samples[name]}};
    std::fprintf(progress, "  %-32s %.4g particle-steps/s  cost %.2f x linear\n", name.c_str(), pss, linear / pss);
    std::fflush(progress);
  }
  return laws;
}

// One thread, the largest thread count fixed and the same governed (a run's default), alternated, while another
// CPU-bound process runs.
Json time_contention(const Deck& deck, const TestDef& test, const State& state, const BenchOptions& o,
                     std::FILE* progress) {
  const int many = *std::max_element(o.threads.begin(), o.threads.end());
  const std::vector<std::pair<std::string, std::pair<int, bool>>> cases = {
      {"1 thread", {1, false}},
      {std::to_string(many) + " threads fixed", {many, false}},
      {std::to_string(many) + " threads governed", {many, true}}};
  std::map<std::string, std::vector<double>> busy;
  {
    const BusyProcess other;  // another job on one of the cores
    for (int r = 0; r < o.repeats; ++r)
      for (const auto& [name, how] : cases)
        busy[name].push_back(
            time_shear(deck, test, state, how.first, o.steps, o.warmup, how.second).particle_steps_per_second);
  }
  std::fprintf(progress, "under contention (another busy process; medians):\n");
  Json contention;
  for (const auto& [name, how] : cases) {
    contention[name] = {{"particle_steps_per_s", median(busy[name])}, {"samples", busy[name]}};
    std::fprintf(progress, "  %-24s %.4g particle-steps/s\n", name.c_str(), median(busy[name]));
  }
  std::fflush(progress);
  return contention;
}

// The extra samples, then periodic copies of the sample, per thread count: about the same particle-steps per
// point (fewer steps for larger samples, at least kMinSteps), the samples made one at a time (1,000,000 spheres:
// about 1 GB, twice while a timing copies it). The copies are tiled from the sample after o.tile_after steps of
// the test (10,000 by default; the steps run past the test's end if it is shorter), when its list's skin has
// adapted (the paper's first list lasts some 5000 steps): each copy's list then has the skin of a long run's, as
// the sample's own long point does. Extra samples start from their files, on the deck's skin.
Json time_scaling(const Deck& deck, const TestDef& test, const State& state, const BenchOptions& o,
                  std::FILE* progress) {
  constexpr std::int64_t kMinSteps = 100;
  const std::size_t n = state.particles.size();
  const std::int64_t tile_after = o.copies.empty() ? 0 : o.tile_after;
  std::fprintf(progress, "scaling (about %lld particle-steps per point, at least %lld steps; copies tiled from the "
               "sample after %lld steps of the test):\n",
               static_cast<long long>(o.steps * static_cast<std::int64_t>(n)), static_cast<long long>(kMinSteps),
               static_cast<long long>(tile_after));
  std::fflush(progress);  // (before the steps that adapt the skin)
  State adapted = state;
  if (tile_after > 0)
    time_shear(deck, test, state, o.threads.back(), tile_after, /*warmup=*/0, /*governed=*/false, &adapted);
  if (!o.copies.empty())
    std::fprintf(progress, "  the copies' list skin %.3g of the deck's\n",
                 adapted.pairs.skin > 0.0 ? adapted.pairs.current_skin() / adapted.pairs.skin : 1.0);
  std::vector<std::pair<std::string, int>> sources;  // (extra state, 0) or ("", copies)
  for (const std::string& path : o.extra_states) sources.emplace_back(path, 0);
  for (int k : o.copies) sources.emplace_back("", k);
  Json scaling;
  for (const auto& [path, k] : sources) {
    const State sample = path.empty() ? tile_state(adapted, k) : read_state(path);
    const std::size_t count = sample.particles.size();
    const auto steps = std::max<std::int64_t>(
        kMinSteps, std::llround(static_cast<double>(o.steps) * static_cast<double>(n) / static_cast<double>(count)));
    const std::int64_t warmup = std::min<std::int64_t>({o.warmup, 200, steps});
    for (int t : o.threads) {
      std::vector<double> v;
      ShearTiming s{};
      for (int r = 0; r < o.repeats; ++r) {
        s = time_shear(deck, test, sample, t, steps, warmup);
        v.push_back(s.particle_steps_per_second);
      }
      const long rss = max_rss_mib();
      scaling.push_back({{"particles", count}, {"threads", t}, {"steps", steps}, {"warmup", warmup},
                         {"copies", k}, {"tiled_after_steps", path.empty() ? tile_after : 0},
                         {"source", path.empty() ? "copies " + std::to_string(k) : path},
                         {"particle_steps_per_s", median(v)}, {"samples", v},
                         {"bytes_per_particle", s.bytes_per_particle},
                         {"bytes_per_particle_breakdown", {{"particles", s.memory.particles},
                                                           {"pairs", s.memory.pairs},
                                                           {"model", s.memory.model}}},
                         {"pairs_per_particle", s.pairs_per_particle},
                         {"crossings_per_particle", s.crossings_per_particle},
                         {"seconds_per_run", static_cast<double>(count) * steps / median(v)},
                         {"max_rss_mib", rss}});
      std::fprintf(progress, "  %8zu particles  %d thread%s  %5lld steps  %.4g particle-steps/s  %.0f "
                   "bytes/particle  peak RSS %ld MiB\n", count, t, plural(t), static_cast<long long>(steps),
                   median(v), s.bytes_per_particle, rss);
      std::fflush(progress);
    }
  }
  return scaling;
}

// `celldem run` (each thread count) against `lmp` (each rank count, paired in order) on a deck that starts from
// the state, alternated: wall times, start-up, reading the state and writing results included.
Json time_whole_processes(const TestDef& test, std::size_t particles, const BenchOptions& o, std::FILE* progress) {
  Json settings;
  const WholeProcess w =
      prepare_whole_process(o.deck_path, test.name, o.state_path, o.process_steps, o.out / "whole", settings);
  std::fprintf(progress, "whole processes (%lld steps from the state; wall time, medians):\n",
               static_cast<long long>(o.process_steps));
  std::map<std::string, std::vector<double>> secs;
  for (int r = 0; r < o.repeats; ++r)
    for (std::size_t q = 0; q < o.threads.size(); ++q) {  // alternated: celldem, LAMMPS, next pair
      const double c = run_celldem_process(w, o.threads[q]);
      const double l = run_lammps_process(w, o.ranks[q]);
      secs["celldem-t" + std::to_string(o.threads[q])].push_back(c);
      secs["lammps-np" + std::to_string(o.ranks[q])].push_back(l);
      std::fprintf(progress, "  repeat %d  celldem run %d thread%s %.3f s   lmp %d rank%s %.3f s\n", r + 1,
                   o.threads[q], plural(o.threads[q]), c, o.ranks[q], plural(o.ranks[q]), l);
      std::fflush(progress);
    }
  Json wp = {{"steps", o.process_steps}, {"deck", (w.dir / "deck.json").string()}, {"lammps_settings", settings},
             {"celldem", "celldem run deck.json --threads K (governed, as by default) --quiet: reads the state, "
                         "writes series.csv, final.state, summary.json"},
             {"lammps", "lmp -in SCRIPT -log none -screen none (mpirun -np K for K > 1): reads state.data, "
                        "writes the series csv"}};
  for (std::size_t q = 0; q < o.threads.size(); ++q) {
    const std::string c = "celldem-t" + std::to_string(o.threads[q]), l = "lammps-np" + std::to_string(o.ranks[q]);
    const double cs = median(secs[c]), ls = median(secs[l]);
    wp["pairs"].push_back({{"threads", o.threads[q]}, {"ranks", o.ranks[q]}, {"celldem_seconds", cs},
                           {"lammps_seconds", ls}, {"ratio", ls / cs}, {"celldem_samples", secs[c]},
                           {"lammps_samples", secs[l]},
                           {"celldem_particle_steps_per_s", static_cast<double>(particles) * o.process_steps / cs},
                           {"lammps_particle_steps_per_s", static_cast<double>(particles) * o.process_steps / ls}});
    std::fprintf(progress, "  celldem run %d thread%s %.3f s, lmp %d rank%s %.3f s: ratio %.2f (LAMMPS time / "
                 "celldem time)\n", o.threads[q], plural(o.threads[q]), cs, o.ranks[q], plural(o.ranks[q]), ls,
                 ls / cs);
  }
  std::fflush(progress);
  return wp;
}

}  // namespace

Json run_bench(const Deck& deck, const TestDef& test, const State& state, const BenchOptions& o, std::FILE* progress) {
  const double load_at_start = load_average();
  Json report = time_threads(deck, test, state, o, progress);
  if (o.laws) report["laws"] = time_laws(deck, static_cast<std::size_t>(&test - deck.tests.data()), state, o, progress);
  if (o.contention) report["contention"] = time_contention(deck, test, state, o, progress);
  if (o.scaling) {
    Json scaling = time_scaling(deck, test, state, o, progress);
    if (!scaling.is_null()) report["scaling"] = std::move(scaling);  // null: no copies and no extra samples
  }
  if (o.whole_process) report["whole_process"] = time_whole_processes(test, state.particles.size(), o, progress);
  report["load_average"] = {{"start", load_at_start}, {"end", load_average()},
                            {"cores", static_cast<int>(std::thread::hardware_concurrency())}};
  std::fprintf(progress, "load average (1 min) %.2f at the start, %.2f at the end, on %u cores\n", load_at_start,
               load_average(), std::thread::hardware_concurrency());
  if (o.vs_lammps) {
    const std::string mine = "celldem-t" + std::to_string(o.threads.back());
    const std::string theirs = "lammps-np" + std::to_string(o.ranks.back());
    const Json& medians = report["median_particle_steps_per_s"];
    report["ratio"] = medians[mine].get<double>() / medians[theirs].get<double>();
    // celldem's whole step (damping, deformation, servo, measurements) against LAMMPS's pair style alone.
    for (std::size_t q = 0; q < std::min(o.threads.size(), o.ranks.size()); ++q) {
      const std::string c = "celldem-t" + std::to_string(o.threads[q]);
      const std::string k = "lammps-bare-np" + std::to_string(o.ranks[q]);
      const double ratio = medians[c].get<double>() / medians[k].get<double>();
      report["ratio_vs_bare_kernel"][c + "/" + k] = ratio;
      std::fprintf(progress, "celldem's full step on %d thread%s / LAMMPS's bare kernel on %d rank%s: %.2f\n",
                   o.threads[q], plural(o.threads[q]), o.ranks[q], plural(o.ranks[q]), ratio);
    }
  }
  return report;
}

}  // namespace celldem
