// Mixed control of the periodic cell: during a leg of a load program each of the six components of the cell
// (core/choices.hpp kComponentNames: x1 x2 x3, the axes' lengths h(k,k); x12 x13 x23, the tilts h(0,1), h(0,2),
// h(1,2) of the upper-triangular cell, LAMMPS's xy xz yz) is strain-driven, stress-driven (servo), held, or
// (a normal axis) volume-driven. One model for all six; only the geometry of a component differs:
//
// Strain of component k against the stage start (compression sign):
//   normal k:   e_k  = 1 - h(k,k) / L_k,                     L_k = h(k,k) at the stage start
//   shear ij:   g_ij = -(h(i,j) - h_ref(i,j)) / L_j,          i.e. h = (I - E) h_ref with E(i,j) = g_ij
// The sign makes g_ij and the contact shear stress s_ij (compression sign: (1/V) sum f (x) l) work-conjugate:
// a positive g_ij raises s_ij, as a positive e_k raises s_kk, so one servo law serves every component.
//
// Strain-driven (strain_increment d or strain_rate r): after a leg progress n (steps at the deck's rate) the
// strain is exactly e_k = e_k(leg start) + n d (or n r dt): no drift from summing increments.
//
// Stress-driven components hold a target by the servo (per component, once per step):
//   err_k   = target_k - s_k                        [Pa]  (s from the previous force evaluation)
//   I_k    += err_k                                  (not while the increment is saturated: anti-windup)
//   de_k    = (gain * err_k + integral_gain * I_k) / K_k,   |de_k| <= cap (the leg's, core/plan servo_cap)
//   normal: h(k,k) *= 1 - de_k;   shear: h(i,j) -= L_j de_k
// K_k is the affine stiffness of the component from the contacts' normal springs, (1/V) sum_c kn (n_i l_j)^2
// (state.stiffness): the affine strain moves each branch by dl = -de l_j e_i, so a contact's overlap grows by
// n_i l_j de and its normal force by kn n_i l_j de along n, adding kn (n_i l_j)^2 de to s_ij. It leaves out the
// tangential springs and the stress's own rotation (terms of order s_ij, far below kn): the servo needs the
// scale, not the bits. So `gain` is the fraction of the stress error an affine step would remove.
// The targets (control_targets()):
//   stress s:        s (a shear component's of either sign);
//   stress_ramp:     from + rate t, t the time since the leg start (the servo aims at the target of the step's
//                    end, t = (leg steps + 1) dt), so the target moves instead of stepping;
//   mean_stress p:   the axes share 3p minus the other axes' stresses equally (p held);
//   b:               s_minor + b (s_major - s_minor), s_major the strain-driven axis's stress, s_minor the other
//                    stress axis's; with a mean_stress minor axis both follow from b and p together:
//                    s_minor = (3p - (1 + b) s_major) / (2 - b);
//   a principal-axis rotation (core/deck.hpp PrincipalRotation) moves the targets of its plane's two normal
//   axes and its shear axis, aimed like a ramp's at the step's end; its other two shear axes hold 0.
// Constant-volume axes scale together (equal strain increments from the leg start) so that det h stays at the
// leg's start volume. A held component keeps its cell entry as it stands, untouched. The lower-triangular
// entries of h are always held.
#pragma once
#include <array>
#include <optional>

#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

struct Loading {
  std::array<AxisControl, kComponents> axes;  // x1 x2 x3 x12 x13 x23 (Leg::axes)
  Friction friction;  // sliding and rolling
  double servo_cap = 0.0;  // [-] cap of a servo component's strain per step (core/plan servo_cap); 0: the model's
  std::optional<PrincipalRotation> rotation = {};  // (Leg::rotation) its plane's stress targets move with the leg time
};

// The cell entries of the six components, h(i, j) for kComponentEntries.
Vec6 cell_components(const Mat3& h);

// Whether the loading's control reads the shear stresses (a stress-driven shear component): only then does the
// pair loop sum them (contact/contact_forces.hpp); otherwise the state's shear stresses read zero after a step
// (the series measures them apart, measure/micro.hpp).
bool needs_shear_sums(const Loading& loading);

// Starts a stage from the state as it stands: step counters and servo memory reset, strains and volume
// measured from the current cell. The one place that resets the control.
void begin_stage(State& state);
// Starts leg `leg` of the stage's program where the previous one ended: its steps count afresh, its
// strain-driven components start from their present strains, the servo's memory is cleared.
void begin_leg(State& state, int leg);
// The current leg goes on from the state as it stands at another rate (a rate check's branch): its steps and
// progress count afresh at factor 1 and its strain-driven components start from their present strains; the
// servo keeps its memory and a constant-volume axis the leg's volume.
void restart_leg(State& state);

// The targets of the leg's servo components for the stresses s at `leg_time` [s] after the leg start (NaN for
// components that are not stress-driven): the rules above, in one place for the servo and the control checks.
Vec6 control_targets(const std::array<AxisControl, kComponents>& axes, const std::optional<PrincipalRotation>& rotation,
                     const Vec6& s, double leg_time, double dt);
// The normal axes' part (no rotation): what the equilibrium check and the translator read.
Vec3 stress_targets(const std::array<AxisControl, kComponents>& axes, const Vec3& s, double leg_time);

// Sets the cell for the end of this step (state.control.leg_steps is the number of steps already done in
// the leg) and the velocity gradient L with hdot = L h_mid; state.servo_saturated says which servo components
// moved by their cap in this step.
void advance_cell(const Model& model, const Loading& loading, State& state);

// Strains of the six components relative to the stage start, compression positive (the convention above).
Vec6 component_strains(const State& state);
// The normal axes' engineering strains, and the shear axes' g12, g13, g23.
inline Vec3 axis_strains(const State& state) { return component_strains(state).head<3>(); }
inline Vec3 shear_strains(const State& state) { return component_strains(state).tail<3>(); }

}  // namespace celldem
