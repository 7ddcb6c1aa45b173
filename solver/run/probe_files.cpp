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

namespace celldem::probe_files {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// Strain probes net of their reference (`probes` in kStrainProbeNames order, each from the same start): the
// columns of the tangent stiffness (the loaded stress increments per unit strain) and of its elastic part (those
// recovered on unloading). With the reference's drift |ds| over the probe and the smallest |ds| response.
ElasticCheck strain_stiffness(const ProbeResult& reference, const std::vector<std::optional<ProbeResult>>& probes,
                              double magnitude) {
  ElasticCheck c;
  c.whole = reference.ran && reference.controlled;
  c.drift = std::max(norm(minus(stresses(reference.loaded), stresses(reference.start))),
                     norm(minus(stresses(reference.unloaded), stresses(reference.start))));
  c.smallest_response = INFINITY;
  for (std::size_t column = 0; column < probes.size(); ++column) {
    if (!probes[column] || !probes[column]->ran || !probes[column]->controlled) {
      c.whole = false;
      c.reason = std::string("the elastic check's probe ") + kStrainProbeNames[column] + " did not run or hold its control";
      continue;
    }
    const ProbeResult& r = *probes[column];
    const Row6 ds = minus(stresses(r.loaded), stresses(reference.loaded));
    const Row6 ds_residual = minus(stresses(r.unloaded), stresses(reference.unloaded));
    c.smallest_response = std::min(c.smallest_response, norm(ds));
    for (std::size_t i = 0; i < 6; ++i) {
      c.tangent(static_cast<int>(i), static_cast<int>(column)) = ds[i] / magnitude;
      c.elastic(static_cast<int>(i), static_cast<int>(column)) = (ds[i] - ds_residual[i]) / magnitude;
    }
  }
  return c;
}

// A scaled stress set's magnitude at a point [Pa]: target_strain over the largest compliance |C^-1 d| of the set's
// directions, C the tangent stiffness where its symmetric part is positive definite, else the elastic one; with
// what it came from. NaN where neither gives a finite positive size.
std::pair<double, std::string> stiffness_scale(const ProbeDef& def, const ElasticCheck& check) {
  const std::vector<ProbeDirection> directions = probe_directions(def);
  for (const auto& [c, from] : {std::pair{check.tangent, "tangent"}, std::pair{check.elastic, "elastic"}}) {
    if (!(min_symmetric_eigenvalue(c) > 0.0)) continue;
    const Eigen::Matrix<double, 6, 6> compliance = c.inverse();
    double largest = 0.0;
    for (std::size_t k = 1; k < directions.size(); ++k) {
      Eigen::Matrix<double, 6, 1> d;
      for (int i = 0; i < 6; ++i) d(i) = directions[k].direction[static_cast<std::size_t>(i)];
      largest = std::max(largest, (compliance * d).norm());
    }
    const double m = def.target_strain / largest;
    if (std::isfinite(m) && m > 0.0) return {m, from};
  }
  return {NAN, "none"};
}

}  // namespace

// A probe's record as its folder holds it (run_probe wrote it, in this run or in another job's: --probes);
// nullopt when the folder has none.
std::optional<ProbeResult> read_probe_result(const fs::path& dir) {
  if (!fs::exists(dir / kProbeResultName)) return std::nullopt;
  const Json j = Json::parse(read_file((dir / kProbeResultName).string()));
  ProbeResult r;
  r.ran = j.at("ran").get<bool>();
  r.controlled = j.at("controlled").get<bool>();
  r.error = j.at("error").get<std::string>();
  if (r.ran) {
    const std::vector<SeriesRow> rows = read_series_file(dir / "series.csv");
    const auto loaded = std::find_if(rows.rbegin(), rows.rend(), [](const SeriesRow& row) { return row.leg == 1.0; });
    if (loaded == rows.rend() || rows.back().leg != 3.0)
      throw RunError((dir / "series.csv").string() + ": no row at the end of the loaded hold (leg 1) or of the "
                     "unloaded hold (leg 3): not a finished probe's series");
    r.start = rows.front();
    r.loaded = *loaded;
    r.unloaded = rows.back();
  }
  return r;
}

// The smallest eigenvalue of the symmetric part of `a` [its unit]; NaN for a matrix with a non-finite entry.
double min_symmetric_eigenvalue(const Eigen::Matrix<double, 6, 6>& a) {
  if (!a.allFinite()) return NAN;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> solver(0.5 * (a + a.transpose()));
  return solver.eigenvalues().minCoeff();
}

ElasticCheck read_elastic_check(const fs::path& point_dir, const ProbeDef& def) {
  const std::optional<ProbeResult> reference = read_probe_result(point_dir / (std::string(kElasticPrefix) + "reference"));
  if (!reference || !reference->ran) {
    ElasticCheck c;
    c.reason = "the elastic check's reference did not run";
    return c;
  }
  std::vector<std::optional<ProbeResult>> probes;
  for (const char* name : kStrainProbeNames) probes.push_back(read_probe_result(point_dir / (std::string(kElasticPrefix) + name)));
  ElasticCheck c = strain_stiffness(*reference, probes, def.target_strain);
  if (!reference->controlled) c.reason = "the elastic check's reference lost its control";
  return c;
}

// A scaled stress set's magnitude at a point [Pa], and what it came from: stiffness_scale, capped by the test's path.
std::pair<double, std::string> probe_scale(const ProbeDef& def, const ElasticCheck& check, double path_tangent) {
  std::pair<double, std::string> sized = stiffness_scale(def, check);
  // A strain probe holds the other strains and so blocks the mechanism that a stress probe frees: the test's own
  // path (which loads at its stresses) is softer in the loading cone. The smaller size of the two, not below a
  // hundredth of the elastic one (at a limit state the path's tangent vanishes).
  const double path = def.target_strain * path_tangent;
  if (std::isfinite(sized.first) && std::isfinite(path) && path < sized.first)
    sized = {std::max(path, 0.01 * sized.first), path >= 0.01 * sized.first ? "path" : "path, floored"};
  return sized;
}

// The test's tangent along its own path at a point [Pa]: |ds| / |de| (six components each) between the point's row
// of the test's series and the row before it; NaN where there is none.
double path_tangent(const fs::path& run_dir, const TestDef& test, double point_step) {
  const fs::path file = run_dir / test.name / "series.csv";
  if (!fs::exists(file)) return NAN;
  const std::vector<SeriesRow> rows = read_series_file(file);
  const auto at = std::find_if(rows.begin(), rows.end(), [&](const SeriesRow& r) { return r.step == point_step; });
  if (at == rows.end() || at == rows.begin()) return NAN;
  const double de = norm(minus(strains(*at), strains(*(at - 1))));
  return de > 0.0 ? norm(minus(stresses(*at), stresses(*(at - 1)))) / de : NAN;
}

}  // namespace celldem::probe_files
