// celldem bench: shear-phase throughput on a prepared sample, optionally beside LAMMPS on the same scene
// and across particle counts (tiled copies of the sample).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <thread>

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

// The bench's copy of a translated script with LAMMPS's fastest honest settings for this scene (the
// translator's own script is left as it is). Measured on the paper TTC scene (8000 spheres, 1 and 2 ranks,
// alternated, outputs compared; README "Performance"):
//   newton on            each pair across a periodic boundary is computed once, not once per side
//                        (fix neigh/history carries the history back by reverse communication)
//   neighbor skin        the translator's (celldem's, 0.01 of the largest diameter): 0.005 and 0.02 were within
//                        noise of it, 0.05 and 0.1 slower (more listed pairs; the list build is ~1 % of the time)
//   neigh_modify         every 1 delay 0 check yes: a rebuild only when some atom moved half the skin (the box
//                        deformation included); every 2 / delay 5 gained nothing and could miss a contact
//   atom_modify sort     1000 steps, default bins (the data file is already spatially ordered; 0 0 and 100
//                        were within noise)
//   measurements         the contact count and the kinetic energies (compute contact/atom is a pass over the
//                        neighbour list) evaluated at output steps only, as celldem evaluates them for its
//                        rows; the box lengths and stresses the servo and the series use stay per step
// The physics is unchanged: the same pairs, forces and control; the series agree to the printed digits.
std::string tune_lammps_script(const std::string& script, const TestDef& test, Json& settings) {
  std::vector<std::string> lines;
  {
    std::istringstream in(script);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  auto starts = [](const std::string& line, const std::string& word) { return line.rfind(word + " ", 0) == 0; };
  bool newton = false, neigh = false;
  for (std::string& line : lines) {
    if (starts(line, "newton")) {
      line = "newton          on";
      newton = true;
    } else if (starts(line, "neigh_modify")) {
      line = "neigh_modify    delay 0 every 1 check yes\natom_modify     sort 1000 0.0";
      neigh = true;
    } else if (starts(line, "neighbor")) {
      settings["neighbor"] = line.substr(16) + " (the translator's: celldem's skin, 0.01 of the largest diameter)";
    }
  }
  if (!newton || !neigh) throw std::runtime_error("bench: the translated LAMMPS script has no newton/neigh_modify line");
  settings["newton"] = "on";
  settings["neigh_modify"] = "delay 0 every 1 check yes";
  settings["atom_modify"] = "sort 1000 0.0";

  // Measurements at output steps only: split `fix obs ... ave/time 1 1 1 ... c_nc2 c_ket c_ker`.
  std::vector<std::string> tuned = lines;
  const std::string head = "fix             obs all ave/time 1 1 1 ";
  const std::string tail = " c_nc2 c_ket c_ker";
  bool split = false;
  for (std::size_t k = 0; k < tuned.size(); ++k) {
    std::string& line = tuned[k];
    if (line.rfind(head, 0) != 0 || line.size() < head.size() + tail.size() ||
        line.compare(line.size() - tail.size(), tail.size(), tail) != 0)
      continue;
    const std::string per_step = line.substr(0, line.size() - tail.size());
    std::istringstream values(per_step.substr(head.size()));
    int count = 0;
    for (std::string v; values >> v;) ++count;
    const std::string every = std::to_string(test.output_interval);
    line = per_step + "\nfix             obsr all ave/time " + every + " 1 " + every + tail;
    for (std::size_t q = k + 1; q < tuned.size(); ++q)
      if (starts(tuned[q], "variable"))
        for (int m = 1; m <= 3; ++m) {
          const std::string from = "f_obs[" + std::to_string(count + m) + "]";
          const std::string to = "f_obsr[" + std::to_string(m) + "]";
          for (std::size_t at; (at = tuned[q].find(from)) != std::string::npos;) tuned[q].replace(at, from.size(), to);
        }
    split = true;
    break;
  }
  // Only where nothing but the series rows (fix print, every output_interval) reads those values; the thermo
  // line (printed at the end of any run, too) drops Z.
  const std::regex thermo_z(" v_Z\\b");
  const std::regex uses(R"(\bv_(Z|nc|ek)\b)");
  for (std::string& line : tuned) {
    if (starts(line, "thermo_style")) line = std::regex_replace(line, thermo_z, "");
    else if (!starts(line, "variable") && !starts(line, "fix             out") && std::regex_search(line, uses))
      split = false;
  }
  if (split) lines = tuned;
  settings["measurements"] = split ? "contact count and kinetic energy at output steps only (fix ave/time every "
                                     "output_interval), as celldem's rows; lengths and stresses every step"
                                   : "as translated (every step)";
  std::string out;
  for (const std::string& line : lines) out += line + "\n";
  return out;
}

LammpsScene prepare_lammps(const Deck& deck, const TestDef& test, const State& state, std::int64_t steps,
                           const fs::path& dir, Json* tuned_settings) {
  fs::create_directories(dir);
  const std::vector<std::string> diffs = state_differences(state, TargetCode::Lammps);
  std::ofstream(dir / kTranslatedDataName) << translate_data(deck, state, TargetCode::Lammps, "bench", diffs);
  const std::string script = script_file_name(test, TargetCode::Lammps);
  const std::string text = translate_test(deck, test, TargetCode::Lammps);
  std::ofstream(dir / script) << (tuned_settings ? tune_lammps_script(text, test, *tuned_settings) : text);
  return {dir, script, steps};
}

std::string mpi_env() { return "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1 "; }

double run_lammps(const LammpsScene& scene, int ranks) {
  const std::string log = "bench-np" + std::to_string(ranks) + ".log";
  const std::string cmd = "cd '" + scene.dir.string() + "' && " + mpi_env() +
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

// Whole processes: `celldem run` on a deck that starts from the state and runs the test for `steps` steps,
// and `lmp` on the translated (tuned) script of the same deck; wall time of each process, start-up, reading
// the state and writing results included.
struct WholeProcess {
  fs::path dir;         // holds deck.json, celldem-t<K>/ and lammps/
  LammpsScene lammps;
};

WholeProcess prepare_whole_process(const std::string& deck_path, const std::string& test_name,
                                   const std::string& state_path, std::int64_t steps, const fs::path& dir,
                                   Json& settings) {
  fs::create_directories(dir);
  Json d = Json::parse(std::ifstream(deck_path));
  d.erase("prepare");
  d["initial_state"] = fs::absolute(state_path).string();
  Json tests = Json::array();
  for (Json& t : d["tests"])
    if (t.value("name", "") == test_name) {
      if (t.contains("legs")) throw DeckError("bench --whole-process: test '" + test_name + "' has a load program");
      t["end"] = {{"steps", steps}};
      tests.push_back(t);
    }
  d["tests"] = tests;
  std::ofstream(dir / "deck.json") << d.dump(2) << "\n";
  const Deck deck = read_deck((dir / "deck.json").string());
  const State state = read_state(state_path);
  return {dir, prepare_lammps(deck, deck.tests.front(), state, steps, dir / "lammps", &settings)};
}

double seconds_of(const std::string& cmd) {
  const auto t0 = std::chrono::steady_clock::now();
  if (std::system(cmd.c_str()) != 0) throw std::runtime_error("bench: failed: " + cmd);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double run_celldem_process(const WholeProcess& w, int threads) {
  const std::string exe = fs::read_symlink("/proc/self/exe").string();
  return seconds_of("cd '" + w.dir.string() + "' && '" + exe + "' run deck.json --out celldem-t" +
                    std::to_string(threads) + " --threads " + std::to_string(threads) +
                    " --quiet --force > /dev/null 2>&1");
}

double run_lammps_process(const WholeProcess& w, int ranks) {
  // One rank: lmp itself, as one would run it; more: through mpirun (its start-up is part of the run).
  const std::string launch = ranks == 1 ? "" : "mpirun --oversubscribe -np " + std::to_string(ranks) + " ";
  return seconds_of("cd '" + w.lammps.dir.string() + "' && " + mpi_env() + launch + "lmp -in " + w.lammps.script +
                    " -log none -screen none > /dev/null 2>&1");
}

// The largest relative difference of the stresses (s11, s22, s33) and of the contact count between two series
// written by the translated script (rows of the same steps), and the rows compared: the tuned scene against the
// translator's own, for "the same physics".
std::pair<double, std::size_t> series_difference(const fs::path& a, const fs::path& b) {
  auto rows = [](const fs::path& path) {
    std::vector<std::vector<double>> out;
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);  // header
    while (std::getline(in, line)) {
      std::vector<double> row;
      std::stringstream ss(line);
      for (std::string cell; std::getline(ss, cell, ',');) row.push_back(std::strtod(cell.c_str(), nullptr));
      out.push_back(row);
    }
    return out;
  };
  const auto ra = rows(a), rb = rows(b);
  double worst = 0.0;
  const std::size_t count = std::min(ra.size(), rb.size());
  for (std::size_t r = 0; r < count; ++r)
    for (std::size_t c : {6u, 7u, 8u, 10u})  // s11, s22, s33, n_contacts
      if (c < ra[r].size() && c < rb[r].size())
        worst = std::max(worst, std::abs(ra[r][c] - rb[r][c]) / std::max(std::abs(rb[r][c]), 1e-300));
  return {ra.size() == rb.size() ? worst : INFINITY, count};
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
