#include "core/model.hpp"

#include <cmath>

namespace celldem {

Model make_model(const Deck& deck, const std::vector<double>& radius) {
  Model m;
  m.dt = deck.time_step;
  m.density = deck.sample.density;
  m.contact = deck.contact;
  m.kinematics = deck.kinematics;
  m.servo = deck.servo;
  const std::size_t n = radius.size();
  m.mass.resize(n);
  m.velocity_keep.resize(n);
  m.velocity_gain.resize(n);
  m.spin_keep.resize(n);
  m.spin_gain.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double r = radius[i];
    const double volume = 4.0 / 3.0 * M_PI * r * r * r;
    const double mass = deck.sample.density * volume;
    const double inertia = 0.4 * mass * r * r;  // solid sphere
    // Body damping as a fraction of critical: 2 sqrt(m kn) on translation, 2 r sqrt(I kt) on rotation.
    const double c_t = deck.damping.translational * 2.0 * std::sqrt(mass * deck.contact.kn);
    const double c_r = deck.damping.rotational * 2.0 * r * std::sqrt(inertia * deck.contact.kt);
    const double at = 0.5 * c_t * m.dt / mass;
    const double ar = 0.5 * c_r * m.dt / inertia;
    m.mass[i] = mass;
    m.velocity_keep[i] = (1.0 - at) / (1.0 + at);
    m.velocity_gain[i] = m.dt / (mass * (1.0 + at));
    m.spin_keep[i] = (1.0 - ar) / (1.0 + ar);
    m.spin_gain[i] = m.dt / (inertia * (1.0 + ar));
    m.max_radius = std::max(m.max_radius, r);
    m.solid_volume += volume;
  }
  return m;
}

}  // namespace celldem
