#include "run/driven_measure.hpp"

#include <algorithm>
#include <cmath>

#include "cell/control.hpp"

namespace celldem {

TestMeasure driven_measure(const TestDef& test) {
  for (const Leg& leg : test.legs) {
    if (leg.rotation) return {TestMeasure::Kind::Rotation, -1};
    int fastest = -1;
    for (int k = 0; k < kComponents; ++k)
      if (std::abs(leg.strain_per_step(k, 1.0)) > (fastest < 0 ? 0.0 : std::abs(leg.strain_per_step(fastest, 1.0)))) fastest = k;
    if (fastest < 0) continue;
    if (is_shear_component(fastest)) return {TestMeasure::Kind::Shear, fastest};
    return {leg.strain_per_step(fastest, 1.0) < 0.0 ? TestMeasure::Kind::Extension : TestMeasure::Kind::Axial, fastest};
  }
  return {TestMeasure::Kind::Stress, -1};
}

double driven_value(const TestMeasure& m, const SeriesRow& r) {
  switch (m.kind) {
    case TestMeasure::Kind::Extension: return r.s33 / r.s11;
    case TestMeasure::Kind::Shear:
      return std::abs(r.stress(m.component)) / r.stress(kComponentEntries[static_cast<std::size_t>(m.component)][1]);
    default: return r.ratio13;
  }
}

double driven_strain(const TestMeasure& m, const SeriesRow& r) {
  return m.kind == TestMeasure::Kind::Shear ? r.strain(m.component) : r.e1;
}

std::string measure_name(const TestMeasure& m) {
  switch (m.kind) {
    case TestMeasure::Kind::Extension: return "s33/s11";
    case TestMeasure::Kind::Shear: {
      const int j = kComponentEntries[static_cast<std::size_t>(m.component)][1] + 1;
      return "|s" + component_name(m.component).substr(1) + "|/s" + std::to_string(j) + std::to_string(j);
    }
    default: return "s11/s33";
  }
}

std::string strain_name(const TestMeasure& m) {
  return m.kind == TestMeasure::Kind::Shear ? "g" + component_name(m.component).substr(1) : "e1";
}

std::string driven_measure_words(const TestMeasure& m) {
  switch (m.kind) {
    case TestMeasure::Kind::Rotation: return "principal-axis rotation";
    case TestMeasure::Kind::Stress: return "none (stress-controlled)";
    default: return measure_name(m);
  }
}

std::size_t peak_row(const TestMeasure& m, const std::vector<SeriesRow>& rows) {
  std::size_t peak = 0;
  for (std::size_t r = 0; r < rows.size(); ++r)
    if (driven_value(m, rows[r]) > driven_value(m, rows[peak]) || !std::isfinite(driven_value(m, rows[peak]))) peak = r;
  return peak;
}

bool PeakTracker::offer(const SeriesRow& row) {
  const double v = driven_value(measure_, row);
  if (!(v > best_)) return false;
  best_ = v;
  return true;
}

void PeakTracker::seen(const std::vector<SeriesRow>& rows) {
  for (const SeriesRow& row : rows) best_ = std::max(best_, driven_value(measure_, row));
}

}  // namespace celldem
