// The contact law, composed of stateless sub-models (normal, tangential, rolling, twisting) chosen at compile
// time: Law<...> is a template parameter of the pair loop, so there is no per-contact dispatch. The stored
// springs (tangential and rolling displacement, twist angle) go in and come out explicitly.
//
// Equations (n: unit normal from i to j, overlap d = ri + rj - |branch|, R* = ri rj / (ri + rj), a = sqrt(R* d)):
//   normal      linear          fn = kn d                                 tangent stiffness kn
//               hertz           fn = 4/3 E* a d  (= 4/3 E* sqrt(R*) d^3/2)  tangent stiffness 2 E* a
//   tangential  linear_history  ft = -kt xi                               |ft| <= mu fn (xi rescaled with it)
//               mindlin         ft = -8 G* a xi  (displacement history, no rescaling when a changes: LAMMPS's
//                                                 `tangential mindlin`; the force follows the contact radius, so a
//                                                 closed cycle of overlap and slip can return energy: loaded
//                                                 at a1 to xi, unloaded at a2 < a1, it gives back
//                                                 1/2 (k1 - k2) xi^2 less than it took, or more the other way)
//               mindlin_rescale as mindlin, and when a shrinks below the last step's a_old the stored xi is first
//                               scaled by a / a_old (not when a grows; LAMMPS's `tangential mindlin_rescale`,
//                               a_old kept per pair): unloading at a stretched spring loses energy (1/2 k xi^2
//                               falls as a^3), loading still adds 1/2 (k2 - k1) xi^2 as with mindlin
//   rolling     sds             v_roll = R* (w_j - w_i) x n, xi_r += v_roll dt (kept in the tangent plane, its
//                               length kept), f_r = -k_roll xi_r - gamma_roll v_roll, |f_r| <= mu_roll fn (then
//                               xi_r = -(f_r + gamma_roll v_roll) / k_roll); moment -R* n x f_r on i, +R* n x f_r on j
//   twisting    marshall        theta += (w_j - w_i).n dt, M = -k_tw theta, k_tw = 0.5 kt a^2 (kt: the tangential
//                               stiffness), |M| <= 2/3 a mu fn (theta rescaled); moment -M n on i, +M n on j
// E* = E / (2 (1 - nu^2)) and G* = E / (4 (2 - nu) (1 + nu)) for two spheres of one material (core/deck.hpp).
// The rolling and twisting laws follow LAMMPS's pair granular (Wang et al. 2015's rolling velocity; Marshall
// 2009's twisting); their sliders keep the direction of the spring(-dashpot) force.
//
// Every law is written without branches on plain doubles (Real3) so that the pair loop can evaluate it for
// several pairs at once in SIMD lanes: every choice is a select, and a pair that does not touch returns
// zeros. The arithmetic is the same operation for operation in any lane width (no contraction, no
// reassociation), so the results do not depend on the instruction set the loop was compiled for.
#pragma once
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "core/choices.hpp"
#include "core/deck.hpp"
#include "core/types.hpp"

namespace celldem {

// The sub-models, as a type.
template <NormalModel N, TangentialModel T, RollingModel R, TwistingModel W>
struct Law {
  static constexpr NormalModel normal = N;
  static constexpr TangentialModel tangential = T;
  static constexpr RollingModel rolling = R;
  static constexpr TwistingModel twisting = W;
  static constexpr bool contact_radius = N == NormalModel::Hertz || is_mindlin(T) ||
                                         W == TwistingModel::Marshall;  // a = sqrt(R* d) is needed
  static constexpr bool radius_history = T == TangentialModel::MindlinRescale;  // each pair keeps its last a
  static constexpr bool rotational = R != RollingModel::None || W != TwistingModel::None;  // rolling/twist springs
};
using LinearLaw = Law<NormalModel::Linear, TangentialModel::LinearHistory, RollingModel::None, TwistingModel::None>;

// Calls f(Law<...>{}) with the law the contact definition names: the one place where a run-time choice
// becomes a compile-time one.
template <class F>
decltype(auto) with_law(const ContactDef& c, F&& f) {
  const auto tw = [&](auto normal, auto tangential, auto rolling) -> decltype(auto) {
    constexpr NormalModel N = decltype(normal)::value;
    constexpr TangentialModel T = decltype(tangential)::value;
    constexpr RollingModel R = decltype(rolling)::value;
    if (c.twisting == TwistingModel::Marshall) return f(Law<N, T, R, TwistingModel::Marshall>{});
    return f(Law<N, T, R, TwistingModel::None>{});
  };
  const auto ro = [&](auto normal, auto tangential) -> decltype(auto) {
    if (c.rolling == RollingModel::Sds)
      return tw(normal, tangential, std::integral_constant<RollingModel, RollingModel::Sds>{});
    return tw(normal, tangential, std::integral_constant<RollingModel, RollingModel::None>{});
  };
  const auto ta = [&](auto normal) -> decltype(auto) {
    if (c.tangential == TangentialModel::Mindlin)
      return ro(normal, std::integral_constant<TangentialModel, TangentialModel::Mindlin>{});
    if (c.tangential == TangentialModel::MindlinRescale)
      return ro(normal, std::integral_constant<TangentialModel, TangentialModel::MindlinRescale>{});
    return ro(normal, std::integral_constant<TangentialModel, TangentialModel::LinearHistory>{});
  };
  if (c.normal == NormalModel::Hertz) return ta(std::integral_constant<NormalModel, NormalModel::Hertz>{});
  return ta(std::integral_constant<NormalModel, NormalModel::Linear>{});
}

// The law's constants for one stage.
struct ContactParams {
  double kn = 0.0;   // [N/m] linear
  double kt = 0.0;   // [N/m] linear_history
  double mu = 0.0;   // [-] sliding friction
  TangentialRotation rotation = TangentialRotation::Rotate;
  MomentArm moment_arm = MomentArm::ContactPoint;
  double e_eff = 0.0;       // [Pa] E* (hertz)
  double g_eff = 0.0;       // [Pa] G* (mindlin)
  double k_roll = 0.0;      // [N/m] (sds)
  double gamma_roll = 0.0;  // [N s/m] (sds)
  double mu_roll = 0.0;     // [-] (sds)
};

inline ContactParams contact_params(const ContactDef& c, const Friction& friction) {
  ContactParams p{c.kn, c.kt, friction.sliding, c.rotation, c.moment_arm};
  p.e_eff = c.effective_modulus();
  p.g_eff = c.effective_shear_modulus();
  p.k_roll = c.rolling_stiffness;
  p.gamma_roll = c.rolling_damping;
  p.mu_roll = friction.rolling;
  return p;
}

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

// The springs a contact remembers from step to step.
struct ContactHistory {
  Real3 tangential{0.0, 0.0, 0.0};  // [m] tangential spring displacement
  Real3 rolling{0.0, 0.0, 0.0};     // [m] rolling displacement (sds)
  double twist = 0.0;               // [rad] twist angle (marshall)
  double contact_radius = 0.0;      // [m] a of the last step (mindlin_rescale; 0 for a new contact)
};

struct PairContact {
  Real3 force;       // [N] on j by i (normal part along +branch: repulsion)
  Real3 torque_i;    // [N m] on i
  Real3 torque_j;    // [N m] on j
  ContactHistory history;  // updated springs (zero when apart: history is forgotten)
  Real3 normal;      // unit vector from i to j (meaningful only when touching)
  double normal_force;      // [N] >= 0
  double normal_stiffness;  // [N/m] d fn / d overlap (0 when apart): the servo's axis stiffness
  bool touching;
  bool sliding;      // the trial tangential force reached the Coulomb limit
  // What the step dissipated at this contact (the energy budget, measure/energy.hpp; the pair loop sums them
  // only when asked, and the compiler drops them otherwise): the Coulomb cap's force times the slip it made,
  // the same at the rolling and twisting caps, and the rolling dashpot's force times the rolling motion.
  double slip_work = 0.0;             // [J]
  double rotational_slip_work = 0.0;  // [J]
  double dashpot_work = 0.0;          // [J]
};

// ---- sub-models: plain functions ----

struct NormalForce {
  double force;      // [N]
  double stiffness;  // [N/m] tangent
};
inline NormalForce normal_linear(double kn, double overlap) { return {kn * overlap, kn}; }
// a: contact radius sqrt(R* overlap).
inline NormalForce normal_hertz(double e_eff, double a, double overlap) {
  return {4.0 / 3.0 * e_eff * a * overlap, 2.0 * e_eff * a};
}

inline double tangential_stiffness_mindlin(double g_eff, double a) { return 8.0 * g_eff * a; }

// mindlin_rescale's factor on the stored displacement: a / a_old when the contact radius shrank since the last
// step, else 1 (a new contact has a_old = 0). As LAMMPS, before the displacement is turned into the tangent plane.
inline double mindlin_rescale_factor(double a, double a_old) { return a < a_old ? a / a_old : 1.0; }

// Brings a stored displacement into the tangent plane of n: projected, and (rotate) rescaled to its former length.
inline Real3 into_tangent_plane(Real3 xi, Real3 n, bool rotate) {
  Real3 s = xi - dot(xi, n) * n;
  const double before = dot(xi, xi), after = dot(s, s);
  const bool rescale = rotate && after > 0.0;
  return (rescale ? std::sqrt(before / after) : 1.0) * s;
}

// The rolling spring-dashpot-slider: xi the rolling displacement after this step's motion, v the rolling
// velocity. Returns the force and the displacement after the slider.
struct SpringSlider {
  Real3 force;
  Real3 displacement;
  bool sliding;
};
inline SpringSlider rolling_sds(double k, double gamma, double limit, Real3 xi, Real3 v) {
  const Real3 f = -k * xi - gamma * v;
  const double f2 = dot(f, f);
  const bool sliding = f2 > limit * limit;
  const Real3 capped = (sliding ? limit / std::sqrt(f2) : 1.0) * f;
  const Real3 slipped = (-1.0 / k) * (capped + gamma * v);
  return {capped, select(sliding, slipped, xi), sliding};
}

// The twisting spring-slider (Marshall): theta the twist angle after this step's motion.
struct TwistSpring {
  double moment;  // [N m] about n, on j
  double angle;   // [rad]
};
inline TwistSpring twisting_marshall(double k, double limit, double theta) {
  const double m = -k * theta;
  const bool sliding = std::abs(m) > limit;
  const double capped = sliding ? std::copysign(limit, m) : m;
  return {capped, sliding ? -capped / k : theta};
}

// Lever arms from each centre to the contact point: the middle of the overlap (ContactPoint), or the radii.
struct LeverArms {
  double i, j;  // [m]
};
inline LeverArms lever_arms(MomentArm arm, double ri, double rj, double overlap) {
  const double shift = arm == MomentArm::ContactPoint ? 0.5 : 0.0;
  return {ri - shift * overlap, rj - shift * overlap};
}

// ---- the composed law ----

// branch: x_j - x_i [m] (j's periodic image), dv: velocity of j's centre minus i's (affine part included
// when the kinematics say so) [m/s], wi/wj spins [rad/s], h the springs of the previous step, dt [s].
template <class L>
[[gnu::always_inline]] inline PairContact contact_law(const ContactParams& p, Real3 branch, double ri, double rj,
                                                      Real3 dv, Real3 wi, Real3 wj, const ContactHistory& h,
                                                      double dt) {
  const double reach = ri + rj;
  const double d2 = dot(branch, branch);
  const bool touching = d2 < reach * reach;
  const double d = std::sqrt(d2);
  const Real3 n = (1.0 / d) * branch;
  const double overlap = reach - d;
  const double r_eff = ri * rj / reach;
  double a = 0.0;  // contact radius
  if constexpr (L::contact_radius) a = std::sqrt(r_eff * std::max(overlap, 0.0));
  const LeverArms arms = lever_arms(p.moment_arm, ri, rj, overlap);
  const double ai = arms.i, aj = arms.j;

  // Velocity of j's surface point relative to i's at the contact: dv + wj x (-aj n) - wi x (ai n).
  const Real3 vc = dv - cross(ai * wi + aj * wj, n);
  const Real3 vt = vc - dot(vc, n) * n;

  // The stored displacement in the current tangent plane, plus this step's slip.
  Real3 s = h.tangential;
  if constexpr (L::radius_history) s = mindlin_rescale_factor(a, h.contact_radius) * s;
  s = into_tangent_plane(s, n, p.rotation == TangentialRotation::Rotate);
  const Real3 s_start = s;  // (the energy budget's credit below; rotating keeps the spring's energy)
  s = s + dt * vt;

  NormalForce normal;
  if constexpr (L::normal == NormalModel::Hertz) normal = normal_hertz(p.e_eff, a, overlap);
  else normal = normal_linear(p.kn, overlap);
  const double fn = normal.force;
  double kt = p.kt;
  if constexpr (is_mindlin(L::tangential)) kt = tangential_stiffness_mindlin(p.g_eff, a);

  // Coulomb slider: cap the force, and the spring with it.
  Real3 ft = -kt * s;
  const double ft_max = p.mu * fn;
  const double ft2 = dot(ft, ft);
  const bool sliding = ft2 > ft_max * ft_max;
  const double cap = sliding ? ft_max / std::sqrt(ft2) : 1.0;
  // The slip the cap makes, (1 - cap) s_trial, paid at the mean of the step's start and end spring forces, as
  // the leapfrog's own work pays it: 1/2 kt (s_start + s_capped).(s_trial - s_capped). Paid at the end force
  // alone, the budget's closure was first order in the strain per step (docs/energy.md).
  const double slip_work = sliding ? 0.5 * kt * (1.0 - cap) * dot(s_start + cap * s, s) : 0.0;
  ft = cap * ft;
  s = cap * s;

  const Real3 zero{0.0, 0.0, 0.0};
  const Real3 nxft = cross(n, ft);
  Real3 torque_i = -ai * nxft, torque_j = -aj * nxft;
  PairContact out;
  if constexpr (L::rolling == RollingModel::Sds) {
    const Real3 v_roll = r_eff * cross(wj - wi, n);
    const Real3 xi = into_tangent_plane(h.rolling, n, true) + dt * v_roll;
    const SpringSlider roll = rolling_sds(p.k_roll, p.gamma_roll, p.mu_roll * fn, xi, v_roll);
    const Real3 moment = r_eff * cross(n, roll.force);
    torque_i = torque_i - moment;
    torque_j = torque_j + moment;
    out.history.rolling = select(touching, roll.displacement, zero);
    const Real3 roll_slip = xi - roll.displacement;  // (zero unless the slider slid)
    const double roll_cap =
        roll.sliding
            ? p.mu_roll * fn /
                  std::sqrt(dot(-p.k_roll * xi - p.gamma_roll * v_roll, -p.k_roll * xi - p.gamma_roll * v_roll))
            : 1.0;
    out.rotational_slip_work = touching ? std::sqrt(dot(roll.force, roll.force) * dot(roll_slip, roll_slip)) : 0.0;
    out.dashpot_work = touching ? roll_cap * p.gamma_roll * dot(v_roll, v_roll) * dt : 0.0;
  }
  if constexpr (L::twisting == TwistingModel::Marshall) {
    const double rate = dot(wj - wi, n);
    const double k_twist = 0.5 * kt * a * a;
    const TwistSpring twist = twisting_marshall(k_twist, 2.0 / 3.0 * a * p.mu * fn, h.twist + dt * rate);
    torque_i = torque_i - twist.moment * n;
    torque_j = torque_j + twist.moment * n;
    out.history.twist = touching && k_twist > 0.0 ? twist.angle : 0.0;
    const double twist_slip = h.twist + dt * rate - twist.angle;  // (zero unless the slider slid)
    out.rotational_slip_work += touching && k_twist > 0.0 ? std::abs(twist.moment * twist_slip) : 0.0;
  }

  out.force = select(touching, fn * n + ft, zero);
  out.torque_i = select(touching, torque_i, zero);
  out.torque_j = select(touching, torque_j, zero);
  out.history.tangential = select(touching, s, zero);
  if constexpr (L::radius_history) out.history.contact_radius = touching ? a : 0.0;
  out.normal = n;
  out.normal_force = touching ? fn : 0.0;
  out.normal_stiffness = touching ? normal.stiffness : 0.0;
  out.touching = touching;
  out.sliding = touching && sliding;
  out.slip_work = touching ? slip_work : 0.0;
  return out;
}

// ---- the law in Eigen types, for callers outside the pair loop (tests, measurements) ----

inline Real3 real3(const Vec3& v) { return {v[0], v[1], v[2]}; }
inline Vec3 vec3(Real3 v) { return {v.x, v.y, v.z}; }

struct ContactResult {
  Vec3 force = Vec3::Zero();
  Vec3 torque_i = Vec3::Zero();
  Vec3 torque_j = Vec3::Zero();
  Vec3 tangential = Vec3::Zero();
  Vec3 rolling = Vec3::Zero();
  double twist = 0.0;
  double contact_radius = 0.0;  // (mindlin_rescale)
  Vec3 normal = Vec3::Zero();
  double normal_force = 0.0;
  double normal_stiffness = 0.0;
  bool touching = false;
  bool sliding = false;
  double slip_work = 0.0, rotational_slip_work = 0.0, dashpot_work = 0.0;  // [J] (PairContact)
};

template <class L>
ContactResult evaluate_contact(const ContactParams& p, const Vec3& branch, double ri, double rj, const Vec3& dv,
                               const Vec3& wi, const Vec3& wj, const ContactHistory& h, double dt) {
  const PairContact c = contact_law<L>(p, real3(branch), ri, rj, real3(dv), real3(wi), real3(wj), h, dt);
  ContactResult r;
  if (!c.touching) return r;
  r.force = vec3(c.force);
  r.torque_i = vec3(c.torque_i);
  r.torque_j = vec3(c.torque_j);
  r.tangential = vec3(c.history.tangential);
  r.rolling = vec3(c.history.rolling);
  r.twist = c.history.twist;
  r.contact_radius = c.history.contact_radius;
  r.normal = vec3(c.normal);
  r.normal_force = c.normal_force;
  r.normal_stiffness = c.normal_stiffness;
  r.touching = true;
  r.sliding = c.sliding;
  r.slip_work = c.slip_work, r.rotational_slip_work = c.rotational_slip_work, r.dashpot_work = c.dashpot_work;
  return r;
}

inline ContactResult linear_spring_contact(const ContactParams& p, const Vec3& branch, double ri, double rj,
                                           const Vec3& dv, const Vec3& wi, const Vec3& wj, const Vec3& xi,
                                           double dt) {
  return evaluate_contact<LinearLaw>(p, branch, ri, rj, dv, wi, wj, {real3(xi), {0.0, 0.0, 0.0}, 0.0}, dt);
}

}  // namespace celldem
