// What `celldem bench` measures, in order: the shear phase per thread count (beside LAMMPS on the same scene
// when asked), then each contact law, the run under contention, periodic copies of the sample (scaling) and
// whole processes; each alternates what it compares, repeat by repeat, so that all see the same machine load.
// The result is bench.json's content; app/cmd_bench.cpp parses the options and writes it.
#pragma once
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/state.hpp"

namespace celldem {

struct BenchOptions {
  std::string deck_path;             // the deck and the state as given (reported; the whole processes read them)
  std::string state_path;
  std::filesystem::path out;         // the LAMMPS scenes and the whole processes' folders go below it
  std::vector<int> threads;          // celldem thread counts, timed in this order
  std::vector<int> ranks;            // LAMMPS rank counts (paired in order with `threads` for whole processes)
  std::vector<int> copies;           // copy counts of the sample for the scaling table
  std::vector<std::string> extra_states;  // other prepared samples for the scaling table
  std::int64_t steps = 0;            // timed steps per measurement
  std::int64_t warmup = 0;           // untimed steps before each
  std::int64_t process_steps = 0;    // steps of each whole-process run
  std::int64_t tile_after = 0;       // steps of the test before the sample is tiled for the scaling table
  int repeats = 1;                   // medians over these
  bool vs_lammps = false;            // the scene in LAMMPS too
  bool lammps_as_translated = false; // and the translator's own (untuned) script
  bool laws = false;
  bool contention = false;
  bool scaling = false;
  bool whole_process = false;
};

// Runs every measurement `options` asks for on the deck's test `test` from `state`, printing each result to
// `progress` as it comes, and returns the report (medians, samples, the memory and list statistics of the last
// timing, the machine's load average; "ratio" celldem / LAMMPS with vs_lammps).
nlohmann::json run_bench(const Deck& deck, const TestDef& test, const State& state, const BenchOptions& options,
                         std::FILE* progress);

}  // namespace celldem
