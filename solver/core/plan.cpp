#include "core/plan.hpp"

#include <algorithm>
#include <cmath>

namespace celldem {

bool is_reserved_stage_name(const std::string& name) { return name == "prepare" || name == "figures"; }

TestPlan plan_test(const Deck& deck, const TestDef& test) {
  const AxisControl& a = test.axes[test.end_axis];
  TestPlan p;
  p.strain_per_step = a.mode == AxisMode::StrainRate ? a.value * deck.time_step : a.value;
  p.strain_rate = p.strain_per_step / deck.time_step;
  const auto n = static_cast<std::int64_t>(std::llround(test.end_strain / p.strain_per_step));
  p.steps = test.max_steps > 0 ? std::min(n, test.max_steps) : n;
  p.rows = 1 + p.steps / test.output_interval + (p.steps % test.output_interval != 0);
  return p;
}

double loading_rate(const Deck& deck, const TestDef& test) {
  double rate = 0.0;
  for (const AxisControl& a : test.axes) {
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
