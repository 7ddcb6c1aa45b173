// LAMMPS beside celldem in `celldem bench`: the same scene translated (io/translate) and run by `lmp`, its
// script tuned to LAMMPS's fastest honest settings, timed by LAMMPS's own loop time; and whole processes
// (`celldem run` against `lmp`) on a deck that starts from the state. Needs `lmp` and `mpirun` on the PATH.
#pragma once
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "core/deck.hpp"
#include "core/state.hpp"

namespace celldem {

// The same scene in LAMMPS: translated data and script, `steps` steps, timed by LAMMPS's own "Loop time".
struct LammpsScene {
  std::filesystem::path dir;
  std::string script;
  std::int64_t steps = 0;
};

// The bench's copy of a translated script with LAMMPS's fastest honest settings for this scene (the settings
// and why: bench_lammps.cpp); what it changed goes to `settings`. The physics is unchanged.
std::string tune_lammps_script(const std::string& script, const TestDef& test, nlohmann::json& settings);

// LAMMPS's bare kernel on the same scene: the (tuned) script's set-up up to its time step, then only
// `fix nve/sphere` and the run: no damping, no deformation, no servo, no measurements. What the pair style
// itself costs, the yardstick for celldem's whole step (the physics is not the scene's: nothing loads it).
std::string bare_lammps_script(const std::string& script);

// Writes the translated data file and test script into `dir`: tuned when tuned_settings is given (its settings
// written there); the bare kernel of the tuned script when bare is true.
LammpsScene prepare_lammps(const Deck& deck, const TestDef& test, const State& state, std::int64_t steps,
                           const std::filesystem::path& dir, nlohmann::json* tuned_settings, bool bare = false);

// Runs the scene on `ranks` MPI ranks: particle-steps per second of LAMMPS's loop.
double run_lammps(const LammpsScene& scene, int ranks);

// Whole processes: `celldem run` on a deck that starts from the state and runs the test for `steps` steps,
// and `lmp` on the translated (tuned) script of the same deck; wall time of each process, start-up, reading
// the state and writing results included.
struct WholeProcess {
  std::filesystem::path dir;         // holds deck.json, celldem-t<K>/ and lammps/
  LammpsScene lammps;
};

WholeProcess prepare_whole_process(const std::string& deck_path, const std::string& test_name,
                                   const std::string& state_path, std::int64_t steps, const std::filesystem::path& dir,
                                   nlohmann::json& settings);
// Wall time [s] of one `celldem run` (this executable) with `threads` threads, and of one `lmp` on `ranks` ranks.
double run_celldem_process(const WholeProcess& w, int threads);
double run_lammps_process(const WholeProcess& w, int ranks);

// The largest relative difference of the stresses (s11, s22, s33) and of the contact count between two series
// written by the translated script (rows of the same steps), and the rows compared: the tuned scene against the
// translator's own, for "the same physics".
std::pair<double, std::size_t> series_difference(const std::filesystem::path& a, const std::filesystem::path& b);

}  // namespace celldem
