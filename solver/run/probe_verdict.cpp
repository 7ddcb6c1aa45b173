#include "run/probe_verdict.hpp"
#include "run/probe_files.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <tuple>

#include <Eigen/Dense>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "io/files.hpp"
#include "measure/network_stiffness.hpp"
#include "neighbor/neighbor_list.hpp"
#include "io/series_file.hpp"
#include "io/state_file.hpp"
#include "run/preflight.hpp"
#include "run/program.hpp"
#include "run/progress.hpp"
#include "run/run_directory.hpp"
#include "run/errors.hpp"
#include "run/stage_runner.hpp"
#include "step.hpp"

namespace celldem {
using namespace probe_files;

ProbeVerdict judge_probe_point(const ProbeDef& def, const ProbeEvidence& e) {
  ProbeVerdict v;
  const auto fail = [&](std::string_view check, const std::string& why) {
    v.failed.emplace_back(check);
    if (!v.reason.empty()) v.reason += "; ";
    v.reason.append(check).append(": ").append(why);
  };
  const double drift_ratio = e.drift / e.smallest_response;
  if (std::isfinite(e.smallest_response) && !(e.smallest_response > 0.0))  // no ratio to print: say what it means
    fail(kProbeCheckNames[0], "the smallest response is " + fmt10(e.smallest_response) +
                                  ": the probe moved nothing it can be judged on (magnitudes too small to measure)");
  else if (std::isfinite(e.drift) && std::isfinite(e.smallest_response) && !(drift_ratio <= def.drift_limit))
    fail(kProbeCheckNames[0], "the reference drifts " + fmt10(e.drift) + " over a probe, " + fmt10(drift_ratio) +
                                  " of the smallest response " + fmt10(e.smallest_response) + " (limit " +
                                  fmt10(def.drift_limit) + ")");
  if (!e.rest_reached && std::isnan(e.rest_creep))
    fail(kProbeCheckNames[1], "the point was not rested (rest_max_steps " + std::to_string(def.rest_max_steps) +
                                  "); probed as the test took it");
  else if (!e.rest_reached)
    fail(kProbeCheckNames[1], "the rest's last window crept " + fmt10(e.rest_creep) + " (goal " +
                                  fmt10(def.rest_fraction * def.target_strain) + ") when " +
                                  (e.rest_gave_up.empty() ? "its budget of " + std::to_string(def.rest_max_steps) +
                                                                " steps was spent"
                                                          : e.rest_gave_up) +
                                  "; probed as the test took it");
  if (std::isfinite(e.elastic_asymmetry) || !std::isnan(e.elastic_min_eigenvalue)) {
    if (!(e.elastic_min_eigenvalue > 0.0))
      fail(kProbeCheckNames[2], "the elastic stiffness's symmetric part has the eigenvalue " +
                                    fmt10(e.elastic_min_eigenvalue) + " Pa");
    if (!(e.elastic_asymmetry <= def.asymmetry_limit))
      fail(kProbeCheckNames[3], "|C - C^T| / |C| = " + fmt10(e.elastic_asymmetry) + " (limit " +
                                    fmt10(def.asymmetry_limit) + ")");
  }
  if (!e.elastic_check_missing.empty())
    fail(kProbeCheckNames[4], "no elastic part to compare with: " + e.elastic_check_missing);
  else if (!std::isnan(e.elastic_factor) && !(e.elastic_factor <= def.elastic_factor))
    fail(kProbeCheckNames[4], (e.elastic_worst_probe.empty() ? "a probe" : e.elastic_worst_probe) + "'s recovered strain is " +
                                  (std::isfinite(e.elastic_factor) ? fmt10(e.elastic_factor) + " times"
                                                                   : std::string("more than 60 deg from")) +
                                  " C_elastic^-1 ds (limit " + fmt10(def.elastic_factor) + "x)");
  return v;
}

double elastic_agreement(const std::array<double, 6>& measured, const std::array<double, 6>& predicted) {
  const double a = norm(measured), p = norm(predicted);
  if (!(a > 0.0) || !(p > 0.0)) return INFINITY;
  double dot = 0.0;
  for (std::size_t k = 0; k < 6; ++k) dot += measured[k] * predicted[k];
  if (!(dot / (a * p) >= 0.5)) return INFINITY;  // more than 60 deg apart (or NaN)
  return std::max(a / p, p / a);
}

int probe_cone(const std::array<double, 6>& d, const Vec3& s) {
  const double change = d[0] * s[2] - s[0] * d[2];  // s33^2 d(s11/s33)
  const double scale = std::abs(s[0]) + std::abs(s[2]);
  if (!(std::abs(change) > 1e-9 * scale)) return 0;
  return change > 0.0 ? 1 : -1;
}

}  // namespace celldem
