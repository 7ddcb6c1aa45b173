// A new sample: spheres of randomly chosen sizes at the points of a cubic grid (the paper's section 4); or the
// start of a preparation from a loaded sample (initial_state with prepare), its overlaps relaxed on request.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/state.hpp"
#include "measure/micro.hpp"

namespace celldem {

// n = ceil(count^(1/3)) points per side at grid_spacing; the first `count` grid points are used, each
// sphere offset by a small random amount inside its free gap so that the grid is not a perfect lattice.
// Sizes: each particle draws one of the listed diameters with equal probability, or, with a grading, a
// diameter by inverse transform of the grading's number distribution (core/grading.hpp); portable RNG.
State make_grid_sample(const SampleDef& sample, double skin);

// The diameters [m] that make_grid_sample gives a graded sample's spheres, in particle order, without
// building it; empty for the listed forms.
std::vector<double> graded_sample_diameters(const SampleDef& sample);

// The soft start of an imported sample (prepare.relax_overlaps): the overlaps as loaded and after the cell's
// isotropic dilation by `factor` (1: none asked for, or none needed), relative to the smaller radius.
struct OverlapRelaxation {
  double max_overlap = 0.0;  // prepare.relax_overlaps; 0: not asked for
  double factor = 1.0;       // h -> factor h
  Overlaps before, after;
};
// Lists the state's pairs (the deck's skin), measures their overlaps and, when the deck asks, dilates the cell
// (measure/micro overlap_dilation) so that none exceeds prepare.relax_overlaps. Scaled positions, velocities
// and contact history are kept; the pair list is rebuilt for the dilated cell.
OverlapRelaxation relax_overlaps(const Deck& deck, State& state);

// Where a preparation from initial_state starts: the loaded state (run/preflight load_initial_sample), its
// overlaps relaxed as asked, a new stage begun, with its solid fraction (solid volume / cell volume, as the
// fast leg's end measures it).
struct PreparationStart {
  State state;
  std::vector<std::int64_t> atom_ids;  // a LAMMPS data file's; empty for a state file
  OverlapRelaxation relaxation;
  double solid_fraction = 0.0;
};
PreparationStart preparation_start(const Deck& deck);

// Why the default program's fast leg is left out (core/plan preparation_program), for the log and summary.
std::string skipped_fast_leg_note(const Deck& deck, double start_solid_fraction);
// The start in words, a line each (no trailing newline): the file and its solid fraction, its overlaps and
// their relaxation, a fast leg left out. Printed by `run` and `check`.
std::string describe_preparation_start(const Deck& deck, const PreparationStart& start, int skipped);
// The same for a deck without prepare, whose tests start from initial_state as loaded (preparation_start
// relaxes nothing without prepare): the file, its solid fraction and its overlaps. Printed by `check`.
std::string describe_test_start(const Deck& deck, const PreparationStart& loaded);

}  // namespace celldem
