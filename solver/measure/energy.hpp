// The energy budget of a stage: the work the cell does on the contacts, what the contact springs store, the
// kinetic energy of the fluctuating motion, what friction and damping dissipate, and what is left over (the
// closure error), defined against the integrator's own arithmetic (docs/energy.md):
//   boundary work   W = sum over steps of -dt L : (M_old + M_new)/2, M = sum f (x) l (the contact stress times V):
//                   the cell's velocity gradient L of the step times the trapezoid of the stress at its two ends
//                   (contact/contact_forces.cpp adds it each step);
//   stored          the springs' energies at the state: normal fn^2/(2 kn) or Hertz's 2/5 fn d, tangential
//                   |ft|^2/(2 kt), rolling k_roll |xi_r|^2/2, twisting k_tw theta^2/2;
//   kinetic         the leapfrog's, 1/2 m v(t - dt/2).v(t + dt/2) = 1/2 m |v|^2 - 1/2 dt F.v with v the
//                   state's half-step velocity and F the force that made it (and the same for the spins): the
//                   form whose change over a step is exactly dt F_mid.v (no O(dt) offset of the half steps);
//   friction        at each Coulomb cap, the capped force times the slip it made; the rolling and twisting caps
//                   likewise; the rolling dashpot's force times the rolling motion;
//   body damping    each kick's c dt |v̄|^2, v̄ the mean of the velocities before and after it (exact for the
//                   implicit update: integrate/leapfrog.cpp);
//   closure         W - (E - E_start) - dissipated, E = stored + kinetic.
#pragma once
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

struct EnergyPartition {
  double normal = 0.0;               // [J] normal springs
  double tangential = 0.0;           // [J] tangential springs
  double rotational_springs = 0.0;   // [J] rolling and twisting springs
  double kinetic_translation = 0.0;  // [J] the leapfrog's, fluctuating translation
  double kinetic_rotation = 0.0;     // [J] the leapfrog's, rotation
  double stored() const { return normal + tangential + rotational_springs; }
  double kinetic() const { return kinetic_translation + kinetic_rotation; }
  double total() const { return stored() + kinetic(); }
};
// The stored and kinetic energy of the state (its last force evaluation and half-step velocities).
EnergyPartition energy_partition(const Model& model, const State& state);

// Opens the stage's budget at the state as it stands (after its first force evaluation: step.hpp
// evaluate_forces): the totals set to zero, the start energy measured. The sum M of that evaluation is kept.
void open_energy_budget(const Model& model, State& state);

struct EnergyBudget {
  EnergyPartition partition;
  EnergyLedger totals;
  double closure = 0.0;           // [J] W - (E - E_start) - dissipated
  double closure_relative = 0.0;  // closure / W (NaN while W = 0)
};
// The budget of the state's stage so far (NaN everywhere when the ledger is not open).
EnergyBudget energy_budget(const Model& model, const State& state);

}  // namespace celldem
