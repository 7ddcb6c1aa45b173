// The mutable state of a simulation: periodic cell, particles, contacts (with history) and control memory.
// A state file (io/state_file) keeps what the next step needs to continue bit for bit: the cell, the particles,
// the control memory, the last evaluation's stresses and each touching pair's history. The pair list itself,
// the pair and net forces, the incoming pairs and the build's positions and skin are recomputed from those.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "core/choices.hpp"
#include "core/types.hpp"

namespace celldem {

// The periodic cell: columns of h are the cell vectors [m]. Positions are stored scaled (s = h^-1 x), so a
// change of h deforms every particle position and every periodic image exactly (the affine field).
struct Cell {
  Mat3 h = Mat3::Identity();      // [m]
  Mat3 velocity_gradient = Mat3::Zero();  // L [1/s] of the last step: xdot_affine = L x
  double volume() const { return h.determinant(); }
  // Distance between opposite faces of the cell, per cell vector [m]: what limits the cutoff.
  Vec3 face_widths() const;
};

// Per-particle arrays (structure of arrays), all of length N, indexed by particle id.
struct Particles {
  std::vector<double> radius;    // [m]
  std::vector<Vec3> scaled;      // s, dimensionless, x = h s; never wrapped (the pair image absorbs whole
                                 // cells), so rebuilding the list never changes the arithmetic of a step
  std::vector<Vec3> velocity;    // v' [m/s], fluctuation about the affine field, at the half step
  std::vector<Vec3> spin;        // omega [rad/s], at the half step
  std::vector<Vec3> force;       // [N] net contact force of the last force evaluation
  std::vector<Vec3> torque;      // [N m] net contact moment of the last force evaluation
  std::size_t size() const { return radius.size(); }
  void resize(std::size_t n);
};

// Fixed blocks of particle ids for the pair loop's hand-over of forces (PairList): the threads take whole
// blocks, and the larger the block, the fewer pairs cross between blocks (about 10 % of the paper sample's).
constexpr std::size_t kForceBlock = 2048;
// The force block of particle i.
constexpr Index force_block(Index i) { return i / static_cast<Index>(kForceBlock); }

// Pair flags.
enum PairFlag : std::uint8_t { kTouching = 1, kSliding = 2 };

// A pair's periodic image in whole cells. Positions are never wrapped, so this is the difference of the two
// particles' unwrapped cells: a few at most; 16 bits leave room for particles that crossed the cell thousands
// of times (rebuild_pairs refuses more) and keep the pair arrays small.
using PairImage = std::array<std::int16_t, 3>;

// Half neighbour list in CSR form, pair p = (i, neighbor[p]) for p in [first[i], first[i+1]), sorted by j,
// each pair with its periodic image and the history of its contact. Pairs not touching have zero history.
struct PairList {
  std::vector<Index> first;                      // (N+1) offsets into the pair arrays: i owns [first[i], first[i+1])
  std::vector<Index> neighbor;                   // (P) j of each pair, j > i or an image of a lower id
  std::vector<PairImage> image;                  // (P) integer shift n: branch = h (s_j - s_i + n)
  std::vector<Vec3> tangential;                  // (P) xi [m], stored tangential spring displacement
  // The rotational springs, only with a law that has them (ContactDef::rotational_history(); else empty).
  std::vector<Vec3> rolling;                     // (P or 0) [m] stored rolling displacement
  std::vector<double> twist;                     // (P or 0) [rad] stored twist angle
  // The contact radius of the last step, only with a law that rescales by it (ContactDef::radius_history()).
  std::vector<double> contact_radius;            // (P or 0) [m] a = sqrt(R* overlap), 0 apart
  std::vector<std::uint8_t> flags;               // (P) PairFlag bits of the last force evaluation
  // Per-pair results of the last force evaluation (zero where the pair does not touch).
  std::vector<Vec3> force;                       // (P) [N] force on j by i
  std::vector<Vec3> torque_i;                    // (P) [N m] moment on i
  std::vector<Vec3> torque_j;                    // (P) [N m] moment on j
  // Each particle's net force and moment is summed from its pairs after the pair loop, in one fixed order for
  // any number of threads (integrate/leapfrog.cpp): particles are grouped in fixed blocks of kForceBlock ids,
  // and particle j's sum takes first its incoming pairs (those where it is the neighbour) whose owner is in its
  // force block, then its own pairs, then its incoming pairs whose owner is in an earlier block (crossing
  // pairs), each in pair order. The incoming pairs, as a CSR by j in that order:
  std::vector<Index> incoming_first;             // (N + 1) offsets into incoming_pair
  std::vector<Index> incoming_crossing;          // (N)     where j's crossing pairs start
  std::vector<Index> incoming_pair;              // (P)     pair indices
  // The pairs whose ends lie in two force blocks.
  std::size_t crossings() const {
    std::size_t c = 0;
    for (std::size_t j = 0; j < incoming_crossing.size(); ++j)
      c += static_cast<std::size_t>(incoming_first[j + 1] - incoming_crossing[j]);
    return c;
  }
  // Positions and cell at the last build, for the rebuild criterion. The positions are kept in single
  // precision (half the memory and the drift's traffic); build_rounding bounds what that rounding hides, and
  // the criterion adds it to the distance moved, so the list is rebuilt no later than with exact positions.
  std::vector<Vec3f> scaled_at_build;            // (N)
  double build_rounding = 0.0;                   // [-] largest |s - float(s)| of a component at the build
  Mat3 h_at_build = Mat3::Identity();
  double skin = 0.0;                             // [m] the largest extra cutoff beyond contact (the deck's)
  // The skin of the current list (adapt_skin: at most skin; 0 for skin itself) and the step of its build.
  // State files keep neither: the list never changes results, only their cost.
  double build_skin = 0.0;                       // [m]
  std::int64_t built_at_step = 0;                // steps_since_creation at the build
  double current_skin() const { return build_skin > 0.0 ? std::min(build_skin, skin) : skin; }
  std::size_t size() const { return neighbor.size(); }
  // The owner of pair q: a binary search of first, for checks and measurements (the pair loop walks first).
  Index owner_of(std::size_t q) const {
    return static_cast<Index>(std::upper_bound(first.begin(), first.end(), static_cast<Index>(q)) - first.begin()) - 1;
  }
};

// Calls f(i, q) for every listed pair q, in list order, with its owner i.
template <class F>
void for_each_pair(const PairList& pl, F&& f) {
  for (std::size_t i = 0; i + 1 < pl.first.size(); ++i)
    for (Index q = pl.first[i]; q < pl.first[i + 1]; ++q) f(static_cast<Index>(i), q);
}

// The force blocks the calling thread takes inside a parallel region, in ascending order: thread_blocks
// (core/parallel.hpp) over the blocks of n particles by their pairs (by their particles while the list is
// not built). The pair loop, the drift and the kick all take these, so a thread mostly works on data it
// wrote itself in the step's previous phase (with contiguous shares of particles instead, half of what the
// kick read came from the other core on two threads).
std::vector<std::size_t> thread_force_blocks(const PairList& pl, std::size_t n);

// The invariant of that deal, given every thread's blocks (dealt[t]: thread t's): each of the force blocks
// of n particles is dealt to exactly one thread, each thread's in ascending order. A block dealt twice would
// be moved, summed and kicked twice; one dealt to none, never. Stops the program naming what broke (whatever
// the build: tests call it to show it does); the checking build checks each deal (step.cpp).
void check_force_block_partition(const std::vector<std::vector<std::size_t>>& dealt, std::size_t n);

// One stored contact (the history that must survive a neighbour rebuild or a restart).
struct StoredContact {
  Index i, j;
  Vec3 tangential;
  std::uint8_t flags;
  Vec3 rolling = Vec3::Zero();  // (laws with rotational springs)
  double twist = 0.0;
  double contact_radius = 0.0;  // [m] (mindlin_rescale)
};

// Mixed control memory: what the loading stage needs to continue exactly, one record of the six components
// (core/choices.hpp kComponentNames). A stage starts from begin_stage() (cell/control.hpp), the one place that
// resets it.
struct ControlState {
  std::int64_t leg_steps = 0;            // steps done in the current leg of the stage's load program
  std::int32_t leg = 0;                  // the current leg (its index in the program)
  std::int64_t stage_steps = 0;          // steps done in the current stage (the series' `step`)
  // [m] each component's cell entry h(i, j) at the stage start (kComponentEntries): the axes' lengths, then the
  // tilts. A component's strain is measured against it (cell/control.hpp component_strains).
  Vec6 reference = (Vec6() << 1.0, 1.0, 1.0, 0.0, 0.0, 0.0).finished();
  double reference_volume = 1.0;         // [m^3]
  Vec6 servo_integral = Vec6::Zero();    // [Pa] accumulated stress error per component
  Vec6 leg_start_strains = Vec6::Zero(); // [-] strains (against the stage start) where the leg began: a
                                         // strain-driven component is at leg_start + progress x increment
  double leg_start_volume = 1.0;         // [m^3] cell volume where the leg began (constant-volume axes)
  // The loading rate's factor on the deck's rate of the strain-driven components (an adaptive leg's,
  // Leg::adaptive; 1 otherwise), and the leg's progress in steps at the deck's rate (the sum of the factors of
  // its steps). A leg at the deck's rate has factor 1 and progress = leg_steps, exactly.
  double rate_factor = 1.0;
  double leg_progress = 0.0;
  // The stage-start length of axis k (the reference of the normal component k).
  double reference_length(int k) const { return reference[k]; }
};

// The energy budget's running totals over the current stage (measure/energy.hpp has the definitions): what
// each step adds, kept only when the deck asks (Model::energy_budget; `open` false otherwise). Carried by the
// checkpoint's record, so a resumed stage adds to the same totals.
struct EnergyLedger {
  bool open = false;                 // opened at the stage's first force evaluation (open_energy_budget)
  Mat3 last_moment = Mat3::Zero();   // [N m] sum f (x) l of the last force evaluation (the trapezoid's start)
  double start_energy = 0.0;         // [J] stored + kinetic when the stage opened it
  double boundary_work = 0.0;        // [J] work of the cell on the contacts
  double friction = 0.0;             // [J] dissipated at the Coulomb cap
  double rotational_friction = 0.0;  // [J] at the rolling and twisting caps
  double contact_damping = 0.0;      // [J] by the rolling dashpot
  double damping_translation = 0.0;  // [J] by the body damping of the fluctuating velocities
  double damping_rotation = 0.0;     // [J] and of the spins
  double dissipated() const {
    return friction + rotational_friction + contact_damping + damping_translation + damping_rotation;
  }
};

struct State {
  Cell cell;
  Particles particles;
  PairList pairs;
  ControlState control;
  double time = 0.0;            // [s]
  std::int64_t steps_since_creation = 0;  // over every stage since the sample was made
  // Measured in the last force evaluation; the servo reads them on the next step.
  // [Pa] the contact stress of the six components, s11 s22 s33 s12 s13 s23 (symmetric part, compression
  // positive; the shear components only where the loading reads them, else 0: contact_forces.hpp shear_sums)
  // and their affine stiffnesses d(s_k)/d(e_k) from the normal springs (cell/control.hpp).
  Vec6 stress = Vec6::Zero();
  Vec6 stiffness = Vec6::Zero();
  std::int64_t touching = 0;    // contacts in the last force evaluation
  // Set by the last step's advance_cell: the servo components whose increment sat at its cap (not saved: every
  // step sets it before anything reads it).
  std::array<bool, kComponents> servo_saturated = {};
  // The normal stresses s11, s22, s33.
  Vec3 normal_stress() const { return stress.head<3>(); }
  double mean_stress() const { return stress.head<3>().sum() / 3.0; }
  // [1/s] the fastest strain-driven axis's rate in the steps being run, the adaptive factor included (series
  // `strain_rate`; not saved: run_program sets it before each run of steps; 0 outside a load program).
  double driving_rate = 0.0;
  double driving_factor = 1.0;  // the adaptive factor in those steps (series `rate_factor`; 1 at the deck's rate)
  // [1/s] the inertial number's strain-rate scale in those steps (core/plan leg_inertial_rate, the adaptive factor
  // included; series `inertial_number`); 0 outside a load program.
  double inertial_rate = 0.0;
  EnergyLedger energy;  // the energy budget's totals (open only when Model::energy_budget)
};

}  // namespace celldem
