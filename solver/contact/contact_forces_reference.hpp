// The pair loop written plainly, for the tests to hold the fast one (contact/contact_forces.cpp) against:
// one scalar loop over the listed pairs in list order, each pair through the contact law once, its force
// and moments added to both ends, the cell's sums added up. No chunks, SIMD lanes, force blocks, reduction
// blocks or incoming-pair lists. Not used by the solver.
#pragma once
#include <cstdint>
#include <vector>

#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// What one evaluation of the pairs gives, as the fast path leaves it in the state (its pair arrays, the
// particles' force and torque after gather_forces, stress, stiffness and touching).
struct ReferenceContactForces {
  // Per listed pair, in list order (the history arrays sized as the pair list's).
  std::vector<Vec3> force;             // (P) [N] on j by i
  std::vector<Vec3> tangential;        // (P) [m] the tangential spring after the step
  std::vector<Vec3> rolling;           // (P or 0) [m] the rolling spring after the step
  std::vector<double> twist;           // (P or 0) [rad] the twist angle after the step
  std::vector<double> contact_radius;  // (P or 0) [m] this step's contact radius
  std::vector<std::uint8_t> flags;     // (P) PairFlag bits
  // Per particle: the sums over its pairs, in list order, starting from zero.
  std::vector<Vec3> net_force;   // (N) [N]
  std::vector<Vec3> net_torque;  // (N) [N m]
  // Per cell: sums over the pairs in list order, divided by the cell volume.
  // [Pa] per component (x1 x2 x3 x12 x13 x23): sum of force_k branch_k / V (component by component), then of
  // (force_i l_j + force_j l_i) / 2V; the stiffnesses sum of kn (n_i l_j)^2 / V.
  Vec6 stress = Vec6::Zero();
  Vec6 stiffness = Vec6::Zero();
  std::int64_t touching = 0;           // pairs in contact
};

// The contact forces of the state as it stands (its pair list built, as compute_contact_forces requires),
// the state left unchanged. advance_slip as for compute_contact_forces.
ReferenceContactForces reference_contact_forces(const Model& model, const Friction& friction, const State& state,
                                                bool advance_slip = true);

}  // namespace celldem
