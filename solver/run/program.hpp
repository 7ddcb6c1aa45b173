// Running a stage's load program: its legs in order, each from where the previous one ended, until the
// last leg's end condition; and how well each leg's controls held their targets.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

class StageOutput;

// The worst errors of a leg's controls over its steps after the first kSettleStrain of its driving strain.
inline constexpr double kSettleStrain = 0.002;
struct ControlErrors {
  double stress = 0.0;       // stress axes: max |s - target| / target
  double b = 0.0;            // b axis: max |b - target| (axis stresses)
  double mean_stress = 0.0;  // mean_stress axes: max |p - target| / target
  double volume = 0.0;       // constant-volume axes: max |V - V(leg start)| / V(leg start)
  std::int64_t steps = 0;    // steps checked
};
nlohmann::json to_json(const ControlErrors& e);
ControlErrors control_errors_from_json(const nlohmann::json& j);

struct Program {
  const std::vector<Leg>& legs;
  Friction friction;  // sliding and rolling
  const EquilibriumDef* equilibrium = nullptr;  // for legs that end in equilibrium (the preparation)
  std::int64_t planned_steps = -1;              // all legs, when known (progress and ETA)
  bool adaptive_threads = true;                 // a ThreadGovernor may drop to one thread under contention
};

// Runs the program from the state's current leg (state.control.phase) to its end. `errors` holds one entry
// per leg (kept across a resume by the stage's checkpoints).
void run_program(const Model& model, const Program& program, State& state, StageOutput& out,
                 std::vector<ControlErrors>& errors);

}  // namespace celldem
