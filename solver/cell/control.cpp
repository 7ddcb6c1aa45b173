#include "cell/control.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace celldem {

bool needs_shear_sums(const Loading& loading) {
  if (loading.rotation) return true;
  for (const std::optional<AxisControl>& a : loading.shear)
    if (a && a->stress_driven()) return true;
  return false;
}

void begin_stage(State& state) {
  state.control = ControlState{};
  state.control.reference_lengths = state.cell.h.diagonal();
  state.control.reference_volume = state.cell.volume();
  state.control.leg_start_volume = state.control.reference_volume;
  for (int a = 0; a < 3; ++a)
    state.control.reference_tilts[a] = state.cell.h(kShearAxisEntries[a][0], kShearAxisEntries[a][1]);
}

void restart_leg(State& state) {
  ControlState& c = state.control;
  c.leg_steps = 0;
  c.leg_progress = 0.0;
  c.rate_factor = 1.0;
  c.leg_start_strains = axis_strains(state);
  c.leg_start_shear = shear_strains(state);
}

void begin_leg(State& state, int leg) {
  ControlState& c = state.control;
  c.leg = leg;
  restart_leg(state);
  c.leg_start_volume = state.cell.volume();
  c.servo_integral = Vec3::Zero();
  c.shear_servo_integral = Vec3::Zero();
}

Vec3 stress_targets(const std::array<AxisControl, 3>& axes, const Vec3& s, double leg_time) {
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

namespace {

// The servo's strain increment of an axis towards `target` from its stress and stiffness (and its integral,
// anti-windup), at most `cap`; `saturated` says whether it sat at the cap.
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

double servo_increment(const ServoDef& servo, double cap, double target, int k, State& state) {
  return servo_increment(servo, cap, target, state.normal_stress[k], state.axis_stiffness[k],
                         state.control.servo_integral[k], state.servo_saturated[k]);
}

// The shear axes' tilts for the end of this step (the convention in control.hpp); unnamed axes untouched.
// `target`: the shear stress axes' targets.
void advance_shear(const Model& model, const Loading& loading, double cap, const Vec3& target, State& state) {
  ControlState& ctl = state.control;
  const double next_step = ctl.leg_progress + ctl.rate_factor;  // (leg_steps + 1 at the deck's rate)
  state.shear_servo_saturated = {false, false, false};
  for (int a = 0; a < 3; ++a) {
    if (!loading.shear[a]) continue;
    const AxisControl& axis = *loading.shear[a];
    const int i = kShearAxisEntries[a][0], j = kShearAxisEntries[a][1];
    const double length = ctl.reference_lengths[j], g0 = ctl.leg_start_shear[a];
    switch (axis.mode) {
      case AxisMode::StrainIncrement:  // exact: no drift from summing increments
        state.cell.h(i, j) = ctl.reference_tilts[a] - length * (g0 + next_step * axis.value);
        break;
      case AxisMode::StrainRate:
        state.cell.h(i, j) = ctl.reference_tilts[a] - length * (g0 + next_step * axis.value * model.dt);
        break;
      default: {  // stress (the deck reader allows no other)
        const double dg = servo_increment(model.servo, cap, target[a], state.shear_stress[a], state.shear_stiffness[a],
                                          ctl.shear_servo_integral[a], state.shear_servo_saturated[a]);
        state.cell.h(i, j) -= length * dg;
      }
    }
  }
}

// Scales the constant-volume axes by one common factor x so that det h = volume. det h is a polynomial of
// degree (number of such axes) in x, found exactly from its values at a few points.
void hold_volume(const std::array<AxisControl, 3>& axes, double volume, Mat3& h) {
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
  const double next_step = static_cast<double>(ctl.leg_steps + 1);
  // The strain-driven axes' progress at the step's end: leg_steps + 1 exactly at the deck's rate (factor 1 and
  // integer progress), the sum of the factors with an adaptive rate.
  const double next_progress = ctl.leg_progress + ctl.rate_factor;
  Vec3 target = stress_targets(loading.axes, state.normal_stress, next_step * model.dt);
  Vec3 shear_target;
  for (int a = 0; a < 3; ++a) shear_target[a] = loading.shear[a] ? loading.shear[a]->value : 0.0;
  if (loading.rotation) {
    const std::array<double, 3> t = loading.rotation->targets(next_step * model.dt, model.dt);
    const auto [i, j] = kShearAxisEntries[loading.rotation->plane];
    target[i] = t[0], target[j] = t[1], shear_target[loading.rotation->plane] = t[2];
  }
  const double cap = loading.servo_cap > 0.0 ? loading.servo_cap : model.servo.max_strain_increment;
  state.servo_saturated = {false, false, false};
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = loading.axes[k];
    const double e0 = ctl.leg_start_strains[k];
    switch (a.mode) {
      case AxisMode::StrainIncrement:  // exact engineering strain: no drift from summing increments
        cell.h(k, k) = ctl.reference_lengths[k] * (1.0 - (e0 + next_progress * a.value));
        break;
      case AxisMode::StrainRate:
        cell.h(k, k) = ctl.reference_lengths[k] * (1.0 - (e0 + next_progress * a.value * model.dt));
        break;
      case AxisMode::Stress:
      case AxisMode::StressRamp:
      case AxisMode::MeanStress:
      case AxisMode::B:
        cell.h(k, k) *= 1.0 - servo_increment(model.servo, cap, target[k], k, state);
        break;
      case AxisMode::ConstantVolume:  // below, once the other axes are set
        break;
    }
  }
  advance_shear(model, loading, cap, shear_target, state);  // before hold_volume, which reads the cell with its new tilts
  hold_volume(loading.axes, ctl.leg_start_volume, cell.h);
  cell.velocity_gradient = (cell.h - h_before) / model.dt * (0.5 * (cell.h + h_before)).inverse();
  ++ctl.leg_steps;
  ctl.leg_progress = next_progress;
}

Vec3 axis_strains(const State& state) {
  Vec3 e;
  for (int k = 0; k < 3; ++k) e[k] = 1.0 - state.cell.h(k, k) / state.control.reference_lengths[k];
  return e;
}

Vec3 shear_strains(const State& state) {
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    const int i = kShearAxisEntries[a][0], j = kShearAxisEntries[a][1];
    g[a] = (state.control.reference_tilts[a] - state.cell.h(i, j)) / state.control.reference_lengths[j];  // (+0 unsheared)
  }
  return g;
}

}  // namespace celldem
