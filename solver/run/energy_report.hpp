// The energy budget of a finished test, from its series rows (measure/energy.hpp defines the columns): totals
// over the test and per leg, the worst closure error, damping's share of the dissipation, and the verdicts on
// them (docs/energy.md). Computed from the rows as series.csv holds them, so a resumed run reports the same.
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "measure/series.hpp"

namespace celldem {

// A closure error above this fraction of the boundary work (at a row whose boundary work is at least
// kClosureFloor of the test's) is flagged: the integration does not keep the energy it is given.
inline constexpr double kClosureBound = 0.01;
inline constexpr double kClosureFloor = 0.01;
// A test in which the damping (body and contact) takes more than this share of the dissipation is flagged as
// damping-dominated: its answer depends on a numerical choice.
inline constexpr double kDampingShareBound = 0.05;

struct EnergyReport {
  nlohmann::json json;                // summary.json's tests.<test>.energy
  std::vector<std::string> warnings;  // each naming the test (and for the closure, the step, leg and time step)
  std::vector<std::string> console;   // lines after "<test>: "
};
// rows: the test's rows (the energy columns NaN: no budget, an empty report). dt: the test's time step [s].
EnergyReport energy_report(const std::string& test, const std::vector<SeriesRow>& rows, double dt);

}  // namespace celldem
