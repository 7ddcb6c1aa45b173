#include "run/stage_runner.hpp"

#include "cell/control.hpp"
#include "io/state_file.hpp"
#include "run/preflight.hpp"
#include "run/run_options.hpp"
#include "run/stage_output.hpp"

namespace celldem {

StageResult run_stage(const RunContext& context, const Model& model, const StageSpec& spec, State state,
                      const std::vector<StageObserver*>& observers) {
  RunOptions options = context.options;  // (the stage's output keeps a reference: it lives as long)
  if (!spec.progress_line) options.progress = ProgressMode::Off;
  StageOutput out(context.run, context.deck, options, model, spec.name, spec.output_interval,
                  spec.kind == StageKind::Test, spec.branch, observers);
  out.set_start_cause(spec.start_cause);
  out.open(state, spec.resumed);
  if (spec.restart_legs) begin_leg(state, 0);
  const Program program{.legs = spec.legs,
                        .friction = spec.friction,
                        .equilibrium = spec.equilibrium,
                        .planned_steps = spec.planned_steps,
                        .adaptive_threads = spec.adaptive_threads,
                        .kind = spec.kind,
                        .stage = spec.name,
                        .control_failure = spec.control_failure,
                        .equilibrium_key = spec.equilibrium_key,
                        .print_control_warnings = spec.print_control_warnings};
  run_program(model, program, state, out, out.control_errors());
  out.finish(state);
  if (spec.final_state)
    write_state(spec.final_state->path, state, spec.final_state->label, state_physics(context.deck));
  return {out.rows(), out.control_errors(), out.elapsed(), std::move(state)};
}

}  // namespace celldem
