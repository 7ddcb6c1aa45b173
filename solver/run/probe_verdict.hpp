// What a probe point's probes say, judged on their evidence (run/probes.hpp).
#pragma once
#include <array>
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "core/deck.hpp"

namespace celldem {

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

}  // namespace celldem
