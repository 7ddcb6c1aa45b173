// The immutable model: constants of the physics and per-particle properties derived from the deck and the
// sample's radii. Built once per run; stages take it by const reference.
#pragma once
#include <vector>

#include "core/types.hpp"
#include "core/deck.hpp"

namespace celldem {

struct Model {
  double dt = 0.0;                 // [s]
  double density = 0.0;           // [kg/m^3]
  ContactDef contact;              // kn, kt and the tangential-history choices
  Kinematics kinematics = Kinematics::Affine;
  ServoDef servo;
  bool energy_budget = false;      // keep the energy budget (State::energy; the deck's `energy_budget`)
  double max_radius = 0.0;         // [m]
  double solid_volume = 0.0;       // [m^3] sum of sphere volumes
  // Per particle (N). Leapfrog with implicit body damping:
  //   v(t+dt/2) = keep * v(t-dt/2) + gain * F(t), keep = (1 - c dt/2m)/(1 + c dt/2m), gain = dt/(m (1 + c dt/2m))
  std::vector<double> velocity_keep, velocity_gain;  // [-], [s/kg]
  std::vector<double> spin_keep, spin_gain;          // [-], [s/(kg m^2)]
  // A sphere's mass [kg] (what the factors above were made from; computed when needed, not stored).
  double mass_of(double radius) const;
};

// The model of a stage that runs with `time_step` (Deck::stage_time_step); without it, the deck's.
Model make_model(const Deck& deck, const std::vector<double>& radius, double time_step);
Model make_model(const Deck& deck, const std::vector<double>& radius);

}  // namespace celldem
