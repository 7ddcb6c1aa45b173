// Running a stage's load program: its legs in order, each from where the previous one ended, until the
// last leg's end condition; each leg's controls judged by run/control_verdict.hpp.
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "run/control_verdict.hpp"

namespace celldem {

class StageOutput;

// What a stage is: the sample's preparation, or a loading test.
enum class StageKind { Preparation, Test };

struct Program {
  const std::vector<Leg>& legs;
  Friction friction;  // sliding and rolling
  const EquilibriumDef* equilibrium = nullptr;  // for legs that end in equilibrium
  std::int64_t planned_steps = -1;              // all legs, when known (progress and ETA)
  bool adaptive_threads = true;                 // a ThreadGovernor may drop to one thread under contention
  StageKind kind = StageKind::Preparation;
  std::string stage = "prepare";                // the stage's name (messages): "prepare" or the test's
  ControlFailure control_failure = ControlFailure::Stop;  // a failed control stops the stage, or is recorded
  std::string equilibrium_key = "prepare.equilibrium";    // where the deck sets `equilibrium` (messages)
  bool print_control_warnings = true;  // with control_failure warn: print a failed control (probes record it only)
};

// Runs the program from the state's current leg (state.control.leg) to its end, or to the end of a leg at which one
// of the stage's observers ends it (StageOutput::leg_ends_stage). `errors` holds one entry
// per leg (kept across a resume by the stage's checkpoints). Each leg's end is a row of the series. Throws
// RunError for a leg that ends after no step, and (control_failure stop) for a control that fails, naming
// the stage, leg, component, its target, what it reached and what to change.
void run_program(const Model& model, const Program& program, State& state, StageOutput& out,
                 std::vector<ControlErrors>& errors);

}  // namespace celldem
