// Macro and micro measurements: pure functions of the state, computed only when a row is written.
#pragma once
#include <limits>

#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

struct Fabric {
  Mat3 all = Mat3::Zero();     // (1/Nc) sum n (x) n over all contacts
  Mat3 strong = Mat3::Zero();  // contacts with normal force above the mean
  Mat3 weak = Mat3::Zero();    // contacts with normal force at or below the mean
  std::int64_t contacts = 0, strong_contacts = 0;
};

// Contact normals from the stored pair list (the last force evaluation); normal force = kn * overlap.
Fabric contact_fabric(const Model& model, const State& state);

// Fabric of an explicit set of unit normals and normal forces (the definition, for tests and reuse).
Fabric fabric_of(const std::vector<Vec3>& normals, const std::vector<double>& normal_forces);

struct Coordination {
  double z = 0.0;          // 2 contacts / particles (the paper's definition)
  double z_mechanical = 0.0;  // the same without rattlers (fewer than min_contacts, removed iteratively)
  std::int64_t rattlers = 0;
};
// Rattlers have fewer than min_contacts contacts: 2 for frictional packings (a sphere with friction is held by
// two), d + 1 = 4 for frictionless ones.
inline constexpr int kFrictionalRattler = 2, kFrictionlessRattler = 4;
Coordination coordination(const State& state, int min_contacts = kFrictionalRattler);

// Mechanical coordination of an explicit contact list over n particles (for tests and reuse).
Coordination coordination_of(std::size_t n, const std::vector<std::pair<Index, Index>>& contacts,
                             int min_contacts = kFrictionalRattler);

double sliding_fraction(const State& state);  // contacts at the Coulomb limit / contacts
double kinetic_energy(const Model& model, const State& state);  // [J] fluctuating translation + rotation
double elastic_energy(const Model& model, const State& state);  // [J] stored in the contact springs
// Mean |net contact force| over particles / mean contact normal force (0 when nothing touches).
double unbalanced_force_ratio(const Model& model, const State& state);
double void_ratio(const Model& model, const State& state);

// Each particle's share of the contact stress [Pa], compression positive: (1/V_p) sum over its contacts of
// sym(f (x) l_p), f the pair's force on j by i and l_p the part of the branch on p's side, branch r_p/(r_i + r_j)
// (the standard particle stress with the contact point on the line of centres), so that the particles' V_p
// sigma_p add up to the cell's V sigma (contact_stress). From the last force evaluation. (N)
std::vector<Mat3> particle_stresses(const State& state);
// Each particle's net contact force [N] (the sum of its pairs' forces on it) of the last evaluation. (N)
std::vector<Vec3> net_contact_forces(const State& state);

// The overlaps of the listed pairs (an imported packing's, before it runs), relative to the smaller radius.
struct Overlaps {
  std::int64_t count = 0;       // touching pairs
  std::int64_t deep = 0;        // pairs overlapping by more than `deep` of the smaller radius
  double worst = 0.0;           // largest overlap / min(r_i, r_j)
  Index worst_i = 0, worst_j = 0;
  double closest = std::numeric_limits<double>::infinity();  // smallest centre distance / (r_i + r_j)
  Index closest_i = 0, closest_j = 0;
};
Overlaps overlaps(const State& state, double deep);
// The smallest isotropic dilation of the cell (h -> factor h, scaled positions kept) after which no listed
// pair overlaps by more than max_overlap of its smaller radius: the largest (r_i + r_j - max_overlap r_min) / d
// over the listed pairs, at least 1. A dilation only parts spheres, so the pairs listed before it suffice.
double overlap_dilation(const State& state, double max_overlap);

struct StressInvariants {
  double p = 0.0, q = 0.0, sin_phi = 0.0;  // [Pa], [Pa], [-]
};
StressInvariants stress_invariants(const Mat3& stress);
// Principal stresses of the symmetric tensor, descending (sigma1 >= sigma2 >= sigma3).
Vec3 principal_stresses(const Mat3& stress);
// b = (s2 - s3) / (s1 - s3) from the axis stresses s11, s22, s33 (NaN when s1 == s3).
double b_value(double s11, double s22, double s33);

}  // namespace celldem
