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
  double mean_normal_force = 0.0;  // [N] (1/Nc) sum of the normal forces (0 without contacts)
};

// Fabric of an explicit set of unit normals and normal forces: the definition (measure_contacts applies it
// to the contacts of the pair list).
Fabric fabric_of(const std::vector<Vec3>& normals, const std::vector<double>& normal_forces);

struct Coordination {
  double z = 0.0;          // 2 contacts / particles (the paper's definition)
  double z_mechanical = 0.0;  // the same without rattlers (fewer than min_contacts, removed iteratively)
  std::int64_t rattlers = 0;
};
// Rattlers have fewer than min_contacts contacts: 2 for frictional packings (a sphere with friction is held by
// two), d + 1 = 4 for frictionless ones.
inline constexpr int kFrictionalRattler = 2, kFrictionlessRattler = 4;

// Which of n particles are rattlers of an explicit contact list: fewer than min_contacts contacts, removed
// iteratively (a rattler's contacts no longer count for its neighbours) until none is left below. (n)
std::vector<char> rattlers_of(std::size_t n, const std::vector<std::pair<Index, Index>>& contacts, int min_contacts);

// Mechanical coordination of an explicit contact list over n particles: the definition (measure_contacts
// applies it to the touching pairs of the list, under both rules; its rattlers are rattlers_of's).
Coordination coordination_of(std::size_t n, const std::vector<std::pair<Index, Index>>& contacts,
                             int min_contacts = kFrictionalRattler);

// Everything that a series row, the health checks (run/health), the preparation's equilibrium check
// (quasi_static) and its summary read from the contacts and particles of the last force evaluation, measured
// by one walk of the pair list in list order and one of the particles. Each quantity has this one
// definition; callers read its fields.
struct ContactMeasures {
  Mat3 stress = Mat3::Zero();   // [Pa] contact stress, compression + (ContactStressSum: contact/contact_forces.hpp)
  Fabric fabric;                // all / strong / weak, the contact count and the mean normal force
  Coordination coordination;               // rattlers: fewer than kFrictionalRattler contacts
  Coordination coordination_frictionless;  // rattlers: fewer than kFrictionlessRattler contacts
  std::int64_t sliding = 0;        // contacts at the Coulomb limit
  double sliding_fraction = 0.0;   // sliding / contacts (0 without contacts)
  double kinetic_energy = 0.0;     // [J] fluctuating translation + rotation
  // [J] stored in the contact springs. Normal spring: fn^2 / (2 kn), or Hertz's 2/5 fn overlap; tangential:
  // |ft|^2 / (2 kt), kt the law's stiffness at this contact (mindlin: 8 G* a); rolling: k_roll |xi_r|^2 / 2;
  // twist: k_tw theta^2 / 2.
  double elastic_energy = 0.0;
  // Mean |net contact force| over particles / mean contact normal force (0 when nothing touches).
  double unbalanced_force = 0.0;
};
ContactMeasures measure_contacts(const Model& model, const State& state);

double void_ratio(const Model& model, const State& state);

// The scaled separation s_j - s_i + image of listed pair q, owned by i, and its branch vector h (that) [m]:
// x_j - x_i across the pair's periodic image.
Vec3 pair_scaled_separation(const State& state, Index i, Index q);
Vec3 pair_branch(const State& state, Index i, Index q);

// Each particle's share of the contact stress [Pa], compression positive: (1/V_p) sum over its contacts of
// sym(f (x) l_p), f the pair's force on j by i and l_p the part of the branch on p's side, branch r_p/(r_i + r_j)
// (the standard particle stress with the contact point on the line of centres), so that the particles' V_p
// sigma_p add up to the cell's V sigma (ContactMeasures::stress). From the last force evaluation. (N)
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
