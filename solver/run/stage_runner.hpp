// Every stage runs through run_stage: the preparation, each loading test, a rate check's runs, each probe point's
// rest and each probe. A stage is described whole (StageSpec, built with designated initializers) and run with its
// list of observers (run/stage_observer.hpp); it returns what it leaves (StageResult).
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "run/program.hpp"
#include "run/stage_observer.hpp"

namespace celldem {

// A state file a stage writes when it ends (prepared.state, a test's final.state).
struct FinalStateFile {
  std::string path;
  std::string label;  // the file's label: "prepared", "test:<name>"
};

struct StageSpec {
  std::string name{};        // "prepare", the test's name, or a branch's folder ("ttc/verify/slow")
  StageKind kind = StageKind::Test;  // a test's stages and its branches check kinetic energy; the preparation not
  std::vector<Leg> legs{};   // the load program
  Friction friction{};       // sliding and rolling
  const EquilibriumDef* equilibrium = nullptr;          // for legs that end in equilibrium
  std::string equilibrium_key = "tests[].equilibrium";  // where the deck sets it (messages)
  std::int64_t planned_steps = -1;                      // the stage's last step when known (progress and ETA)
  std::int64_t output_interval = 1;                     // steps between rows
  bool resumed = false;      // continues from its checkpoint (run_directory)
  bool branch = false;       // a branch of a test: no checkpoints, run again whole after a stop
  bool adaptive_threads = true;     // a ThreadGovernor may drop to one thread under contention
  bool progress_line = true;        // its own progress line (a probe's is its set's)
  ControlFailure control_failure = ControlFailure::Stop;
  bool print_control_warnings = true;  // with control_failure warn: print a failed control (else recorded only)
  bool restart_legs = false;  // its first row is the state as it stands (a probe point's leg), then its legs begin
  std::string start_cause{};  // what a runaway would most likely come from (RunawayMonitor::set_start_cause)
  std::optional<FinalStateFile> final_state{};  // written when the stage ends
};

// Runs one stage of `model` from `state` (its forces evaluated; a resumed stage's checkpoint) with its observers
// (called in order; not owned) and returns what it leaves. Throws what the stage throws (RunError, Interrupted).
StageResult run_stage(const RunContext& context, const Model& model, const StageSpec& spec, State state,
                      const std::vector<StageObserver*>& observers = {});

}  // namespace celldem
