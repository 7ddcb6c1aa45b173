#include "run/bench_lammps.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "io/deck_reader.hpp"
#include "io/state_file.hpp"
#include "io/translate.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {
std::string mpi_env() { return "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1 "; }

double seconds_of(const std::string& cmd) {
  const auto t0 = std::chrono::steady_clock::now();
  if (std::system(cmd.c_str()) != 0) throw std::runtime_error("bench: failed: " + cmd);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

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

std::string bare_lammps_script(const std::string& script) {
  std::istringstream in(script);
  std::string out;
  bool timestep = false, integrator = false, run = false;
  for (std::string line; std::getline(in, line);) {
    const auto starts = [&line](const char* word) { return line.rfind(std::string(word) + " ", 0) == 0; };
    if (!timestep) {  // the set-up: units, box, data, neighbour list, pair style, time step
      out += line + "\n";
      timestep = starts("timestep");
    } else if (starts("fix") && line.find(" nve/sphere") != std::string::npos) {
      out += line + "\n";
      integrator = true;
    } else if (starts("run")) {
      out += "thermo          0\n" + line + "\n";
      run = true;
    }
  }
  if (!timestep || !integrator || !run)
    throw std::runtime_error("bench: the translated LAMMPS script has no timestep, fix nve/sphere or run line");
  return out;
}

LammpsScene prepare_lammps(const Deck& deck, const TestDef& test, const State& state, std::int64_t steps,
                           const fs::path& dir, Json* tuned_settings, bool bare) {
  fs::create_directories(dir);
  const std::vector<std::string> diffs = state_differences(state, TargetCode::Lammps);
  std::ofstream(dir / kTranslatedDataName) << translate_data(deck, state, TargetCode::Lammps, "bench", diffs);
  const std::string script = script_file_name(test, TargetCode::Lammps);
  const std::string text = translate_test(deck, test, TargetCode::Lammps);
  Json settings;  // the bare kernel's set-up is the tuned script's, whose settings the caller did not ask for
  const bool tuned = tuned_settings || bare;
  const std::string text_run = tuned ? tune_lammps_script(text, test, tuned_settings ? *tuned_settings : settings) : text;
  std::ofstream(dir / script) << (bare ? bare_lammps_script(text_run) : text_run);
  return {dir, script, steps};
}

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

}  // namespace celldem
