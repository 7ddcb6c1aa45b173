// Mixed control of the periodic cell: each principal axis is strain-driven or stress-driven (servo).
//
// Servo law (per stress-controlled axis k, once per step, compression positive):
//   err_k   = target_k - s_kk                       [Pa]  (s from the previous force evaluation)
//   I_k    += err_k                                  (not while the increment is saturated: anti-windup)
//   de_k    = (gain * err_k + integral_gain * I_k) / K_kk,   |de_k| <= max_strain_increment
//   h_kk   *= 1 - de_k
// K_kk = (1/V) sum_c kn (n_k l_k)^2 is the affine stiffness of the axis measured from the contacts, so
// `gain` is the fraction of the stress error an affine step would remove (dimensionless, default 0.05),
// and the integral term removes the steady lag a proportional servo has while the sample dilates.
#pragma once
#include <array>

#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

struct Loading {
  std::array<AxisControl, 3> axes;  // x1, x2, x3
  double friction = 0.0;
};

// Starts a stage from the state as it stands: step counters and servo memory reset, strains and volume
// measured from the current cell. The one place that resets the control.
void begin_stage(State& state);
// Starts the next phase of a stage: its strain-driven axes count their steps afresh; strains in the series
// stay relative to the stage start.
void begin_phase(State& state, int phase);

// Sets the cell for the end of this step (state.control.phase_steps is the number of steps already done in
// the phase) and the velocity gradient L with hdot = L h_mid. Off-diagonal terms of h are held.
void advance_cell(const Model& model, const Loading& loading, State& state);

// Engineering strains of the cell relative to the stage start, compression positive.
Vec3 axis_strains(const State& state);

}  // namespace celldem
