#include "run/time_step_check.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/number_text.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {

std::string time_step_key(const Deck& deck, const std::string& stage) {
  if (stage == "prepare") return deck.prepare && deck.prepare->time_step ? "prepare.time_step" : "time_step";
  const std::string test = stage.substr(0, stage.find('/'));  // a branch's test
  for (std::size_t i = 0; i < deck.tests.size(); ++i)
    if (deck.tests[i].name == test && deck.tests[i].time_step) return "tests[" + std::to_string(i) + "].time_step";
  return "time_step";
}

namespace {

// What the network's limit depends on: the cell, the spheres' sizes and places, the law's springs, the masses.
std::uint64_t fingerprint(const Model& model, const State& state, NetworkSprings springs) {
  std::uint64_t hash = 14695981039346656037ull;  // FNV-1a 64 over the bytes
  const auto add = [&hash](const void* data, std::size_t bytes) {
    const auto* c = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < bytes; ++k) hash = (hash ^ c[k]) * 1099511628211ull;
  };
  add(state.cell.h.data(), sizeof(double) * 9);
  add(state.particles.radius.data(), sizeof(double) * state.particles.size());
  add(state.particles.scaled.data(), sizeof(Vec3) * state.particles.size());
  for (const double k : {model.contact.kn, model.contact.kt, model.contact.youngs_modulus, model.contact.poisson_ratio,
                         model.contact.rolling_stiffness, model.density})
    add(&k, sizeof k);
  const int flags = static_cast<int>(model.contact.normal) * 64 + static_cast<int>(model.contact.tangential) * 16 +
                    static_cast<int>(model.contact.rolling) * 8 + static_cast<int>(model.contact.twisting) * 4 +
                    static_cast<int>(model.contact.moment_arm) * 2 + springs.tangential * 1;
  add(&flags, sizeof flags);
  add(&springs.rolling, sizeof springs.rolling);
  return hash;
}

// Stages that start from one state (a probe point's probes all start from its rested state, side by side on
// threads) share its judgement: the last few networks measured, by fingerprint.
NetworkTimeStep network_of(const Model& model, const State& state, NetworkSprings springs, bool listed) {
  static std::mutex mutex;
  static std::vector<std::pair<std::uint64_t, NetworkTimeStep>> recent;  // (at most kRecent, oldest first)
  constexpr std::size_t kRecent = 16;
  const std::uint64_t key = fingerprint(model, state, springs);
  {
    const std::lock_guard<std::mutex> lock(mutex);
    for (const auto& [k, n] : recent)
      if (k == key) {
        NetworkTimeStep cached = n;
        cached.seconds = 0.0;  // not measured again
        return cached;
      }
  }
  NetworkTimeStep n;
  if (listed) {
    n = network_time_step_limit(model, state, springs);
  } else {
    State copy = state;
    rebuild_pairs(model, copy);
    n = network_time_step_limit(model, copy, springs);
  }
  const std::lock_guard<std::mutex> lock(mutex);
  if (recent.size() == kRecent) recent.erase(recent.begin());
  recent.emplace_back(key, n);
  return n;
}

std::string springs_text(NetworkSprings s) {
  return s.tangential ? (s.rolling ? "sticking, rolling springs held" : "sticking")
                      : "normal springs only: no friction";
}

}  // namespace

NetworkStepJudgement judge_network_time_step(const Model& model, const State& state, const Friction& friction,
                                             const std::string& where, const std::string& key, bool listed) {
  NetworkStepJudgement j;
  j.time_step = model.dt;
  if (state.particles.size() == 0) return j;
  j.network = network_of(model, state, network_springs(friction), listed);
  if (!(j.network.omega_max > 0.0)) return j;  // no contact: nothing oscillates
  j.ratio = j.time_step / j.network.limit;
  if (!(j.ratio > kNetworkWarnFraction)) return j;
  j.verdict = j.ratio > kNetworkRefuseFraction ? NetworkStepVerdict::Refuse : NetworkStepVerdict::Warn;
  const NetworkTimeStep& n = j.network;
  const double suggested = kNetworkWarnFraction * n.limit;
  j.message = where + ": time step " + fmt3(j.time_step) + " s is " + fmt3(j.ratio) +
              " of the contact network's stability limit 2/omega_max = " + fmt3(n.limit) + " s (" +
              fmt3(n.limit / n.unit) + " sqrt(m_min/kn); its " + std::to_string(n.contacts) + " contacts, " +
              springs_text(n.springs) + "; the pair formula's 2/omega is " + fmt3(n.pair_limit) + " s), above ";
  if (j.verdict == NetworkStepVerdict::Refuse)
    j.message += "the refusal margin " + fmt3(kNetworkRefuseFraction) +
                 " of it (the step is unstable for that "
                 "network and packings boil there; docs/physics.md)";
  else
    j.message += "the margin " + fmt3(kNetworkWarnFraction) + " of it (" +
                 (j.ratio > 1.0 ? std::string("unstable while the contacts stick: only sliding holds it")
                                : std::string("too close to the limit as the fabric changes")) +
                 "; refused above " + fmt3(kNetworkRefuseFraction) + ")";
  j.message +=
      "; set " + key + " to at most " + fmt3(suggested) + " s (" + fmt3(kNetworkWarnFraction) + " x the limit)";
  return j;
}

nlohmann::json to_json(const NetworkStepJudgement& j) {
  const NetworkTimeStep& n = j.network;
  return {{"time_step", j.time_step},
          {"limit", number_or_null(n.limit)},
          {"limit_over_unit", number_or_null(n.limit / n.unit)},
          {"pair_limit", number_or_null(n.pair_limit)},
          {"time_step_over_limit", j.ratio},
          {"verdict", j.verdict == NetworkStepVerdict::Ok     ? "ok"
                      : j.verdict == NetworkStepVerdict::Warn ? "warn"
                                                              : "refuse"},
          {"warn_above", kNetworkWarnFraction},
          {"refuse_above", kNetworkRefuseFraction},
          {"contacts", n.contacts},
          {"tangential_springs", n.springs.tangential},
          {"iterations", n.iterations},
          {"wall_s", n.seconds}};
}

NetworkTimeStepWatch::NetworkTimeStepWatch(const Model& model, const Friction& friction, std::string stage,
                                           std::string key, std::int64_t interval,
                                           std::function<void(const std::string&)> warn)
    : model_(model),
      friction_(friction),
      stage_(std::move(stage)),
      key_(std::move(key)),
      interval_(interval),
      warn_(std::move(warn)) {}

void NetworkTimeStepWatch::start(const NetworkStepJudgement& judgement) {
  start_ = to_json(judgement);
  judge(judgement);
}

void NetworkTimeStepWatch::judge(const NetworkStepJudgement& j) {
  ++checks_;
  seconds_ += j.network.seconds;
  if (j.ratio > largest_ratio_) largest_ratio_ = j.ratio;
  if (j.verdict > warned_) {  // once per margin crossed: the first time the step is above it
    warned_ = j.verdict;
    warn_(j.message);
  }
}

void NetworkTimeStepWatch::on_step(const State& state) {
  const std::int64_t step = state.control.stage_steps;
  if (step <= 0 || step % interval_ != 0) return;
  const NetworkStepJudgement j =
      judge_network_time_step(model_, state, friction_, stage_ + " at step " + std::to_string(step), key_, true);
  if (j.ratio > largest_ratio_) largest_step_ = step;
  judge(j);
}

void NetworkTimeStepWatch::on_finish(const State& state, const std::vector<SeriesRow>&) {
  const std::int64_t step = state.control.stage_steps;
  if (step <= 0 || step % interval_ == 0) return;  // judged by on_step at this step
  const NetworkStepJudgement j = judge_network_time_step(
      model_, state, friction_, stage_ + " at its end (step " + std::to_string(step) + ")", key_);
  if (j.ratio > largest_ratio_) largest_step_ = step;
  judge(j);
}

void NetworkTimeStepWatch::save(nlohmann::json& memory) const {
  memory["network_time_step"] = {{"record", record()}, {"warned", static_cast<int>(warned_)}};
}

void NetworkTimeStepWatch::restore(const nlohmann::json& memory) {
  if (!memory.contains("network_time_step")) return;  // (a checkpoint written before the watch kept its memory)
  const nlohmann::json& m = memory.at("network_time_step");
  const nlohmann::json& r = m.at("record");
  start_ = r.at("at_start");
  largest_ratio_ = r.at("largest_time_step_over_limit").get<double>();
  largest_step_ = r.at("largest_at_step").get<std::int64_t>();
  checks_ = r.at("checks").get<int>();
  seconds_ = r.at("wall_s").get<double>();
  warned_ = static_cast<NetworkStepVerdict>(m.at("warned").get<int>());
  restored_ = true;
}

nlohmann::json NetworkTimeStepWatch::record() const {
  return {{"at_start", start_},
          {"largest_time_step_over_limit", largest_ratio_},
          {"largest_at_step", largest_step_},
          {"checks", checks_},
          {"check_interval", interval_},
          {"wall_s", seconds_}};
}

}  // namespace celldem
