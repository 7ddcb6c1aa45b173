// Linear spring contact law: normal spring kn, incremental tangential spring kt with a Coulomb slider.
// A stateless function: the stored tangential displacement goes in and comes out explicitly.
//
// The law is written without branches on plain doubles (Real3) so that the pair loop can evaluate it for
// several pairs at once in SIMD lanes: every choice is a select, and a pair that does not touch returns
// zeros. The arithmetic is the same operation for operation in any lane width (no contraction, no
// reassociation), so the results do not depend on the instruction set the loop was compiled for.
#pragma once
#include <cmath>

#include "core/types.hpp"
#include "core/choices.hpp"

namespace celldem {

struct ContactParams {
  double kn = 0.0;   // [N/m]
  double kt = 0.0;   // [N/m]
  double mu = 0.0;   // [-]
  TangentialRotation rotation = TangentialRotation::Rotate;
  MomentArm moment_arm = MomentArm::ContactPoint;
};

// A 3-vector as three doubles. Sums run left to right, as Eigen's do, so both give the same bits.
struct Real3 {
  double x, y, z;
};
inline Real3 operator+(Real3 a, Real3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Real3 operator-(Real3 a, Real3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Real3 operator*(double s, Real3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Real3 a, Real3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Real3 cross(Real3 a, Real3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline Real3 select(bool c, Real3 a, Real3 b) { return {c ? a.x : b.x, c ? a.y : b.y, c ? a.z : b.z}; }

struct PairContact {
  Real3 force;       // [N] on j by i (normal part along +branch: repulsion)
  Real3 torque_i;    // [N m] on i
  Real3 torque_j;    // [N m] on j
  Real3 tangential;  // [m] updated stored tangential displacement (zero when apart: history is forgotten)
  Real3 normal;      // unit vector from i to j (meaningful only when touching)
  double normal_force;  // [N] >= 0
  bool touching;
  bool sliding;      // the trial tangential force reached the Coulomb limit
};

// branch: x_j - x_i [m] (j's periodic image), dv: velocity of j's centre minus i's (affine part included
// when the kinematics say so) [m/s], wi/wj spins [rad/s], xi the stored tangential displacement [m] of the
// previous step, dt [s].
[[gnu::always_inline]] inline PairContact contact_law(const ContactParams& p, Real3 branch, double ri, double rj,
                                                      Real3 dv, Real3 wi, Real3 wj, Real3 xi, double dt) {
  const double reach = ri + rj;
  const double d2 = dot(branch, branch);
  const bool touching = d2 < reach * reach;
  const double d = std::sqrt(d2);
  const Real3 n = (1.0 / d) * branch;
  const double overlap = reach - d;
  // Lever arms from each centre to the contact point (middle of the overlap), or the plain radii.
  const double arm_shift = p.moment_arm == MomentArm::ContactPoint ? 0.5 : 0.0;
  const double ai = ri - arm_shift * overlap, aj = rj - arm_shift * overlap;

  // Velocity of j's surface point relative to i's at the contact: dv + wj x (-aj n) - wi x (ai n).
  const Real3 vc = dv - cross(ai * wi + aj * wj, n);
  const Real3 vt = vc - dot(vc, n) * n;

  // Bring the stored displacement into the current tangent plane (keeping its length when rotating), then
  // add this step's slip.
  Real3 s = xi - dot(xi, n) * n;
  const double before = dot(xi, xi), after = dot(s, s);
  const bool rescale = p.rotation == TangentialRotation::Rotate && after > 0.0;
  s = (rescale ? std::sqrt(before / after) : 1.0) * s;
  s = s + dt * vt;

  // Coulomb slider: cap the force, and the spring with it.
  const double fn = p.kn * overlap;
  Real3 ft = -p.kt * s;
  const double ft_max = p.mu * fn;
  const double ft2 = dot(ft, ft);
  const bool sliding = ft2 > ft_max * ft_max;
  const double cap = sliding ? ft_max / std::sqrt(ft2) : 1.0;
  ft = cap * ft;
  s = cap * s;

  const Real3 nxft = cross(n, ft);
  const Real3 zero{0.0, 0.0, 0.0};
  PairContact out;
  out.force = select(touching, fn * n + ft, zero);
  out.torque_i = select(touching, -ai * nxft, zero);
  out.torque_j = select(touching, -aj * nxft, zero);
  out.tangential = select(touching, s, zero);
  out.normal = n;
  out.normal_force = touching ? fn : 0.0;
  out.touching = touching;
  out.sliding = touching && sliding;
  return out;
}

// The law in Eigen types, for callers outside the pair loop (tests, measurements).
struct ContactResult {
  Vec3 force = Vec3::Zero();
  Vec3 torque_i = Vec3::Zero();
  Vec3 torque_j = Vec3::Zero();
  Vec3 tangential = Vec3::Zero();
  Vec3 normal = Vec3::Zero();
  double normal_force = 0.0;
  bool touching = false;
  bool sliding = false;
};

inline Real3 real3(const Vec3& v) { return {v[0], v[1], v[2]}; }
inline Vec3 vec3(Real3 v) { return {v.x, v.y, v.z}; }

inline ContactResult linear_spring_contact(const ContactParams& p, const Vec3& branch, double ri, double rj,
                                           const Vec3& dv, const Vec3& wi, const Vec3& wj, const Vec3& xi,
                                           double dt) {
  const PairContact c = contact_law(p, real3(branch), ri, rj, real3(dv), real3(wi), real3(wj), real3(xi), dt);
  ContactResult r;
  if (!c.touching) return r;
  r.force = vec3(c.force);
  r.torque_i = vec3(c.torque_i);
  r.torque_j = vec3(c.torque_j);
  r.tangential = vec3(c.tangential);
  r.normal = vec3(c.normal);
  r.normal_force = c.normal_force;
  r.touching = true;
  r.sliding = c.sliding;
  return r;
}

}  // namespace celldem
