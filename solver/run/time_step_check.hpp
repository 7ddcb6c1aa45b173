// The time step against the contact network's own stability limit 2 / omega_max (measure/network_stiffness.hpp
// network_time_step_limit; docs/physics.md, "The time step from the contact network"), with the stage's springs
// (tangential and twisting ones only where it has friction). Judged on the state each stage starts from (run_stage:
// the preparation, every test, a rate check's runs, a probe point's rest, each probe), on a deck's initial_state
// before any run (preflight, for check and run alike), and again every checkpoint_interval steps of a stage as its
// fabric evolves (NetworkTimeStepWatch, run_stage's own observer).
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/plan.hpp"
#include "core/state.hpp"
#include "measure/network_stiffness.hpp"
#include "run/stage_observer.hpp"

namespace celldem {

// The margins: core/plan.hpp kNetworkWarnFraction and kNetworkRefuseFraction.
enum class NetworkStepVerdict { Ok, Warn, Refuse };

struct NetworkStepJudgement {
  NetworkTimeStep network;
  double time_step = 0.0;  // [s] the stage's (model.dt)
  double ratio = 0.0;      // time_step / network.limit (0 without contacts)
  NetworkStepVerdict verdict = NetworkStepVerdict::Ok;
  std::string message;  // what the verdict says (empty when Ok)
};

// The deck key that sets a stage's time step: "prepare.time_step" or "tests[i].time_step" where the stage has its own,
// else "time_step". stage: "prepare", a test's name or a branch of it ("ttc/verify/slow").
std::string time_step_key(const Deck& deck, const std::string& stage);

// The stage's time step against the network of `state`: every pair that overlaps in its geometry, from a pair list
// rebuilt on a copy (a state read back lists only the pairs it stored), or with `listed` from the state's own list
// (a running stage's, which holds every pair within the skin). `where`: "test 'ttc' as it starts", "the preparation
// at step 20000"; `key` from time_step_key. A state without particles or contacts is Ok with no message.
NetworkStepJudgement judge_network_time_step(const Model& model, const State& state, const Friction& friction,
                                             const std::string& where, const std::string& key, bool listed = false);

// The judgement as summary.json and plan --json record it.
nlohmann::json to_json(const NetworkStepJudgement& j);

// run_stage's own observer: every `interval` steps of the stage (the deck's checkpoint_interval) and at its end, the
// network of the state as it stands judged again; a step above a margin is warned of once per margin (`warn`: the
// stage's warnings, recorded in summary.json), never stopped for (a packing that boils is stopped by the run's
// quasi-static checks).
class NetworkTimeStepWatch : public StageObserver {
 public:
  NetworkTimeStepWatch(const Model& model, const Friction& friction, std::string stage, std::string key,
                       std::int64_t interval, std::function<void(const std::string&)> warn);
  // The judgement of the stage's starting state, which run_stage made (it refuses before any output).
  void start(const NetworkStepJudgement& judgement);
  void on_step(const State& state) override;
  // The stage's end state too, unless a check just judged it (a preparation shorter than the interval ends dense).
  void on_finish(const State& state, const std::vector<SeriesRow>& rows) override;
  // Its judgements so far, kept with each checkpoint, so that a resumed stage records what an uninterrupted one does.
  void save(nlohmann::json& memory) const override;
  void restore(const nlohmann::json& memory) override;
  bool restored() const { return restored_; }
  // summary.json's record: the start's judgement, the largest ratio of any check, their count and time.
  nlohmann::json record() const;

 private:
  void judge(const NetworkStepJudgement& j);
  const Model& model_;
  Friction friction_;
  std::string stage_, key_;
  std::int64_t interval_;
  std::function<void(const std::string&)> warn_;
  nlohmann::json start_;
  double largest_ratio_ = 0.0;
  std::int64_t largest_step_ = 0;
  int checks_ = 0;
  double seconds_ = 0.0;
  NetworkStepVerdict warned_ = NetworkStepVerdict::Ok;  // the worst verdict warned of so far
  bool restored_ = false;
};

}  // namespace celldem
