// A new sample: spheres of randomly chosen sizes at the points of a cubic grid (the paper's section 4).
#pragma once
#include "core/state.hpp"
#include "core/deck.hpp"

namespace celldem {

// n = ceil(count^(1/3)) points per side at grid_spacing; the first `count` grid points are used, each
// sphere offset by a small random amount inside its free gap so that the grid is not a perfect lattice.
// Sizes: each particle draws one of the listed diameters with equal probability (portable RNG).
State make_grid_sample(const SampleDef& sample, double skin);

}  // namespace celldem
