// What the probes' folders hold and what their runs (run/probes.cpp) and their table (run/probe_table.cpp) both
// read: the file names, a probe's record, a stress set's elastic check and the probes' size it gives.
#pragma once
#include <array>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "core/deck.hpp"
#include "measure/series.hpp"

namespace celldem::probe_files {

inline constexpr double kPi = 3.14159265358979323846;
using Row6 = std::array<double, 6>;
inline constexpr std::array<const char*, 6> kStressNames = {"s11", "s22", "s33", "s12", "s13", "s23"};
inline constexpr std::array<const char*, 6> kStrainNames = {"e1", "e2", "e3", "g12", "g13", "g23"};
inline constexpr std::array<const char*, 6> kStrainProbeNames = {"e11", "e22", "e33", "g12", "g13", "g23"};


inline Row6 stresses(const SeriesRow& r) { return {r.s11, r.s22, r.s33, r.s12, r.s13, r.s23}; }
inline Row6 strains(const SeriesRow& r) { return {r.e1, r.e2, r.e3, r.g12, r.g13, r.g23}; }
inline Row6 minus(const Row6& a, const Row6& b) {
  Row6 d;
  for (int k = 0; k < 6; ++k) d[k] = a[k] - b[k];
  return d;
}
inline double norm(const Row6& a) {
  double s = 0.0;
  for (double x : a) s += x * x;
  return std::sqrt(s);
}

// What one probe did: its rows at the end of the loaded hold and of the unloaded hold.
struct ProbeResult {
  bool ran = false;
  bool controlled = true;
  std::string error;   // the probe failed (a RunError), else empty
  SeriesRow start, loaded, unloaded;
};

inline constexpr const char* kProbeResultName = "result.json";
inline constexpr const char* kPointRecordName = "point.json";

inline constexpr const char* kRestName = "rest";            // <point>/rest: the rest before probing
inline constexpr const char* kRestedStateName = "rested.state";
inline constexpr const char* kElasticPrefix = "elastic-";   // <point>/elastic-<probe>: a stress set's elastic check


// A probe's record as its folder holds it (run_probe wrote it, in this run or in another job's: --probes);
// nullopt when the folder has none.
std::optional<ProbeResult> read_probe_result(const std::filesystem::path& dir);

// The smallest eigenvalue of the symmetric part of `a` [its unit]; NaN for a matrix with a non-finite entry.
double min_symmetric_eigenvalue(const Eigen::Matrix<double, 6, 6>& a);

// A stress set's elastic check at a point (its six strain probes net of their reference, which holds the strains):
// the tangent and elastic stiffness, the reference's stress drift and the smallest probe response |ds|.
struct ElasticCheck {
  bool whole = false;  // every probe and the reference ran and held their controls
  std::string reason;  // why not
  Eigen::Matrix<double, 6, 6> tangent = Eigen::Matrix<double, 6, 6>::Zero(), elastic = tangent;
  double drift = NAN, smallest_response = NAN;  // [Pa]
};

// A stress set's elastic check as the point's folder holds it (<point>/elastic-<probe>/).
ElasticCheck read_elastic_check(const std::filesystem::path& point_dir, const ProbeDef& def);

// A scaled stress set's magnitude at a point [Pa], and what it came from: target_strain over the largest compliance
// |C^-1 d| of the set's directions (C the tangent stiffness where its symmetric part is positive definite, else the
// elastic one), capped by the test's path; NaN where neither gives a finite positive size.
std::pair<double, std::string> probe_scale(const ProbeDef& def, const ElasticCheck& check, double path_tangent);

// The test's tangent along its own path at a point [Pa]: |ds| / |de| between the point's row of the test's series
// and the row before it; NaN where there is none.
double path_tangent(const std::filesystem::path& run_dir, const TestDef& test, double point_step);

}  // namespace celldem::probe_files
