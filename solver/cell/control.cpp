#include "cell/control.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace celldem {

Vec6 cell_components(const Mat3& h) {
  Vec6 c;
  for (int k = 0; k < kComponents; ++k) c[k] = h(kComponentEntries[k][0], kComponentEntries[k][1]);
  return c;
}

bool needs_shear_sums(const Loading& loading) {
  for (int k = 3; k < kComponents; ++k)
    if (loading.axes[k].stress_driven()) return true;
  return false;
}

void begin_stage(State& state) {
  state.control = ControlState{};
  state.control.reference = cell_components(state.cell.h);
  state.control.reference_volume = state.cell.volume();
  state.control.leg_start_volume = state.control.reference_volume;
}

void restart_leg(State& state) {
  ControlState& c = state.control;
  c.leg_steps = 0;
  c.leg_progress = 0.0;
  c.rate_factor = 1.0;
  c.leg_start_strains = component_strains(state);
}

void begin_leg(State& state, int leg) {
  ControlState& c = state.control;
  c.leg = leg;
  restart_leg(state);
  c.leg_start_volume = state.cell.volume();
  c.servo_integral = Vec6::Zero();
}

Vec3 stress_targets(const std::array<AxisControl, kComponents>& axes, const Vec3& s, double leg_time) {
  Vec3 target = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  int major = -1, b_axis = -1, minor = -1;
  double known = 0.0;  // stress of the axes that are not mean_stress
  int mean_axes = 0;
  double mean = 0.0;
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = axes[k];
    if (a.strain_driven()) major = k;
    if (a.mode == AxisMode::B) b_axis = k;
    if (a.mode == AxisMode::Stress || a.mode == AxisMode::MeanStress) minor = k;
    if (a.mode == AxisMode::Stress || a.mode == AxisMode::StressRamp) target[k] = a.stress_target(leg_time);
    if (a.mode == AxisMode::MeanStress) ++mean_axes, mean = a.value;
    else if (a.mode != AxisMode::B) known += a.mode == AxisMode::Stress ? a.value : s[k];
  }
  if (b_axis >= 0) {
    const double b = axes[b_axis].value, s_major = s[major];
    if (axes[minor].mode == AxisMode::MeanStress) target[minor] = (3.0 * mean - (1.0 + b) * s_major) / (2.0 - b);
    target[b_axis] = target[minor] + b * (s_major - target[minor]);
  } else if (mean_axes > 0) {
    for (int k = 0; k < 3; ++k)
      if (axes[k].mode == AxisMode::MeanStress) target[k] = (3.0 * mean - known) / mean_axes;
  }
  return target;
}

Vec6 control_targets(const std::array<AxisControl, kComponents>& axes, const std::optional<PrincipalRotation>& rotation,
                     const Vec6& s, double leg_time, double dt) {
  Vec6 target;
  target.head<3>() = stress_targets(axes, s.head<3>(), leg_time);
  for (int k = 3; k < kComponents; ++k)
    target[k] = axes[k].stress_driven() ? axes[k].value : std::numeric_limits<double>::quiet_NaN();
  if (rotation) {
    const std::array<double, 3> t = rotation->targets(leg_time, dt);
    const auto [i, j] = kShearAxisEntries[rotation->plane];
    target[i] = t[0], target[j] = t[1], target[3 + rotation->plane] = t[2];
  }
  return target;
}

namespace {

// The servo's strain increment of a component towards `target` from its stress and stiffness (and its
// integral, anti-windup), at most `cap`; `saturated` says whether it sat at the cap.
double servo_increment(const ServoDef& servo, double cap, double target, double stress, double stiffness,
                       double& integral, bool& saturated) {
  const double err = target - stress;
  double de;
  if (stiffness > 0.0) {
    de = (servo.gain * err + servo.integral_gain * (integral + err)) / stiffness;
  } else {
    de = err > 0.0 ? cap : -cap;  // nothing touches yet
  }
  saturated = !(std::abs(de) < cap);
  if (!saturated) integral += err;
  return std::clamp(de, -cap, cap);
}

// Sets component k's cell entry to the strain e against the stage start (the geometry in control.hpp).
void set_strain(int k, double e, const ControlState& ctl, Mat3& h) {
  const auto [i, j] = kComponentEntries[k];
  if (i == j) h(k, k) = ctl.reference[k] * (1.0 - e);
  else h(i, j) = ctl.reference[k] - ctl.reference_length(j) * e;
}

// Strains component k's cell entry by de (a servo's increment).
void add_strain(int k, double de, const ControlState& ctl, Mat3& h) {
  const auto [i, j] = kComponentEntries[k];
  if (i == j) h(k, k) *= 1.0 - de;
  else h(i, j) -= ctl.reference_length(j) * de;
}

// Scales the constant-volume axes by one common factor x so that det h = volume. det h is a polynomial of
// degree (number of such axes) in x, found exactly from its values at a few points.
void hold_volume(const std::array<AxisControl, kComponents>& axes, double volume, Mat3& h) {
  int cv[2], n = 0;
  for (int k = 0; k < 3; ++k)
    if (axes[k].mode == AxisMode::ConstantVolume) cv[n++] = k;
  if (n == 0) return;
  Mat3 base = h;  // the axes at the leg's proportions, scaled by x below
  auto det_at = [&](double x) {
    Mat3 t = base;
    for (int i = 0; i < n; ++i) t(cv[i], cv[i]) = base(cv[i], cv[i]) * x;
    return t.determinant();
  };
  double x;
  if (n == 1) {
    const double d0 = det_at(0.0), d1 = det_at(1.0);
    x = (volume - d0) / (d1 - d0);
  } else {  // det(x) = A x^2 + B x + C; the root near 1 (the present cell)
    const double c = det_at(0.0), p = det_at(1.0), m = det_at(-1.0);
    const double a = 0.5 * (p + m) - c, b = 0.5 * (p - m);
    const double disc = std::sqrt(std::max(0.0, b * b - 4.0 * a * (c - volume)));
    x = std::abs(a) > 0.0 ? (-b + disc) / (2.0 * a) : (volume - c) / b;
  }
  for (int i = 0; i < n; ++i) h(cv[i], cv[i]) = base(cv[i], cv[i]) * x;
}

}  // namespace

void advance_cell(const Model& model, const Loading& loading, State& state) {
  Cell& cell = state.cell;
  ControlState& ctl = state.control;
  const Mat3 h_before = cell.h;
  // The step's end: in time since the leg start (the servo's moving targets), and in progress (the strain-driven
  // components: leg_steps + 1 exactly at the deck's rate, the sum of the factors with an adaptive rate).
  const double end_time = static_cast<double>(ctl.leg_steps + 1) * model.dt;
  const double end_progress = ctl.leg_progress + ctl.rate_factor;
  const Vec6 target = control_targets(loading.axes, loading.rotation, state.stress, end_time, model.dt);
  const double cap = loading.servo_cap > 0.0 ? loading.servo_cap : model.servo.max_strain_increment;
  state.servo_saturated = {};
  for (int k = 0; k < kComponents; ++k) {
    const AxisControl& a = loading.axes[k];
    const double e0 = ctl.leg_start_strains[k];
    switch (a.mode) {
      case AxisMode::StrainIncrement:  // exact strain: no drift from summing increments
        set_strain(k, e0 + end_progress * a.value, ctl, cell.h);
        break;
      case AxisMode::StrainRate:
        set_strain(k, e0 + end_progress * a.value * model.dt, ctl, cell.h);
        break;
      case AxisMode::Stress:
      case AxisMode::StressRamp:
      case AxisMode::MeanStress:
      case AxisMode::B:
        add_strain(k, servo_increment(model.servo, cap, target[k], state.stress[k], state.stiffness[k],
                                      ctl.servo_integral[k], state.servo_saturated[k]), ctl, cell.h);
        break;
      case AxisMode::ConstantVolume:  // below, once the other components are set (tilts included)
      case AxisMode::Held:
        break;
    }
  }
  hold_volume(loading.axes, ctl.leg_start_volume, cell.h);
  cell.velocity_gradient = (cell.h - h_before) / model.dt * (0.5 * (cell.h + h_before)).inverse();
  ++ctl.leg_steps;
  ctl.leg_progress = end_progress;
}

Vec6 component_strains(const State& state) {
  const ControlState& ctl = state.control;
  Vec6 e;
  for (int k = 0; k < kComponents; ++k) {
    const auto [i, j] = kComponentEntries[k];
    e[k] = i == j ? 1.0 - state.cell.h(k, k) / ctl.reference[k]
                  : (ctl.reference[k] - state.cell.h(i, j)) / ctl.reference_length(j);  // (+0 unsheared)
  }
  return e;
}

}  // namespace celldem
