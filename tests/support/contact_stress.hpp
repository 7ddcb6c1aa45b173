// The full contact stress tensor of the last force evaluation as one call, for tests. The solver never needs it
// alone: the step keeps the diagonal (state.stress.head<3>()) and a series row takes the tensor from
// measure_contacts (measure/micro.hpp), which walks the pairs once for everything a row needs.
#pragma once
#include "contact/contact_forces.hpp"
#include "core/state.hpp"

namespace celldem::testing {

// [Pa] symmetric part, compression positive: ContactStressSum over the pair list, in list order, divided by
// the cell volume, so that its diagonal is state.stress.head<3>() to the bit.
inline Mat3 contact_stress(const State& state) {
  const Particles& p = state.particles;
  const PairList& pl = state.pairs;
  ContactStressSum sum(state.cell.h);
  for_each_pair(pl, [&](Index i, Index q) {
    sum.add(i, pl.force[q], p.scaled[pl.neighbor[q]] - p.scaled[i] + Vec3(pl.image[q][0], pl.image[q][1], pl.image[q][2]));
  });
  return sum.stress(state.cell.volume());
}

}  // namespace celldem::testing
