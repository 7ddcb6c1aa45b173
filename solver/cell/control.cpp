#include "cell/control.hpp"

#include <algorithm>
#include <cmath>

namespace celldem {

void begin_stage(State& state) {
  state.control = ControlState{};
  state.control.reference_lengths = state.cell.h.diagonal();
  state.control.reference_volume = state.cell.volume();
}

void begin_phase(State& state, int phase) {
  state.control.phase = phase;
  state.control.phase_steps = 0;
}

void advance_cell(const Model& model, const Loading& loading, State& state) {
  Cell& cell = state.cell;
  ControlState& ctl = state.control;
  const Mat3 h_before = cell.h;
  const double next_step = static_cast<double>(ctl.phase_steps + 1);
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = loading.axes[k];
    switch (a.mode) {
      case AxisMode::StrainIncrement:  // exact engineering strain: no drift from summing increments
        cell.h(k, k) = ctl.reference_lengths[k] * (1.0 - next_step * a.value);
        break;
      case AxisMode::StrainRate:
        cell.h(k, k) = ctl.reference_lengths[k] * (1.0 - next_step * a.value * model.dt);
        break;
      case AxisMode::Stress: {
        const ServoDef& servo = model.servo;
        const double err = a.value - state.normal_stress[k];
        const double stiffness = state.axis_stiffness[k];
        double de;
        if (stiffness > 0.0) {
          de = (servo.gain * err + servo.integral_gain * (ctl.servo_integral[k] + err)) / stiffness;
        } else {
          de = err > 0.0 ? servo.max_strain_increment : -servo.max_strain_increment;  // nothing touches yet
        }
        if (std::abs(de) < servo.max_strain_increment) ctl.servo_integral[k] += err;
        de = std::clamp(de, -servo.max_strain_increment, servo.max_strain_increment);
        cell.h(k, k) *= 1.0 - de;
        break;
      }
    }
  }
  cell.velocity_gradient = (cell.h - h_before) / model.dt * (0.5 * (cell.h + h_before)).inverse();
  ++ctl.phase_steps;
}

Vec3 axis_strains(const State& state) {
  Vec3 e;
  for (int k = 0; k < 3; ++k) e[k] = 1.0 - state.cell.h(k, k) / state.control.reference_lengths[k];
  return e;
}

}  // namespace celldem
