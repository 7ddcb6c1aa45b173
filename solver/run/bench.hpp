// Benchmarks of the shear phase: celldem's throughput on a prepared sample (and tiled copies of it for
// scaling); the same scene in LAMMPS through the translated deck, alternated so that both see the
// same machine load, is in run/bench_lammps.hpp, and the measurements `celldem bench` makes of them in
// run/bench_suite.hpp.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "core/state.hpp"
#include "core/deck.hpp"
#include "core/model.hpp"

namespace celldem {

// `copies` periodic copies of a state (contacts and their history included), stacked in a near-cubic
// block (2 = 2x1x1, 4 = 2x2x1, 8 = 2x2x2, 16 = 4x2x2, ...): a larger sample with the same packing
// statistics, for measuring how cost grows with the particle count. Copies are consecutive in particle
// order, so the result is as spatially ordered as the original. Its first list is built with the skin the
// original's list had adapted to (PairList::build_skin), as each copy's would have.
State tile_state(const State& state, int copies);

// Memory per particle [bytes] of the arrays that grow with the sample (capacities, not sizes): the State's
// per-particle arrays (Particles and the neighbour list's CSR offsets, reverse offsets and positions at the
// last build), its per-pair arrays (pairs, images, springs, flags, per-pair results, reverse index), and
// the Model's per-particle constants (mass, damping factors). Transients of a rebuild are not counted.
struct MemoryPerParticle {
  double particles = 0.0;
  double pairs = 0.0;
  double model = 0.0;
  double total() const { return particles + pairs + model; }
};
MemoryPerParticle memory_per_particle(const State& state, const Model& model);

struct ShearTiming {
  double seconds = 0.0;                  // wall time of the timed steps (rows included)
  double particle_steps_per_second = 0.0;
  double row_seconds = 0.0;              // mean time of one series row (measurements + formatting)
  double step_seconds = 0.0;             // mean time of one step without rows
  double bytes_per_particle = 0.0;       // all of the below: the memory a step touches, per particle
  MemoryPerParticle memory;              // its parts
  double pairs_per_particle = 0.0;       // neighbour-list pairs at the end
  double crossings_per_particle = 0.0;   // of which crossing between force blocks (PairList)
  double contacts_per_particle = 0.0;    // touching pairs at the end
  std::int64_t rebuilds = 0;             // neighbour-list rebuilds during the timed steps
};

// Runs `steps` steps of the deck's test `test` from `state` with `threads` threads, writing a row every
// output_interval steps to memory (as a run would to its file), after `warmup` untimed steps.
// governed: with a ThreadGovernor, as a run has by default (else the thread count is fixed). final_state, if
// given, receives the state after the steps.
ShearTiming time_shear(const Deck& deck, const TestDef& test, const State& state, int threads, std::int64_t steps,
                       std::int64_t warmup, bool governed = false, State* final_state = nullptr);

// A CPU-bound process (a busy loop) until the object goes: the contention of another job on the machine.
class BusyProcess {
 public:
  BusyProcess();
  ~BusyProcess();
  BusyProcess(const BusyProcess&) = delete;
  BusyProcess& operator=(const BusyProcess&) = delete;

 private:
  int pid_ = -1;
};

// The deck with each contact law in turn, for timing their cost against the deck's own (linear) law:
// "linear", "hertz", "hertz+mindlin", "hertz+mindlin+rolling", "hertz+mindlin+rolling+twisting". The Hertz
// modulus makes its tangent stiffness equal kn at the mean contact force of the deck's largest stress
// (pi d^2 p / 3.6), nu = 0.25; the rolling spring is kt (mu_roll 0.1). Same scene, comparable forces.
std::vector<std::pair<std::string, Deck>> contact_law_variants(const Deck& deck);

}  // namespace celldem
