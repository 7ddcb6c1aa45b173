#include "core/plan.hpp"

#include <algorithm>
#include <cmath>

namespace celldem {

bool is_reserved_stage_name(const std::string& name) { return name == "prepare" || name == "figures"; }

std::vector<Leg> preparation_legs(const PrepareDef& prep) {
  Leg fast, servo;
  fast.axes.fill({AxisMode::StrainIncrement, prep.fast_strain_increment});
  fast.end = {.kind = LegEndKind::SolidFraction, .value = prep.fast_solid_fraction};
  servo.axes.fill({AxisMode::Stress, prep.target_pressure});
  servo.end = {.kind = LegEndKind::Equilibrium, .max_steps = prep.equilibrium.max_steps};
  return {fast, servo};
}

std::int64_t leg_steps(const Leg& leg, double time_step, double from) {
  const LegEnd& e = leg.end;
  std::int64_t n = -1;
  if (e.kind == LegEndKind::Steps) n = e.steps;
  if (e.kind == LegEndKind::Strain && leg.axes[e.axis].strain_driven())
    n = std::max<std::int64_t>(0, std::llround((e.value - from) / leg.strain_per_step(e.axis, time_step)));
  if (n >= 0 && e.max_steps > 0) n = std::min(n, e.max_steps);
  return n;
}

TestPlan plan_test(const Deck& deck, const TestDef& test) {
  TestPlan p;
  const Leg& first = test.legs.front();
  p.strain_per_step = first.strain_per_step(first.end.axis, deck.time_step);
  p.strain_rate = p.strain_per_step / deck.time_step;
  // A leg starts where the previous one ended: its end axis from the previous strain end of that axis.
  Vec3 strain = Vec3::Zero();
  for (const Leg& leg : test.legs) {
    const std::int64_t n = leg_steps(leg, deck.time_step, strain[leg.end.axis]);
    if (n < 0) {
      p.steps = p.rows = -1;
      return p;
    }
    p.steps += n;
    for (int k = 0; k < 3; ++k) strain[k] += n * leg.strain_per_step(k, deck.time_step);
    if (leg.end.kind == LegEndKind::Strain && n != leg.end.max_steps) strain[leg.end.axis] = leg.end.value;
  }
  p.rows = 1 + p.steps / test.output_interval + (p.steps % test.output_interval != 0);
  return p;
}

double loading_rate(const Deck& deck, const TestDef& test) {
  double rate = 0.0;
  for (const Leg& leg : test.legs)
    for (const AxisControl& a : leg.axes) {
      if (a.mode == AxisMode::StrainIncrement) rate = std::max(rate, std::abs(a.value) / deck.time_step);
      if (a.mode == AxisMode::StrainRate) rate = std::max(rate, std::abs(a.value));
    }
  return rate;
}

BodyProperties body_properties(double r, double density, const DampingDef& damping, const ContactDef& contact) {
  BodyProperties b;
  b.volume = 4.0 / 3.0 * M_PI * r * r * r;
  b.mass = density * b.volume;
  b.inertia = 0.4 * b.mass * r * r;  // solid sphere
  b.translational_drag = damping.translational * 2.0 * std::sqrt(b.mass * contact.kn);
  b.rotational_drag = damping.rotational * 2.0 * r * std::sqrt(b.inertia * contact.kt);
  return b;
}

double critical_time_step(const SampleDef& sample, double kn) {
  const double d_min = *std::min_element(sample.diameters.begin(), sample.diameters.end());
  return std::sqrt(body_properties(0.5 * d_min, sample.density, {}, {}).mass / kn);
}

double skin_length(const Deck& deck) {
  return deck.neighbor_skin * *std::max_element(deck.sample.diameters.begin(), deck.sample.diameters.end());
}

double mean_diameter(const SampleDef& sample) {
  double d_mean = 0.0;
  for (double d : sample.diameters) d_mean += d / static_cast<double>(sample.diameters.size());
  return d_mean;
}

}  // namespace celldem
