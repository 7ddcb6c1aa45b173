#include "run/stage_runner.hpp"

#include <optional>

#include "cell/control.hpp"
#include "io/state_file.hpp"
#include "run/preflight.hpp"
#include "run/run_options.hpp"
#include "run/stage_output.hpp"
#include "run/time_step_check.hpp"

namespace celldem {

StageResult run_stage(const RunContext& context, const Model& model, const StageSpec& spec, State state,
                      const std::vector<StageObserver*>& observers) {
  RunOptions options = context.options;  // (the stage's output keeps a reference: it lives as long)
  if (!spec.progress_line) options.progress = ProgressMode::Off;
  // The time step against the network the stage starts from (refused before any output), then every checkpoint
  // interval as its fabric evolves: the stage's own first observer.
  const std::string key = time_step_key(context.deck, spec.name);
  const std::string where = (spec.kind == StageKind::Preparation ? "the preparation" : "stage '" + spec.name + "'");
  const auto judge_start = [&](const State& s) {
    return judge_network_time_step(model, s, spec.friction, where + (spec.resumed ? " as it resumes" : " as it starts"),
                                   key);
  };
  // A fresh stage is judged before any output. A resumed one is judged as it went on: its checkpoint holds the
  // start's judgement (judged again only where an older checkpoint lacks it), and a later check only warns.
  std::optional<NetworkStepJudgement> at_start;
  if (!spec.resumed) {
    at_start = judge_start(state);
    if (at_start->verdict == NetworkStepVerdict::Refuse) throw DeckError(at_start->message);
  }
  StageOutput* output = nullptr;
  NetworkTimeStepWatch watch(model, spec.friction, where, key, context.deck.checkpoint_interval,
                             [&output](const std::string& warning) { output->warn(warning); });
  std::vector<StageObserver*> all{&watch};
  all.insert(all.end(), observers.begin(), observers.end());
  StageOutput out(context.run, context.deck, options, model, spec.name, spec.output_interval,
                  spec.kind == StageKind::Test, spec.branch, all);
  output = &out;
  out.set_start_cause(spec.start_cause);
  out.open(state, spec.resumed);
  if (!watch.restored()) watch.start(at_start ? *at_start : judge_start(state));
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
  return {out.rows(), out.control_errors(), out.elapsed(), std::move(state), watch.record()};
}

}  // namespace celldem
