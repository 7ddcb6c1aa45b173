#include "run/probe_table.hpp"
#include "run/probe_files.hpp"
#include "run/probe_points.hpp"
#include "run/probe_verdict.hpp"

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
namespace fs = std::filesystem;
using Json = nlohmann::json;
using namespace probe_files;

namespace {

Json matrix_json(const Eigen::Matrix<double, 6, 6>& m) {
  Json rows = Json::array();
  for (int i = 0; i < 6; ++i) {
    Json row = Json::array();
    for (int j = 0; j < 6; ++j) row.push_back(m(i, j));
    rows.push_back(row);
  }
  return rows;
}

struct PlanePoint {
  double angle;  // [rad] the stress probe's direction in the plane
  double p1, p2; // its plastic strain increment's coordinates in the plane
};

double degrees_in_circle(double radians) {
  const double d = std::fmod(radians * 180.0 / kPi, 360.0);
  return d < 0.0 ? d + 360.0 : d;
}

// What the plastic responses of one probe set in a plane say, as an elastoplastic model reads them. With one
// plastic mechanism every plastic increment has the same direction (the flow direction), and its size grows
// with the loading direction's projection on the loading surface's normal n: |dep| = c max(0, cos(a - a_n)).
// The flow direction is the principal axis of the increments' scatter (its concentration
// lambda_max / (lambda_max + lambda_min) is 1 when all are parallel, 0.5 when they point anywhere), oriented
// as the increments of the directions that load; the normal is the a_n of the least-squares fit of that law over a 0.1 deg grid. Their angle is
// the non-associativity (0: associated flow).
Json plastic_response(const std::vector<PlanePoint>& points, double magnitude) {
  double sxx = 0.0, sxy = 0.0, syy = 0.0;
  for (const PlanePoint& q : points) sxx += q.p1 * q.p1, sxy += q.p1 * q.p2, syy += q.p2 * q.p2;
  if (points.empty() || sxx + syy == 0.0) return Json();
  const double half_trace = 0.5 * (sxx + syy), root = std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
  const double lambda_max = half_trace + root, lambda_min = half_trace - root;
  double flow = 0.5 * std::atan2(2.0 * sxy, sxx - syy);
  double best = INFINITY, normal = 0.0, scale = 0.0;
  for (int k = 0; k < 3600; ++k) {
    const double a = 2.0 * kPi * k / 3600.0;
    double gg = 0.0, gp = 0.0;
    for (const PlanePoint& q : points) {
      const double g = std::max(0.0, std::cos(q.angle - a));
      gg += g * g, gp += g * std::hypot(q.p1, q.p2);
    }
    if (gg == 0.0) continue;
    const double c = gp / gg;
    double misfit = 0.0;
    for (const PlanePoint& q : points) {
      const double r = std::hypot(q.p1, q.p2) - c * std::max(0.0, std::cos(q.angle - a));
      misfit += r * r;
    }
    if (misfit < best) best = misfit, normal = a, scale = c;
  }
  // Oriented as the plastic increments of the loading directions (those the fit loads: cos(a - normal) > 0).
  double along = 0.0;
  for (const PlanePoint& q : points)
    if (std::cos(q.angle - normal) > 0.0) along += std::cos(flow) * q.p1 + std::sin(flow) * q.p2;
  if (along < 0.0) flow += kPi;
  double between = std::abs(degrees_in_circle(flow) - degrees_in_circle(normal));
  if (between > 180.0) between = 360.0 - between;
  double total = 0.0;
  for (const PlanePoint& q : points) total += q.p1 * q.p1 + q.p2 * q.p2;
  return {{"magnitude", magnitude},
          {"flow_direction_deg", degrees_in_circle(flow)},
          {"flow_concentration", lambda_max / (lambda_max + lambda_min)},
          {"loading_normal_deg", degrees_in_circle(normal)},
          {"plastic_per_magnitude", scale / magnitude},
          {"fit_explains", total > 0.0 ? 1.0 - best / total : NAN},
          {"non_associativity_deg", between},
          {"meaning", "in the probes' plane (angles as the directions'): the plastic increments' principal direction "
                      "(flow) and how nearly parallel they are (concentration, 1: one mechanism), the loading "
                      "surface's normal from |de_plastic| = c max(0, cos(a - normal)) fitted over the directions "
                      "(plastic_per_magnitude = c / M, fit_explains: the share of the squared plastic response it "
                      "fits), and the angle between flow and normal (0: associated flow)"}};
}

// ||A - A^T|| / ||A|| (Frobenius): 0 for a symmetric matrix.
double asymmetry(const Eigen::Matrix<double, 6, 6>& a) {
  const double n = a.norm();
  return n > 0.0 ? (a - a.transpose()).norm() / n : NAN;
}

// The stiffness of the point's contact network (measure/network_stiffness.hpp: sticking tangential springs
// when the test has friction, normal springs only without), as a strain probe measures it: celldem's shear axes
// g_ij also turn the stress the sample carries (simple_shear_rotation), which the probes' g columns include.
// With the probes' elastic stiffness: ||C_elastic - C_network|| / ||C_network|| (Frobenius). An estimate the law
// or the network cannot give is recorded with its reason.
Json network_estimate(const Deck& deck, const TestDef& test, const State& point, const Eigen::Matrix<double, 6, 6>& elastic) {
  const bool tangential = test.friction > 0.0;
  Json out = {{"tangential_springs", tangential}};
  try {
    State state = point;
    const Model model = make_model(deck, state.particles.radius, deck.stage_time_step(test));
    state.pairs.skin = skin_length(deck);
    rebuild_pairs(model, state);  // a state read back holds its contacts' history, not a built list
    const NetworkStiffness n = network_stiffness(model, state, tangential);
    Mat3 stress;
    const auto& s = state.stress;
    stress << s[0], s[3], s[4], s[3], s[1], s[5], s[4], s[5], s[2];
    Stiffness6 probed = n.relaxed;
    for (int a = 0; a < 3; ++a) {
      Vec3 g = Vec3::Zero();
      g[a] = 1.0;
      probed.col(3 + a) += voigt_of_stress(simple_shear_rotation(stress, g));
    }
    out["affine"] = matrix_json(n.affine);
    out["relaxed"] = matrix_json(n.relaxed);
    out["affine_asymmetry"] = asymmetry(n.affine);
    out["relaxed_asymmetry"] = asymmetry(n.relaxed);
    out["relaxed_as_probed"] = matrix_json(probed);
    out["contacts"] = n.contacts;
    out["rattlers"] = n.rattlers;
    out["solver_residual"] = n.solver_residual;
    out["elastic_vs_network"] = (elastic - probed).norm() / probed.norm();
  } catch (const std::exception& e) {  // another law, or a network with no stable relaxed state
    out["error"] = e.what();
  }
  return out;
}

// The rest before a point's probes, as its folder holds it (rest_point); nullopt when there is none.
struct RestRecord {
  bool reached = false, controlled = true;
  std::int64_t steps = 0;
  double goal = NAN, last_creep = NAN;
  std::string error, gave_up;
  Json json;
};
std::optional<RestRecord> read_rest(const fs::path& point_dir) {
  const fs::path file = point_dir / kRestName / kProbeResultName;
  if (!fs::exists(file)) return std::nullopt;
  RestRecord r;
  r.json = Json::parse(read_file(file.string()));
  r.reached = r.json.at("reached").get<bool>();
  r.controlled = r.json.at("controlled").get<bool>();
  r.steps = r.json.at("steps").get<std::int64_t>();
  r.goal = r.json.at("goal").get<double>();
  r.error = r.json.at("error").get<std::string>();
  if (!r.json.at("creep").empty()) r.last_creep = r.json.at("creep").back().get<double>();
  r.gave_up = r.json.value("gave_up", std::string());
  return r;
}

}  // namespace

namespace {

// probes.csv's header: each probe's response net of its point's reference, at the loaded and the unloaded ends;
// beside it the reference's own drift over the probe, and (stress sets) the elastic prediction and the loading cone.
std::string probes_csv_header() {
  std::string csv = "point,point_step,point_e1,kind,probe,magnitude,angle_deg,d11,d22,d33,d12,d13,d23";
  const auto add_columns = [&](const std::array<const char*, 6>& names, const char* suffix) {
    for (const char* name : names) csv.append(",d").append(name).append(suffix);
  };
  add_columns(kStressNames, "");
  add_columns(kStrainNames, "");
  add_columns(kStrainNames, "_plastic");
  add_columns(kStrainNames, "_elastic");
  add_columns(kStressNames, "_residual");
  csv += ",response,reference_drift,elastic_predicted,elastic_factor,cone,controlled,status\n";
  return csv;
}

// summary.json's probes of a test before its points: the set's settings and rules.
Json set_summary(const ProbeDef& def, const TestDef& test) {
  const bool stress_set = def.kind == ProbeKind::Stress;
  Json summary = {{"kind", std::string(name_of(def.kind, kProbeKindNames))}, {"steps", def.steps},
                  {"hold_steps", def.hold_steps}, {"magnitudes", def.magnitudes}, {"points", Json::object()},
                  {"table", (fs::path(test.name) / "probes" / "probes.csv").string()},
                  {"target_strain", def.target_strain},
                  {"rules", {{"rest_fraction", def.rest_fraction}, {"rest_max_steps", def.rest_max_steps},
                             {"drift_limit", def.drift_limit}, {"asymmetry_limit", def.asymmetry_limit}}}};
  if (stress_set) summary["rules"]["elastic_factor"] = def.elastic_factor;
  if (def.scaled && stress_set) {
    summary["magnitudes"] = Json::array();  // per point (points.<p>.magnitudes)
    summary["magnitude_factors"] = def.magnitudes;
  }
  if (stress_set) summary["plane"] = std::string(name_of(def.plane, kProbePlaneNames));
  return summary;
}

// One point of the table as it is being made: its folder, its row of the test, its summary entry, the evidence of
// its judgement, and the probes' size.
struct PointTable {
  std::string name;
  fs::path dir;
  double step = 0.0, e1 = 0.0;
  Json entry;
  ProbeEvidence evidence;
  ElasticCheck check;  // stress sets
  double scale = 1.0;  // given magnitudes as they are
};

// A stress set's elastic check into the point's entry and evidence, and the probes' size where it is scaled. False
// when the point ends here (no stiffness to size its probes by: they were not run).
bool tabulate_elastic_check(const fs::path& run_dir, const TestDef& test, PointTable& t) {
  const ProbeDef& def = *test.probes;
  t.check = read_elastic_check(t.dir, def);
  const ElasticCheck& check = t.check;
  Json e = {{"target_strain", def.target_strain}, {"whole", check.whole}};
  if (!check.whole) e["reason"] = check.reason;
  e["elastic"] = matrix_json(check.elastic);
  e["tangent"] = matrix_json(check.tangent);
  const double asymmetry_of_elastic = asymmetry(check.elastic);
  const double min_eigenvalue_of_elastic = min_symmetric_eigenvalue(check.elastic);
  e["elastic_asymmetry"] = asymmetry_of_elastic;
  e["elastic_min_eigenvalue"] = min_eigenvalue_of_elastic;
  e["reference_drift_stress"] = check.drift;
  t.entry["elastic_check"] = e;
  if (!check.whole) t.evidence.elastic_check_missing = check.reason;
  if (check.whole) {
    t.evidence.elastic_asymmetry = asymmetry_of_elastic;
    t.evidence.elastic_min_eigenvalue = min_eigenvalue_of_elastic;
  }
  if (!def.scaled) return true;
  std::string scale_from = "given";
  std::tie(t.scale, scale_from) = probe_scale(def, check, path_tangent(run_dir, test, t.step));
  Json m = Json::array();
  for (double f : def.magnitudes) m.push_back(f * t.scale);
  t.entry["magnitudes"] = m;
  t.entry["magnitude_from"] = scale_from;
  if (std::isfinite(t.scale)) return true;
  // Its probes were not run (run_test_probes).
  const ProbeVerdict v = judge_probe_point(def, t.evidence);
  t.entry["checks_failed"] = v.failed;
  t.entry["status"] = "failed";
  t.entry["reason"] = "no stiffness to size the probes by: the elastic check's tangent and elastic stiffness "
                      "are both not positive definite (elastic_check)" + (v.reason.empty() ? "" : "; " + v.reason);
  return false;
}

// What a point's probes gave, net of its reference: counts, the smallest response and the elastic agreement, and
// per magnitude the strain set's stiffness columns or the stress set's responses, cones and plastic increments.
struct ProbeRows {
  int ran = 0, controlled = 0, failed = 0, missing = 0;
  double drift = 0.0;  // the reference's largest drift over a probe
  double smallest = INFINITY, worst_factor = 0.0;
  std::string worst_probe;
  std::vector<double> factors;
  std::vector<Eigen::Matrix<double, 6, 6>> tangent, elastic;  // strain probes: per magnitude
  std::vector<std::vector<double>> response;                  // stress probes: |de| per direction and magnitude
  std::vector<std::vector<int>> cones;
  std::vector<std::vector<PlanePoint>> plastic;               // stress probes in a plane
};

// One probe's row of probes.csv (appended to `csv`) and what it adds to `rows`.
void tabulate_probe(const ProbeDef& def, const PointTable& t, const ProbeDirection& d, const ProbeResult& r,
                    const ProbeResult& reference, ProbeRows& rows, std::string& csv) {
  const bool stress_set = def.kind == ProbeKind::Stress;
  const ElasticCheck& check = t.check;
  const Vec3 s{reference.start.s11, reference.start.s22, reference.start.s33};
  const std::size_t m = static_cast<std::size_t>(std::find(def.magnitudes.begin(), def.magnitudes.end(), d.magnitude) - def.magnitudes.begin());
  const double magnitude = stress_set ? d.magnitude * t.scale : d.magnitude;
  csv.append(t.name).append(",").append(fmt10(t.step)).append(",").append(fmt10(t.e1));
  csv.append(",").append(name_of(def.kind, kProbeKindNames)).append(",").append(d.name);
  csv.append(",").append(fmt10(magnitude)).append(",").append(fmt10(d.angle_deg));
  for (double x : d.direction) csv.append(",").append(fmt10(x));
  if (!r.ran) {
    ++rows.failed;
    for (int c = 0; c < 35; ++c) csv += ",";
    std::string why = r.error;
    std::replace(why.begin(), why.end(), ',', ';');
    std::replace(why.begin(), why.end(), '\n', ' ');
    csv.append(",false,failed: ").append(why).append("\n");
    return;
  }
  ++rows.ran;
  rows.controlled += r.controlled;
  const Row6 ds = minus(stresses(r.loaded), stresses(reference.loaded));
  const Row6 de = minus(strains(r.loaded), strains(reference.loaded));
  const Row6 de_plastic = minus(strains(r.unloaded), strains(reference.unloaded));
  const Row6 ds_residual = minus(stresses(r.unloaded), stresses(reference.unloaded));
  const Row6 de_elastic = minus(de, de_plastic);
  for (const Row6* v : {&ds, &de, &de_plastic, &de_elastic, &ds_residual})
    for (double x : *v) csv.append(",").append(fmt10(x));
  const double size = stress_set ? norm(de) : norm(ds);
  rows.smallest = std::min(rows.smallest, size);
  double predicted = NAN, factor = NAN;
  int cone = 0;
  if (stress_set) {
    cone = probe_cone(d.direction, s);
    if (check.whole) {  // C_elastic^-1 of the recovered stress increment
      Eigen::Matrix<double, 6, 1> recovered;
      for (int i = 0; i < 6; ++i) recovered(i) = ds[static_cast<std::size_t>(i)] - ds_residual[static_cast<std::size_t>(i)];
      const Eigen::Matrix<double, 6, 1> p = check.elastic.fullPivLu().solve(recovered);
      Row6 prediction;
      for (int i = 0; i < 6; ++i) prediction[static_cast<std::size_t>(i)] = p(i);
      predicted = norm(prediction);
      factor = elastic_agreement(de_elastic, prediction);
      rows.factors.push_back(factor);
      if (!(factor <= rows.worst_factor)) rows.worst_probe = d.name;
      rows.worst_factor = std::max(rows.worst_factor, factor);
    }
  }
  csv.append(",").append(fmt10(size)).append(",").append(fmt10(rows.drift)).append(",").append(fmt10(predicted));
  csv.append(",").append(fmt10(factor)).append(",").append(stress_set ? (cone > 0 ? "loading" : cone < 0 ? "unloading" : "neutral") : "");
  csv.append(r.controlled ? ",true,ok\n" : ",false,ok\n");
  if (!stress_set) {
    const int column = static_cast<int>(std::max_element(d.direction.begin(), d.direction.end()) - d.direction.begin());
    for (int i = 0; i < 6; ++i) {
      rows.tangent[m](i, column) = ds[static_cast<std::size_t>(i)] / d.magnitude;
      rows.elastic[m](i, column) = (ds[static_cast<std::size_t>(i)] - ds_residual[static_cast<std::size_t>(i)]) / d.magnitude;
    }
  } else {
    rows.response[m].push_back(norm(de));
    rows.cones[m].push_back(cone);
    if (def.plane != ProbePlane::List) {
      const auto [u1, u2] = plane_basis(def.plane);
      double p1 = 0.0, p2 = 0.0;
      for (int c = 0; c < 3; ++c) p1 += u1[c] * de_plastic[c], p2 += u2[c] * de_plastic[c];
      rows.plastic[m].push_back({d.angle_deg * kPi / 180.0, p1, p2});
    }
  }
}

// Every probe of a point (those another job ran and no merge brought counted as missing).
ProbeRows tabulate_probe_rows(const ProbeDef& def, const PointTable& t, const ProbeResult& reference, std::string& csv) {
  const bool stress_set = def.kind == ProbeKind::Stress;
  ProbeRows rows;
  rows.tangent.assign(def.magnitudes.size(), Eigen::Matrix<double, 6, 6>::Zero());
  rows.elastic = rows.tangent;
  rows.response.resize(def.magnitudes.size());
  rows.cones.resize(def.magnitudes.size());
  rows.plastic.resize(def.magnitudes.size());
  // The reference's drift over a probe: its strains (stress sets: it holds the stresses) or its stresses (strain
  // sets: it holds the strains) from its start to the ends of the loaded and the unloaded holds.
  rows.drift = stress_set ? std::max(norm(minus(strains(reference.loaded), strains(reference.start))),
                                     norm(minus(strains(reference.unloaded), strains(reference.start))))
                          : std::max(norm(minus(stresses(reference.loaded), stresses(reference.start))),
                                     norm(minus(stresses(reference.unloaded), stresses(reference.start))));
  const std::vector<ProbeDirection> directions = probe_directions(def);
  for (std::size_t k = 1; k < directions.size(); ++k) {
    const std::optional<ProbeResult> record = read_probe_result(t.dir / directions[k].name);
    if (!record) {  // another job's (--probes), not merged
      ++rows.missing;
      continue;
    }
    tabulate_probe(def, t, directions[k], *record, reference, rows, csv);
  }
  return rows;
}

// The status, counts, drift and elastic agreement of a point's probes into its entry and evidence; whether the set is
// whole (every probe ran here and held its controls).
bool tabulate_set(const TestDef& test, const ProbeRows& rows, PointTable& t) {
  const ProbeDef& def = *test.probes;
  Json& entry = t.entry;
  // What the set says (stiffness, linearity, the plastic reading) only from a whole set that held its controls:
  // a probe whose stress or strain left its target did not probe the direction it names.
  const bool whole = rows.failed == 0 && rows.missing == 0 && rows.controlled == rows.ran;
  entry["status"] = rows.missing > 0 ? "partly run" : rows.failed > 0 ? "ran with failures" : whole ? "ran" : "ran with uncontrolled probes";
  if (entry["status"] == "ran with uncontrolled probes")
    entry["reason"] = std::to_string(rows.ran - rows.controlled) + " probes lost their control (result.json control_errors): "
                      "the set's stiffness, linearity and plastic reading are not given";
  entry["probes"] = rows.ran + rows.failed;
  entry["failed"] = rows.failed;
  if (rows.missing > 0) {
    entry["missing"] = rows.missing;
    entry["reason"] = std::to_string(rows.missing) + " probes were left to other jobs (--probes); `celldem merge` gathers them";
  }
  entry["controlled"] = rows.controlled;
  entry["folder"] = (fs::path(test.name) / "probes" / t.name).string();
  if (rows.ran > 0) {
    t.evidence.drift = rows.drift;
    t.evidence.smallest_response = rows.smallest;
    entry["drift"] = {{"reference", rows.drift}, {"smallest_response", rows.smallest}, {"ratio", rows.drift / rows.smallest},
                      {"unit", def.kind == ProbeKind::Stress ? "strain |de|" : "stress |ds| [Pa]"}};
  }
  if (!rows.factors.empty()) {
    t.evidence.elastic_factor = rows.worst_factor;
    t.evidence.elastic_worst_probe = rows.worst_probe;
    std::vector<double> sorted = rows.factors;
    std::sort(sorted.begin(), sorted.end());
    const std::vector<double>& factors = rows.factors;
    entry["elastic_check"]["agreement"] = {
        {"worst_factor", rows.worst_factor},  // null when a probe's is infinite (turned)
        {"worst_probe", rows.worst_probe},
        {"turned", std::count_if(factors.begin(), factors.end(), [](double f) { return std::isinf(f); })},
        {"median_factor", sorted[sorted.size() / 2]},
        {"within_limit", std::count_if(factors.begin(), factors.end(), [&](double f) { return f <= def.elastic_factor; })},
        {"probes", factors.size()},
        {"meaning", "per probe, its recovered strain against C_elastic^-1 ds (elastic_agreement): the ratio of "
                    "lengths taken >= 1, infinite where they are more than 60 deg apart"}};
  }
  return whole;
}

// A whole strain set's stiffness per magnitude (stiffness.json's point), with the contact network's estimate.
Json strain_set_stiffness(const Deck& deck, const TestDef& test, const ProbeRows& rows, PointTable& t) {
  const ProbeDef& def = *test.probes;
  Json per_magnitude = Json::array();
  for (std::size_t m = 0; m < def.magnitudes.size(); ++m)
    per_magnitude.push_back({{"magnitude", def.magnitudes[m]}, {"tangent", matrix_json(rows.tangent[m])},
                             {"elastic", matrix_json(rows.elastic[m])}, {"elastic_asymmetry", asymmetry(rows.elastic[m])},
                             {"elastic_min_eigenvalue", min_symmetric_eigenvalue(rows.elastic[m])},
                             {"tangent_asymmetry", asymmetry(rows.tangent[m])}});
  Json point = {{"step", t.step}, {"e1", t.e1}, {"magnitudes", per_magnitude}};
  t.entry["elastic_asymmetry"] = per_magnitude[0]["elastic_asymmetry"];
  t.entry["elastic_min_eigenvalue"] = per_magnitude[0]["elastic_min_eigenvalue"];
  t.evidence.elastic_asymmetry = asymmetry(rows.elastic.front());
  t.evidence.elastic_min_eigenvalue = min_symmetric_eigenvalue(rows.elastic.front());
  const Json network = network_estimate(deck, test, read_state((t.dir / "point.state").string()), rows.elastic.front());
  point["network"] = network;
  if (network.contains("elastic_vs_network")) t.entry["elastic_vs_network"] = network["elastic_vs_network"];
  return point;
}

// A stress set's linearity across magnitudes: per direction |de(M_last)| / |de(M_first)| / (M_last / M_first), 1 in
// the linear range; given per cone (loading: the probe raises s11/s33), whose responses differ. Null: none.
Json linearity(const ProbeDef& def, const ProbeRows& rows) {
  const std::size_t last = def.magnitudes.size() - 1;
  std::vector<double> all;
  std::vector<double> by_cone[2];
  for (std::size_t i = 0; i < rows.response[0].size() && i < rows.response[last].size(); ++i) {
    const double ratio = rows.response[last][i] / rows.response[0][i] / (def.magnitudes[last] / def.magnitudes[0]);
    all.push_back(ratio);
    if (rows.cones[0][i] != 0) by_cone[rows.cones[0][i] > 0 ? 0 : 1].push_back(ratio);
  }
  const auto describe = [](std::vector<double> r) {
    if (r.empty()) return Json();
    std::sort(r.begin(), r.end());
    return Json{{"directions", r.size()}, {"median_ratio", r[r.size() / 2]}, {"min_ratio", r.front()},
                {"max_ratio", r.back()}};
  };
  if (all.empty()) return Json();
  Json out = describe(all);
  out["loading"] = describe(by_cone[0]);
  out["unloading"] = describe(by_cone[1]);
  out["meaning"] = "per direction |de| at the largest magnitude over |de| at the smallest, divided by the "
                   "magnitudes' ratio (1 where the response is linear): over all directions, and per cone "
                   "(loading: the probe raises s11/s33; unloading: it lowers it)";
  return out;
}

// The point's judgement (judge_probe_point): a status naming the first check failed, every failed check with its
// numbers, and the readings that rest on them (linearity, the plastic reading) withheld.
void judge_point(const ProbeDef& def, const ProbeRows& rows, bool whole, PointTable& t) {
  Json& entry = t.entry;
  const bool stress_set = def.kind == ProbeKind::Stress;
  const ProbeVerdict verdict = judge_probe_point(def, t.evidence);
  entry["checks_failed"] = verdict.failed;
  const bool trusted = verdict.failed.empty();
  if (whole && !trusted) {
    entry["status"] = verdict.failed.front();
    entry["reason"] = verdict.reason;
  } else if (!trusted) {
    entry["checks_reason"] = verdict.reason;
  }
  const std::string withheld = "withheld: " + verdict.reason;
  if (stress_set && def.magnitudes.size() > 1 && whole) {
    const Json line = linearity(def, rows);
    if (!line.is_null()) {
      const bool drifting = std::find(verdict.failed.begin(), verdict.failed.end(), kProbeCheckNames[0]) != verdict.failed.end();
      if (drifting) {
        entry["linearity"] = nullptr;
        entry["linearity_withheld"] = withheld;
      } else {
        entry["linearity"] = line;
      }
    }
  }
  if (stress_set && def.plane != ProbePlane::List && whole) {
    if (trusted) {
      entry["plastic"] = plastic_response(rows.plastic.back(), def.magnitudes.back() * t.scale);
    } else {  // the split into elastic and plastic parts, and so flow, normal and concentration, rests on the checks
      entry["plastic"] = nullptr;
      entry["plastic_withheld"] = withheld;
    }
  }
}

// One point of the table: its entry of summary.json's probes (its rows appended to `csv`, a strain set's stiffness
// added to `stiffness`).
Json tabulate_point(const fs::path& run_dir, const Deck& deck, const TestDef& test, const std::string& name,
                    std::string& csv, Json& stiffness) {
  const ProbeDef& def = *test.probes;
  PointTable t;
  t.name = name;
  t.dir = run_dir / test.name / "probes" / name;
  if (!fs::exists(t.dir / kPointRecordName))
    throw RunError(t.dir.string() + ": no " + kPointRecordName + " (not a probed run folder)");
  const Json record = Json::parse(read_file((t.dir / kPointRecordName).string()));
  t.step = record.at("step").get<double>(), t.e1 = record.at("e1").get<double>();
  t.entry = {{"step", t.step}, {"e1", t.e1}};
  // A point that ends here: its status and why.
  const auto settle = [&](const char* status, const std::string& reason) {
    t.entry["status"] = status;
    t.entry["reason"] = reason;
    return t.entry;
  };
  const auto left_to_other_jobs = [&] {
    t.entry["missing"] = static_cast<std::int64_t>(probe_directions(def).size()) - 1;
    return settle("not run here", "its probes were left to other jobs (--probes); `celldem merge` gathers them");
  };
  if (!record.at("reached").get<bool>()) return settle("not run", record.at("reason").get<std::string>());
  t.entry["state"] = (fs::path(test.name) / "probes" / name / "point.state").string();
  const std::optional<ProbeResult> reference_record = read_probe_result(t.dir / "reference");
  const std::optional<RestRecord> rest = read_rest(t.dir);
  if (!rest) return left_to_other_jobs();
  t.entry["rest"] = {{"reached", rest->reached}, {"steps", rest->steps}, {"goal", rest->goal},
                     {"last_window_creep", rest->last_creep}, {"window_steps", rest->json.at("window_steps")},
                     {"controlled", rest->controlled}, {"probed_from", rest->reached ? "rest" : "point"},
                     {"folder", (fs::path(test.name) / "probes" / name / kRestName).string()}};
  if (!rest->gave_up.empty()) t.entry["rest"]["gave_up"] = rest->gave_up;
  if (!rest->error.empty()) return settle("failed", "the rest before the probes failed: " + rest->error);
  t.evidence.rest_reached = rest->reached;
  t.evidence.rest_creep = rest->last_creep;
  t.evidence.rest_gave_up = rest->gave_up;
  // A stress set's elastic check: C_elastic at the same rested state, and the probes' size where it is scaled.
  if (def.kind == ProbeKind::Stress && !tabulate_elastic_check(run_dir, test, t)) return t.entry;
  if (!reference_record) return left_to_other_jobs();
  if (!reference_record->ran) return settle("failed", "the reference probe failed: " + reference_record->error);
  const ProbeRows rows = tabulate_probe_rows(def, t, *reference_record, csv);
  const bool whole = tabulate_set(test, rows, t);
  if (def.kind == ProbeKind::Strain && whole) stiffness["points"][name] = strain_set_stiffness(deck, test, rows, t);
  judge_point(def, rows, whole, t);
  return t.entry;
}

}  // namespace

Json tabulate_probes(const fs::path& run_dir, const Deck& deck, const TestDef& test) {
  const ProbeDef& def = *test.probes;
  const fs::path probes_dir = run_dir / test.name / "probes";
  std::string csv = probes_csv_header();
  Json summary = set_summary(def, test);
  Json stiffness = {{"voigt_order", {"11", "22", "33", "12", "13", "23"}},
                    {"units", "Pa per unit strain; engineering shear strains g_ij; compression +"},
                    {"points", Json::object()}};
  for (const std::string& name : probe_point_names(def))
    summary["points"][name] = tabulate_point(run_dir, deck, test, name, csv, stiffness);
  write_file_atomic(probes_dir / "probes.csv", csv);
  if (def.kind == ProbeKind::Strain) {
    write_file_atomic(probes_dir / "stiffness.json", stiffness.dump(1));
    summary["stiffness"] = (fs::path(test.name) / "probes" / "stiffness.json").string();
  }
  return summary;
}

}  // namespace celldem
