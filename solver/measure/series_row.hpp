// One row of a stage's series.csv: macro state, stress invariants, coordination, sliding and fabric.
#pragma once
#include <deque>
#include <string>
#include <vector>

#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Column names, in file order (an interface: tools read these names).
const std::vector<std::string>& series_columns();

// Dilatancy index DI = -d(ev)/d(e1): least-squares slope of ev against e1 over the rows whose e1 lies in
// the trailing window [e1 - width, e1] (a window in strain, not in rows, so the output interval does not
// change its smoothing). NaN until the window spans at least half its width.
class DilatancyWindow {
 public:
  explicit DilatancyWindow(double width) : width_(width) {}
  double add(double e1, double ev);
  void clear() { points_.clear(); }

 private:
  double width_;
  std::deque<std::pair<double, double>> points_;
};

// Measures every column for the current state. stage_time [s] is the time since the stage started.
std::vector<double> measure_series_row(const Model& model, const State& state, DilatancyWindow& di);

// Formats a row with enough digits to round-trip (%.17g is exact; %.10g is plenty and compact).
std::string format_series_row(const std::vector<double>& values);
std::string series_header();

}  // namespace celldem
