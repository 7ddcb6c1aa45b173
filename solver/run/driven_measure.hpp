// The measure a test drives and its peak, defined once: the summary's peak quantities, the `peak` probe point,
// the peak contact network (peak_contacts.csv) and the console's line all ask these functions.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "measure/series.hpp"

namespace celldem {

// The measure a test drives, from its first leg that drives something.
struct TestMeasure {
  // Axial: a normal axis driven in compression, s11/s33. Extension: a normal axis driven in extension, s33/s11.
  // Shear: a shear component g_ij driven, tau/sigma_n = |s_ij| / s_jj. Rotation: a principal-axis rotation (no peak
  // to reach). Stress: a last leg that no strain drives (stresses held or ramped), no peak to reach either.
  enum class Kind { Axial, Extension, Shear, Rotation, Stress } kind = Kind::Axial;
  int component = 0;  // the fastest driven component, kComponentNames (-1: none)

  // Whether the test drives this measure to a peak (summary.json peak_reached says whether it got there).
  bool has_peak() const { return kind == Kind::Axial || kind == Kind::Extension || kind == Kind::Shear; }
};

// The test's measure: that of its first leg that drives something, by its fastest strain-driven component (a shear
// component: tau/sigma_n; a normal axis: s11/s33, or s33/s11 when it extends), a principal-axis rotation, or none.
TestMeasure driven_measure(const TestDef& test);

// The measure's value at a row. A test with no peak to reach (a rotation, stresses only) is followed on s11/s33.
double driven_value(const TestMeasure& measure, const SeriesRow& row);
// The strain the measure's peak is placed on: e1 (axial, extension, none) or the driven g_ij (shear).
double driven_strain(const TestMeasure& measure, const SeriesRow& row);

// Words: "s11/s33", "s33/s11", "|s12|/s22"; those of driven_value for a rotation or a stress-controlled test.
std::string measure_name(const TestMeasure& measure);
// The name of driven_strain: "e1" or "g12".
std::string strain_name(const TestMeasure& measure);
// summary.json's driven_measure: measure_name, or "principal-axis rotation", "none (stress-controlled)".
std::string driven_measure_words(const TestMeasure& measure);

// The peak of a measure over rows: its first row of the largest value (a non-finite first value gives way).
std::size_t peak_row(const TestMeasure& measure, const std::vector<SeriesRow>& rows);

// The peak so far of a running stage's rows, row by row: a new peak is a row above every earlier one (so the first
// row of the largest value, as peak_row finds it over the whole series).
class PeakTracker {
 public:
  explicit PeakTracker(TestMeasure measure) : measure_(measure) {}
  // True when `row` is a new peak.
  bool offer(const SeriesRow& row);
  // Rows read back on a resume: the peak is taken again only by a row above all of them.
  void seen(const std::vector<SeriesRow>& rows);
  const TestMeasure& measure() const { return measure_; }

 private:
  TestMeasure measure_;
  double best_ = -1.0;
};

}  // namespace celldem
