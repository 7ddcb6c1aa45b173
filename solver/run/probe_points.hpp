// Where a test's probes start and what they load (run/probes.hpp): the points' states, kept as the test runs
// (ProbePoints, held by the test's Probes observer), the probes' directions and load programs, their numbering
// for --probes.
#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/deck.hpp"
#include "core/state.hpp"
#include "measure/series.hpp"
#include "run/driven_measure.hpp"

namespace celldem {

// Which probes of each test's set a run runs (`celldem run --probes K-L`): those numbered first..last, 1-based over
// every point the deck names and each point's probes in probes.csv's order (point by point; at each point the
// directions at the first magnitude, then at the next), with the references of their points. By default all.
// A job array on a cluster runs the deck once per share (the sample and the tests are the same bytes in every
// job) and `celldem merge` gathers the probes into one folder.
struct ProbeSelection {
  std::int64_t first = 1;
  std::int64_t last = std::numeric_limits<std::int64_t>::max();
};
// "K-L" or "K" (K >= 1, L >= K); throws std::invalid_argument with what is wrong.
ProbeSelection parse_probe_selection(const std::string& text);

// The unit basis u1, u2 of a stress probe plane (Rendulic or pi): a direction at angle a is cos a u1 + sin a u2,
// and a strain increment's coordinates in the plane are its projections on them (work-conjugate to the stress's).
// `celldem schema --constants` writes them for the tools (probe_planes).
std::pair<std::array<double, 3>, std::array<double, 3>> plane_basis(ProbePlane plane);

// --probes numbers run over the whole deck: test by test in the deck's order, then point by point and direction by
// direction (probes.csv's order), references not counted. The number before `test`'s first, and the deck's count.
std::int64_t probe_number_offset(const Deck& deck, const TestDef& test);
std::int64_t probe_count(const Deck& deck);

// The points of a probe set by their folder names: "e1_<strain>" for each of at_e1, then at's names.
std::vector<std::string> probe_point_names(const ProbeDef& def);

// The states a test's probes start from, taken at its rows.
class ProbePoints {
 public:
  // `measure`: the test's (driven_measure), whose peak is the `peak` point.
  ProbePoints(const ProbeDef& def, TestMeasure measure);
  // After each row of the test: keeps a copy of the state at the first row reaching each e1 point, and at each new
  // largest value of the test's measure (the peak so far, PeakTracker).
  void on_row(const State& state, const SeriesRow& row);
  // Keeps each point's state in `dir`/<point>/point.state (the test's probes folder), so that a stopped run's points
  // survive: an e1 point's when it is taken, the peak so far's with each checkpoint (save). `physics`: state_physics.
  void keep_in(const std::filesystem::path& dir, const std::string& label, const std::string& physics);
  // Before a checkpoint of the test: the peak so far, if it changed since the last one.
  void save(const State& state);
  // A resumed test: the rows read back count; a point among them continues from the state kept in its folder when
  // that state is one of these rows', else it has lost its state (it is reported, not run). The peak is taken
  // again by a row above all of them.
  void resume(const std::vector<SeriesRow>& rows);
  // The test's last row and state (the end point).
  void finish(const State& state, const SeriesRow& row);

  struct Point {
    std::string name;                    // "e1_0.002", "peak", "end": the folder under <test>/probes/
    std::shared_ptr<const State> state;  // null: not reached or lost (missing says which)
    SeriesRow row;                       // the test's row at the point
    std::string missing;
    bool lost = false;                   // passed before a resume: its state went with the stopped run
  };
  // In order: the e1 points, then the named ones as the deck lists them (without a peak reached, no `peak`: its
  // reason is the summary's evidence, the words judge_peak gave).
  std::vector<Point> points(bool peak_reached, const std::string& peak_evidence) const;

 private:
  void write_point(const Point& p) const;

  const ProbeDef& def_;
  std::vector<Point> e1_;
  Point peak_, end_;
  PeakTracker peak_tracker_;
  std::filesystem::path dir_;  // empty: in memory only
  std::string label_, physics_;
  bool peak_unsaved_ = false;
};

// One probe of a set: its name (the folder), and what it loads.
struct ProbeDirection {
  std::string name;                 // "reference", "d03", "e11", "g12"
  double magnitude = 0.0;           // M [Pa] or [-]; 0 for the reference
  double angle_deg = 0.0;           // stress probes in a plane: a
  std::array<double, 6> direction{};  // unit: (ds11, ds22, ds33, 0, 0, 0) or a unit strain (e11, ..., g23)
};
// The probes of a set at each magnitude, after its reference (first).
std::vector<ProbeDirection> probe_directions(const ProbeDef& def);

// The load program of one probe from a point whose normal stresses are `s` (stress probes' base).
std::vector<Leg> probe_legs(const ProbeDef& def, const ProbeDirection& probe, const Vec3& s, double time_step);

}  // namespace celldem
