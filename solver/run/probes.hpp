// Incremental response probes (tests[].probes): from the exact state at chosen points of a loading test (strains
// of axis 1, the peak, the end), small loadings in several directions, each loaded, held, unloaded and held
// again, so that the response splits into its recovered (elastic) and irrecoverable (plastic) parts.
//
// Each point first rests at its stresses (a probe from equilibrium), and each probe set also runs a reference probe
// that loads nothing: what the sample still deforms (creep under held stresses, relaxation under held strains) is
// subtracted from every probe's response at the same step (as in the stress-probe studies of Calvetti, Viggiani &
// Tamagnini 2003 and Kuhn 2006 with DEM), and reported as the reference's drift beside it.
//
// Stress probes: the three normal stresses follow a ramp from the point's stresses s to s + M d over `steps`,
// are held for `hold_steps`, ramp back to s and are held again; the cell's tilts (shear strains) are held. The
// directions d lie in the Rendulic plane, the deviatoric (pi) plane at constant p, or are listed. Strain probes:
// each of the six strains (e11, e22, e33, g12, g13, g23) in turn moves by M and back, the others held; the
// stress increments over M are a column of the tangent stiffness, the recovered ones of its elastic part.
//
// The points' states are copies of the test's State taken at its rows as it runs (ProbePoints); the test's own
// series and summary are untouched. Outputs: <test>/probes/<point>/<probe>/series.csv, <test>/probes/probes.csv
// and <test>/probes/stiffness.json (docs/outputs.md).
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

class RunDirectory;
struct RunOptions;

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
  // In order: the e1 points, then the named ones as the deck lists them (without a peak reached, no `peak`).
  std::vector<Point> points(bool peak_reached) const;

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

// Probes measured from rest (Calvetti, Viggiani & Tamagnini 2003: a probe from equilibrium). Before its probes a
// point rests at its stresses until it creeps less than rest_fraction x target_strain in one probe's steps (or the
// budget rest_max_steps is spent), and the probes start from the rested state. A stress set also runs an elastic
// check: the six strain probes of target_strain from the same state, whose recovered stress increments are
// C_elastic. What a point's probes say is then judged on their evidence (judge_probe_point), and a point that
// fails a check says which in its status and withholds the readings that rest on it.

// The evidence a point's judgement rests on (NaN: not measured; a check with no evidence is not judged).
struct ProbeEvidence {
  bool rest_reached = true;  // the rest reached its goal within its budget
  double rest_creep = NAN;   // [-] the strain crept in the rest's last window
  std::string rest_gave_up;  // why the rest stopped before its budget without reaching its goal (empty: it did not)
  double drift = NAN;        // the reference's largest drift over a probe: |de| [-] (stress sets), |ds| [Pa] (strain)
  double smallest_response = NAN;  // the point's smallest probe response, in the drift's unit
  double elastic_asymmetry = NAN;  // |C - C^T| / |C| of the elastic stiffness
  double elastic_min_eigenvalue = NAN;  // [Pa] smallest eigenvalue of its symmetric part
  double elastic_factor = NAN;     // stress sets: the worst probe's disagreement (elastic_agreement); inf: turned
  std::string elastic_worst_probe;    // stress sets: the probe of elastic_factor
  std::string elastic_check_missing;  // stress sets: why the elastic check gave no C_elastic (empty: it did)
};

// The checks in the order a status names them, each a machine-readable status string.
inline constexpr std::array<std::string_view, 5> kProbeCheckNames = {
    "drifting", "not at rest", "elastic not positive definite", "elastic asymmetric", "elastic mismatch"};

struct ProbeVerdict {
  std::vector<std::string> failed;  // the checks failed, kProbeCheckNames order
  std::string reason;               // each failed check with its numbers and bound ("; " between)
};
ProbeVerdict judge_probe_point(const ProbeDef& def, const ProbeEvidence& evidence);

// How far a stress probe's recovered strain `measured` is from the elastic prediction C_elastic^-1 ds
// (`predicted`): the ratio of their lengths taken >= 1, or infinity where they are more than 60 deg apart (or one
// is zero). 1: they agree.
double elastic_agreement(const std::array<double, 6>& measured, const std::array<double, 6>& predicted);

// Whether a stress probe of direction `d` (ds11, ds22, ds33) from normal stresses `s` loads (+1: it raises
// s11/s33, the test's stress ratio), unloads (-1) or is neutral (0).
int probe_cone(const std::array<double, 6>& d, const Vec3& s);

// Runs a finished test's probes (in parallel over the test's threads, each probe on one; the results do not
// depend on the thread count) and writes probes.csv and stiffness.json. Returns summary.json's "probes" of the
// test: per point its probes, how many held their controls, and (stress probes) the response's linearity
// across magnitudes or (strain probes) the elastic stiffness's symmetry. A probe that fails is recorded (its
// error), not thrown; a stop request stops the run (probes are run again whole on --resume).
nlohmann::json run_test_probes(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                               const ProbePoints& points, bool peak_reached);

// probes.csv, stiffness.json and summary.json's "probes" of a test from its probe folders under `run_dir` (each
// point's point.json and point.state, each probe's result.json and series.csv): those this run made and those a
// merge brought from other jobs. A probe no folder holds is counted as `missing` at its point.
nlohmann::json tabulate_probes(const std::filesystem::path& run_dir, const Deck& deck, const TestDef& test);

}  // namespace celldem
