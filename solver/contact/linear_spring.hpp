// Linear spring contact law: normal spring kn, incremental tangential spring kt with a Coulomb slider.
// A stateless function: the stored tangential displacement goes in and comes out explicitly.
#pragma once
#include <cmath>

#include "core/types.hpp"
#include "io/deck.hpp"

namespace celldem {

struct ContactParams {
  double kn = 0.0;   // [N/m]
  double kt = 0.0;   // [N/m]
  double mu = 0.0;   // [-]
  TangentialRotation rotation = TangentialRotation::Rotate;
  MomentArm moment_arm = MomentArm::ContactPoint;
};

struct ContactResult {
  Vec3 force = Vec3::Zero();       // [N] on j by i (normal part along +branch: repulsion)
  Vec3 torque_i = Vec3::Zero();    // [N m] on i
  Vec3 torque_j = Vec3::Zero();    // [N m] on j
  Vec3 tangential = Vec3::Zero();  // [m] updated stored tangential displacement
  Vec3 normal = Vec3::Zero();      // unit vector from i to j
  double normal_force = 0.0;       // [N] >= 0
  bool touching = false;
  bool sliding = false;            // the trial tangential force reached the Coulomb limit
};

// branch: x_j - x_i [m] (j's periodic image), dv: velocity of j's centre minus i's (affine part included
// when the kinematics say so) [m/s], wi/wj spins [rad/s], xi the stored tangential displacement [m] of the
// previous step, dt [s].
[[gnu::always_inline]] inline ContactResult linear_spring_contact(const ContactParams& p, const Vec3& branch, double ri, double rj,
                                           const Vec3& dv, const Vec3& wi, const Vec3& wj, const Vec3& xi,
                                           double dt) {
  ContactResult out;
  const double reach = ri + rj;
  const double d2 = branch.squaredNorm();
  if (d2 >= reach * reach) return out;  // apart: history is forgotten
  const double d = std::sqrt(d2);
  const Vec3 n = branch * (1.0 / d);
  const double overlap = reach - d;
  // Lever arms from each centre to the contact point (middle of the overlap), or the plain radii.
  const double ai = p.moment_arm == MomentArm::ContactPoint ? ri - 0.5 * overlap : ri;
  const double aj = p.moment_arm == MomentArm::ContactPoint ? rj - 0.5 * overlap : rj;

  // Velocity of j's surface point relative to i's at the contact: dv + wj x (-aj n) - wi x (ai n).
  const Vec3 vc = dv - (ai * wi + aj * wj).cross(n);
  const Vec3 vt = vc - vc.dot(n) * n;

  // Bring the stored displacement into the current tangent plane, then add this step's slip.
  Vec3 s = xi - xi.dot(n) * n;
  if (p.rotation == TangentialRotation::Rotate) {
    const double before = xi.squaredNorm(), after = s.squaredNorm();
    if (after > 0.0) s *= std::sqrt(before / after);
  }
  s += vt * dt;

  const double fn = p.kn * overlap;
  Vec3 ft = -p.kt * s;
  const double ft_max = p.mu * fn;
  const double ft2 = ft.squaredNorm();
  if (ft2 > ft_max * ft_max) {  // Coulomb slider: cap the force and the spring with it
    const double scale = ft2 > 0.0 ? ft_max / std::sqrt(ft2) : 0.0;
    ft *= scale;
    s *= scale;
    out.sliding = true;
  }
  out.force = fn * n + ft;
  const Vec3 nxft = n.cross(ft);
  out.torque_i = -ai * nxft;
  out.torque_j = -aj * nxft;
  out.tangential = s;
  out.normal = n;
  out.normal_force = fn;
  out.touching = true;
  return out;
}

}  // namespace celldem
