// A new sample: spheres of randomly chosen sizes at the points of a cubic grid (the paper's section 4).
#pragma once
#include "core/state.hpp"
#include "core/deck.hpp"

namespace celldem {

// n = ceil(count^(1/3)) points per side at grid_spacing; the first `count` grid points are used, each
// sphere offset by a small random amount inside its free gap so that the grid is not a perfect lattice.
// Sizes: each particle draws one of the listed diameters with equal probability, or, with a grading, a
// diameter by inverse transform of the grading's number distribution (core/grading.hpp); portable RNG.
State make_grid_sample(const SampleDef& sample, double skin);

// The diameters [m] that make_grid_sample gives a graded sample's spheres, in particle order, without
// building it; empty for the listed forms.
std::vector<double> graded_sample_diameters(const SampleDef& sample);

}  // namespace celldem
