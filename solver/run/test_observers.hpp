// The observers a stage runs with (run/stage_observer.hpp), built from what the deck asks of it: snapshots, the
// peak contact network, probe points and their probes, the rate check. Adding a per-test extra is one observer
// class here and one line of observers_for.
#pragma once
#include <filesystem>
#include <memory>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "run/stage_observer.hpp"

namespace celldem {

// A stage's observers, owned; list() gives them in the order they are called.
class StageObservers {
 public:
  void add(std::unique_ptr<StageObserver> observer) { owned_.push_back(std::move(observer)); }
  std::vector<StageObserver*> list() const;

 private:
  std::vector<std::unique_ptr<StageObserver>> owned_;
};

// Where a loading test starts: its model, the state it starts from (a rate check starts there again), and whether
// it resumes from its checkpoint.
struct TestStart {
  const Model& model;
  std::filesystem::path prepared;
  bool resumed = false;
};

// A loading test's observers, in this order: the contact network of its peak row (peak_contacts.csv and .json, the
// peak of its driven measure), its snapshots (test.snapshots), its probe points and probes (test.probes), its rate
// check (verify_rate_for: the deck's or the command line's; its cost is printed now, before the test runs), its energy
// budget (energy_budget), --tolerance's promise against its actual inertial number (a deck with a tolerance).
StageObservers observers_for(const RunContext& context, const TestDef& test, const TestStart& start);

// The preparation's: its snapshots (prepare.snapshots).
StageObservers preparation_observers(const RunContext& context, const PrepareDef& prepare, const Model& model);

}  // namespace celldem
