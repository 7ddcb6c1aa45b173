#include "core/model.hpp"

#include <algorithm>

#include "core/plan.hpp"

namespace celldem {

double Model::mass_of(double radius) const { return body_properties(radius, density, {}, {}).mass; }

Model make_model(const Deck& deck, const std::vector<double>& radius) {
  return make_model(deck, radius, deck.time_step);
}

Model make_model(const Deck& deck, const std::vector<double>& radius, double time_step) {
  Model m;
  m.dt = time_step;
  m.density = deck.sample.density;
  m.contact = deck.contact;
  m.kinematics = deck.kinematics;
  m.servo = deck.servo;
  m.energy_budget = deck.energy_budget;
  const ContactStiffness stiffness = reference_stiffness(deck.contact, deck.sample);
  const std::size_t n = radius.size();
  m.velocity_keep.resize(n);
  m.velocity_gain.resize(n);
  m.spin_keep.resize(n);
  m.spin_gain.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const BodyProperties b = body_properties(radius[i], deck.sample.density, deck.damping, stiffness);
    const double at = 0.5 * b.translational_drag * m.dt / b.mass;
    const double ar = 0.5 * b.rotational_drag * m.dt / b.inertia;
    m.velocity_keep[i] = (1.0 - at) / (1.0 + at);
    m.velocity_gain[i] = m.dt / (b.mass * (1.0 + at));
    m.spin_keep[i] = (1.0 - ar) / (1.0 + ar);
    m.spin_gain[i] = m.dt / (b.inertia * (1.0 + ar));
    m.max_radius = std::max(m.max_radius, radius[i]);
    m.solid_volume += b.volume;
  }
  return m;
}

}  // namespace celldem
