// Mixed control of the periodic cell: during a leg of a load program each principal axis is strain-driven,
// stress-driven (servo) or volume-driven.
//
// Strain-driven axis k (strain_increment d or strain_rate r): after n steps of the leg its engineering strain
// against the stage start is exactly e_k = e_k(leg start) + n d (or n r dt); h_kk = L_k (1 - e_k).
//
// Stress-driven axes hold a target stress by the servo (per axis, once per step, compression positive):
//   err_k   = target_k - s_kk                       [Pa]  (s from the previous force evaluation)
//   I_k    += err_k                                  (not while the increment is saturated: anti-windup)
//   de_k    = (gain * err_k + integral_gain * I_k) / K_kk,   |de_k| <= cap (the leg's, core/plan servo_cap)
//   h_kk   *= 1 - de_k
// K_kk = (1/V) sum_c kn (n_k l_k)^2 is the affine stiffness of the axis measured from the contacts, so
// `gain` is the fraction of the stress error an affine step would remove. The targets (stress_targets()):
//   stress s:        s;
//   stress_ramp:     from + rate t, t the time since the leg start (the servo aims at the target of the step's
//                    end, t = (leg steps + 1) dt), so the target moves instead of stepping;
//   mean_stress p:   the axes share 3p minus the other axes' stresses equally (p held);
//   b:               s_minor + b (s_major - s_minor), s_major the strain-driven axis's stress, s_minor the other
//                    stress axis's; with a mean_stress minor axis both follow from b and p together:
//                    s_minor = (3p - (1 + b) s_major) / (2 - b).
// Constant-volume axes scale together (equal strain increments from the leg start) so that det h stays at
// the leg's start volume.
//
// Shear axes x12, x13, x23 drive the tilts of the upper-triangular cell, h(0,1), h(0,2), h(1,2) (LAMMPS's xy,
// xz, yz); the lower-triangular terms are always held. The engineering shear strain of axis ij, compression
// sign like the normal strains, is the tilt's change over the stage-start length of axis j:
//   g_ij = -(h(i,j) - h_ref(i,j)) / L_j,      i.e. h = (I - E) h_ref with E(i,j) = g_ij (the upper triangle).
// The sign makes g_ij and the contact shear stress s_ij (compression sign: (1/V) sum f (x) l) work-conjugate:
// a positive g_ij raises s_ij, so the shear servo is the normal one. A strain-driven shear axis follows
// g_ij = g_ij(leg start) + n d (or n r dt) exactly; a stress-driven one (target of either sign) steps
//   dg_ij = (gain * err + integral_gain * I) / K_ij,  |dg_ij| <= cap,   h(i,j) -= L_j dg_ij
// with K_ij = (1/V) sum_c kn (n_i l_j)^2 (state.shear_stiffness, contact/contact_forces.hpp). Why that sum:
// the affine tilt moves each branch by dl = -dg_ij l_j e_i, so a contact's overlap grows by n_i l_j dg_ij and
// its normal force by kn n_i l_j dg_ij along n; the symmetric part of that force (x) l, with l = |l| n, adds
// kn n_i l_j (n_i l_j) dg_ij to s_ij (n_i l_j = n_j l_i). Like K_kk it leaves out the tangential springs and
// the stress's own rotation (terms of order s_ij, far below kn); the servo needs the scale, not the bits.
// A shear axis a leg does not name keeps its tilt as it stands, untouched. A principal-axis rotation
// (core/deck.hpp PrincipalRotation) moves the targets of its plane's two normal axes and its shear axis,
// aimed, like a stress ramp's, at the step's end.
#pragma once
#include <array>
#include <optional>

#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

struct Loading {
  std::array<AxisControl, 3> axes;  // x1, x2, x3
  Friction friction;  // sliding and rolling
  double servo_cap = 0.0;  // [-] cap of a servo axis's strain per step (core/plan servo_cap); 0: the model's
  std::array<std::optional<AxisControl>, 3> shear = {};  // x12, x13, x23 (Leg::shear); none: the tilt held
  std::optional<PrincipalRotation> rotation = {};  // (Leg::rotation) its plane's stress targets move with the leg time
};

// Whether the loading's control reads the shear stresses (a stress-driven shear axis or a principal-axis
// rotation): only then does the pair loop sum them (contact/contact_forces.hpp); otherwise the state's shear
// stresses read zero after a step (the series measures them apart, measure/micro.hpp).
bool needs_shear_sums(const Loading& loading);

// Starts a stage from the state as it stands: step counters and servo memory reset, strains and volume
// measured from the current cell. The one place that resets the control.
void begin_stage(State& state);
// Starts leg `leg` of the stage's program where the previous one ended: its steps count afresh, its
// strain-driven axes start from their present strains, the servo's memory is cleared.
void begin_leg(State& state, int leg);
// The current leg goes on from the state as it stands at another rate (a rate check's branch): its steps and
// progress count afresh at factor 1 and its strain-driven axes, normal and shear, start from their present
// strains; the servo keeps its memory and a constant-volume axis the leg's volume.
void restart_leg(State& state);

// The target stresses of the stress-driven axes for the stresses s at `leg_time` [s] after the leg start (it
// moves stress_ramp targets only; NaN for axes that are not stress-driven).
Vec3 stress_targets(const std::array<AxisControl, 3>& axes, const Vec3& s, double leg_time);

// Sets the cell for the end of this step (state.control.leg_steps is the number of steps already done in
// the leg) and the velocity gradient L with hdot = L h_mid; state.servo_saturated says which servo axes
// moved by their cap in this step.
void advance_cell(const Model& model, const Loading& loading, State& state);

// Engineering strains of the cell relative to the stage start, compression positive.
Vec3 axis_strains(const State& state);
// Engineering shear strains g12, g13, g23 of the cell relative to the stage start (the convention above).
Vec3 shear_strains(const State& state);

}  // namespace celldem
