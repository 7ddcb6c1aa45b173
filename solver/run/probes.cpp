#include "run/probes.hpp"

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

#include <Eigen/Dense>

#include "cell/control.hpp"
#include "core/model.hpp"
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
#include "run/runner.hpp"
#include "run/stage_output.hpp"
#include "step.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

constexpr double kPi = 3.14159265358979323846;
using Row6 = std::array<double, 6>;
constexpr std::array<const char*, 6> kStressNames = {"s11", "s22", "s33", "s12", "s13", "s23"};
constexpr std::array<const char*, 6> kStrainNames = {"e1", "e2", "e3", "g12", "g13", "g23"};
constexpr std::array<const char*, 6> kStrainProbeNames = {"e11", "e22", "e33", "g12", "g13", "g23"};

std::string fmt(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", x);
  return buf;
}

Row6 stresses(const SeriesRow& r) { return {r.s11, r.s22, r.s33, r.s12, r.s13, r.s23}; }
Row6 strains(const SeriesRow& r) { return {r.e1, r.e2, r.e3, r.g12, r.g13, r.g23}; }
Row6 minus(const Row6& a, const Row6& b) {
  Row6 d;
  for (int k = 0; k < 6; ++k) d[k] = a[k] - b[k];
  return d;
}
double norm(const Row6& a) {
  double s = 0.0;
  for (double x : a) s += x * x;
  return std::sqrt(s);
}

// The stress direction cos a u1 + sin a u2 of a probe plane, given cos a and sin a. Rendulic: u1 = (1, 0, 0),
// u2 = (0, 1, 1)/sqrt 2; deviatoric: u1 = (2, -1, -1)/sqrt 6 (a = 0 is triaxial compression), u2 = (0, 1, -1)/sqrt 2.
std::array<double, 3> plane_direction(ProbePlane plane, double c, double s) {
  if (plane == ProbePlane::Rendulic) return {c, s / std::sqrt(2.0), s / std::sqrt(2.0)};
  return {2.0 * c / std::sqrt(6.0), -c / std::sqrt(6.0) + s / std::sqrt(2.0), -c / std::sqrt(6.0) - s / std::sqrt(2.0)};
}

// Whether a row has reached an e1 point: past it in the direction of its sign.
bool reaches(const SeriesRow& row, double target) { return target >= 0.0 ? row.e1 >= target : row.e1 <= target; }

}  // namespace

std::pair<std::array<double, 3>, std::array<double, 3>> plane_basis(ProbePlane plane) {
  return {plane_direction(plane, 1.0, 0.0), plane_direction(plane, 0.0, 1.0)};
}

ProbeSelection parse_probe_selection(const std::string& text) {
  ProbeSelection s;
  const std::size_t dash = text.find('-');
  try {
    std::size_t used = 0;
    s.first = std::stoll(text.substr(0, dash), &used);
    if (used != (dash == std::string::npos ? text.size() : dash)) throw std::invalid_argument("");
    s.last = s.first;
    if (dash != std::string::npos) {
      s.last = std::stoll(text.substr(dash + 1), &used);
      if (used != text.size() - dash - 1) throw std::invalid_argument("");
    }
  } catch (const std::logic_error&) {
    throw std::invalid_argument("expected K or K-L (probe numbers from 1), got \"" + text + "\"");
  }
  if (s.first < 1 || s.last < s.first)
    throw std::invalid_argument("expected K or K-L with 1 <= K <= L, got \"" + text + "\"");
  return s;
}

namespace {
std::int64_t probes_of(const TestDef& test) {  // references not counted
  const ProbePlan p = plan_probes(test);
  return p.points * std::max<std::int64_t>(0, p.probes_per_point - 1);
}
}  // namespace

std::int64_t probe_number_offset(const Deck& deck, const TestDef& test) {
  std::int64_t offset = 0;
  for (const TestDef& t : deck.tests) {
    if (t.name == test.name) break;
    offset += probes_of(t);
  }
  return offset;
}

std::int64_t probe_count(const Deck& deck) {
  std::int64_t n = 0;
  for (const TestDef& t : deck.tests) n += probes_of(t);
  return n;
}

std::vector<std::string> probe_point_names(const ProbeDef& def) {
  std::vector<std::string> names;
  for (const double e1 : def.at_e1) names.push_back("e1_" + fmt(e1));
  names.insert(names.end(), def.at.begin(), def.at.end());
  return names;
}

ProbePoints::ProbePoints(const ProbeDef& def) : def_(def) {
  const std::vector<std::string> names = probe_point_names(def);
  for (std::size_t k = 0; k < def.at_e1.size(); ++k) {
    Point p;
    p.name = names[k];
    p.missing = "the test ended before e1 reached " + fmt(def.at_e1[k]);
    e1_.push_back(p);
  }
  peak_.name = "peak";
  end_.name = "end";
}

void ProbePoints::on_row(const State& state, const SeriesRow& row) {
  std::shared_ptr<const State> copy;  // one copy for every point this row is
  const auto keep = [&](Point& p) {
    if (!copy) copy = std::make_shared<const State>(state);
    p.state = copy;
    p.row = row;
    p.missing.clear();
  };
  for (std::size_t k = 0; k < e1_.size(); ++k) {
    const double target = def_.at_e1[k];
    if (reaches(row, target) && !e1_[k].state && !e1_[k].lost) {
      keep(e1_[k]);
      write_point(e1_[k]);
    }
  }
  const bool wants_peak = std::find(def_.at.begin(), def_.at.end(), "peak") != def_.at.end();
  if (row.ratio13 > best_ratio_) {  // the summary's peak: the first row of the largest s11/s33 (after a resume,
    best_ratio_ = row.ratio13;      // above every row read back too: the state is this run's own)
    if (wants_peak) keep(peak_), peak_unsaved_ = true;
  }
}

void ProbePoints::keep_in(const fs::path& dir, const std::string& label, const std::string& physics) {
  dir_ = dir;
  label_ = label;
  physics_ = physics;
}

void ProbePoints::write_point(const Point& p) const {
  if (dir_.empty() || !p.state) return;
  fs::create_directories(dir_ / p.name);
  write_state((dir_ / p.name / "point.state").string(), *p.state, "probe point " + label_ + "/" + p.name, physics_);
}

void ProbePoints::save(const State&) {
  if (!peak_unsaved_) return;
  write_point(peak_);  // (a new peak at every row of the rising part: written once per checkpoint, not per row)
  peak_unsaved_ = false;
}

void ProbePoints::resume(const std::vector<SeriesRow>& rows) {
  const std::string lost = "the test was resumed after this point (the states kept before are lost with the run "
                           "that was stopped; --force runs it again whole)";
  // The state a stopped run kept of a point, if it is that of one of these rows (a later one is taken again).
  const auto kept = [&](Point& p) {
    const fs::path file = dir_ / p.name / "point.state";
    if (dir_.empty() || !fs::exists(file)) return false;
    State state = read_state(file.string());
    const auto row = std::find_if(rows.begin(), rows.end(), [&](const SeriesRow& r) {
      return r.step == static_cast<double>(state.control.stage_steps);
    });
    if (row == rows.end()) return false;
    p.state = std::make_shared<const State>(std::move(state));
    p.row = *row;
    p.missing.clear();
    return true;
  };
  for (const SeriesRow& row : rows) best_ratio_ = std::max(best_ratio_, row.ratio13);
  for (std::size_t k = 0; k < e1_.size(); ++k) {
    const double target = def_.at_e1[k];
    const auto first = std::find_if(rows.begin(), rows.end(), [&](const SeriesRow& r) { return reaches(r, target); });
    if (first == rows.end()) continue;
    if (!kept(e1_[k]) || e1_[k].row.step != first->step) e1_[k] = Point{e1_[k].name, nullptr, {}, lost, true};
  }
  // The peak: the first row of the largest s11/s33 among those read back.
  const auto peak = std::find_if(rows.begin(), rows.end(), [&](const SeriesRow& r) { return r.ratio13 == best_ratio_; });
  const bool wants_peak = std::find(def_.at.begin(), def_.at.end(), "peak") != def_.at.end();
  if (!wants_peak || peak == rows.end() || !kept(peak_) || peak_.row.step != peak->step)
    peak_ = Point{"peak", nullptr, {}, lost, false};
}

void ProbePoints::finish(const State& state, const SeriesRow& row) {
  end_.state = std::make_shared<const State>(state);
  end_.row = row;
}

std::vector<ProbePoints::Point> ProbePoints::points(bool peak_reached) const {
  std::vector<Point> out = e1_;
  for (const std::string& name : def_.at) {
    Point p = name == "peak" ? peak_ : end_;
    if (name == "peak" && !peak_reached) {
      p.state.reset();
      p.missing = "no peak reached: s11/s33 is largest at the end of the test (summary.json peak_reached)";
    }
    out.push_back(p);
  }
  return out;
}

std::vector<ProbeDirection> probe_directions(const ProbeDef& def) {
  std::vector<ProbeDirection> out;
  out.push_back({"reference", 0.0, 0.0, {}});
  for (std::size_t m = 0; m < def.magnitudes.size(); ++m) {
    std::string prefix;
    if (def.magnitudes.size() > 1) prefix.append("m").append(std::to_string(m + 1)).append("-");
    if (def.kind == ProbeKind::Strain) {
      for (int k = 0; k < 6; ++k) {
        ProbeDirection p{prefix + kStrainProbeNames[k], def.magnitudes[m], 0.0, {}};
        p.direction[k] = 1.0;
        out.push_back(p);
      }
      continue;
    }
    const int n = def.plane == ProbePlane::List ? static_cast<int>(def.list.size()) : def.directions;
    for (int i = 0; i < n; ++i) {
      char name[16];
      std::snprintf(name, sizeof name, "d%02d", i);
      ProbeDirection p{prefix + name, def.magnitudes[m], 0.0, {}};
      if (def.plane == ProbePlane::List) {
        for (int k = 0; k < 3; ++k) p.direction[k] = def.list[static_cast<std::size_t>(i)][k];
      } else {
        const double a = 2.0 * kPi * i / n;
        p.angle_deg = 360.0 * i / n;
        const std::array<double, 3> d = plane_direction(def.plane, std::cos(a), std::sin(a));
        p.direction = {d[0], d[1], d[2], 0, 0, 0};
      }
      out.push_back(p);
    }
  }
  return out;
}

std::vector<Leg> probe_legs(const ProbeDef& def, const ProbeDirection& probe, const Vec3& s, double time_step) {
  const auto ends_after = [](std::int64_t steps) {
    LegEnd e;
    e.kind = LegEndKind::Steps;
    e.steps = steps;
    return e;
  };
  std::vector<Leg> legs(4);
  const double ramp_time = static_cast<double>(def.steps) * time_step;
  for (int phase = 0; phase < 4; ++phase) {  // load, hold, unload, hold
    Leg& leg = legs[static_cast<std::size_t>(phase)];
    leg.end = ends_after(phase % 2 == 0 ? def.steps : def.hold_steps);
    const double sign = phase == 0 ? 1.0 : phase == 2 ? -1.0 : 0.0;  // the ramps' direction
    const bool loaded = phase == 1 || phase == 2;                    // the phase starts at the loaded point
    if (def.kind == ProbeKind::Stress) {
      for (int k = 0; k < 3; ++k) {
        const double increment = probe.magnitude * probe.direction[static_cast<std::size_t>(k)];
        const double from = s[k] + (loaded ? increment : 0.0);
        leg.axes[static_cast<std::size_t>(k)] =
            sign != 0.0 ? AxisControl{AxisMode::StressRamp, from, sign * increment / ramp_time}
                        : AxisControl{AxisMode::Stress, from};
      }
      continue;  // the shear axes are held (no shear axis named: the tilts stay as they stand)
    }
    const double per_step = sign * probe.magnitude / static_cast<double>(def.steps);
    for (int k = 0; k < 3; ++k)
      leg.axes[static_cast<std::size_t>(k)] = {AxisMode::StrainIncrement, per_step * probe.direction[static_cast<std::size_t>(k)]};
    for (int a = 0; a < 3; ++a)
      if (probe.direction[static_cast<std::size_t>(3 + a)] != 0.0)
        leg.axes[static_cast<std::size_t>(3 + a)] = AxisControl{AxisMode::StrainIncrement, per_step};
  }
  return legs;
}

namespace {

// What one probe did: its rows at the end of the loaded hold and of the unloaded hold.
struct ProbeResult {
  bool ran = false;
  bool controlled = true;
  std::string error;   // the probe failed (a RunError), else empty
  SeriesRow loaded, unloaded;
};

struct Job {
  std::size_t point;
  ProbeDirection probe;
};

constexpr const char* kProbeResultName = "result.json";
constexpr const char* kPointRecordName = "point.json";

void run_probe(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
               const ProbePoints::Point& point, const ProbeDirection& probe) {
  bool ran = false, controlled = true;
  std::string error;
  std::int64_t steps = 0;
  Json control_errors = Json::array();
  const ProbeDef& def = *test.probes;
  // From the point's state as its file holds it, forces computed: the same start whether the point was taken in this
  // process or read back by a resumed run (a state file holds no forces or neighbour list).
  State state = read_state((run.stage_dir(test.name) / "probes" / point.name / "point.state").string());
  Model model = make_model(deck, state.particles.radius, deck.stage_time_step(test));
  // The servo keeps the cap of the test's leg at the point: a probe's stress axes follow a sample that moves at
  // the test's rate when the probe starts (the probe's own legs, driven by nothing, would get the smallest cap).
  model.servo.max_strain_increment =
      servo_cap(deck.stage_servo(test), test.legs[static_cast<std::size_t>(state.control.leg)], model.dt);
  model.servo.max_strain_increment_given = true;
  evaluate_forces(model, test.stage_friction(), state);
  const std::vector<Leg> legs = probe_legs(def, probe, state.normal_stress(), model.dt);
  begin_leg(state, 0);
  const std::int64_t from_step = state.control.stage_steps;
  const std::int64_t total = 2 * (def.steps + def.hold_steps);
  const std::int64_t interval = std::max<std::int64_t>(1, def.steps / 10);
  const std::string stage = test.name + "/probes/" + point.name + "/" + probe.name;
  RunOptions quiet = options;
  quiet.progress = ProgressMode::Off;  // one line for the whole set (run_test_probes)
  // A folder a stopped run left (half-written, or whole) is run again: its old result goes first, so that a stop
  // now never leaves it beside a new, partial series.
  fs::remove(run.stage_dir(stage) / kProbeResultName);
  try {
    StageOutput out(run, deck, quiet, model, stage, interval, /*loading_test=*/true);
    out.set_branch();
    out.open(state, /*resumed=*/false);
    Program program{legs, test.stage_friction(), &test.equilibrium, from_step + total};
    program.adaptive_threads = false;
    program.kind = StageKind::Test;
    program.stage = stage;
    program.control_failure = ControlFailure::Warn;  // recorded with the probe, not a stop of the run
    program.print_control_warnings = false;
    std::vector<ControlErrors> errors;
    run_program(model, program, state, out, errors);
    out.finish(state);
    ran = true;
    for (const ControlErrors& e : errors) {
      controlled &= std::none_of(e.failed.begin(), e.failed.end(), [](bool f) { return f; });
      control_errors.push_back(to_json(e));
    }
    steps = state.control.stage_steps - from_step;
  } catch (const RunError& e) {
    error = e.what();
  }
  // What the table needs besides the series: whether the probe ran, held its controls (each leg's errors, as a
  // test's summary holds them), or failed and why.
  const fs::path dir = run.stage_dir(stage);
  fs::create_directories(dir);
  write_file_atomic(dir / kProbeResultName, Json{{"ran", ran}, {"controlled", controlled}, {"error", error},
                                                 {"steps", steps}, {"control_errors", control_errors}}.dump(1));
}

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
    r.loaded = *loaded;
    r.unloaded = rows.back();
  }
  return r;
}

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

}  // namespace

Json run_test_probes(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                     const ProbePoints& probe_points, bool peak_reached) {
  const ProbeDef& def = *test.probes;
  const std::vector<ProbePoints::Point> points = probe_points.points(peak_reached);
  const std::vector<ProbeDirection> directions = probe_directions(def);
  // Each point's record and state, for the table (here or after a merge) and for probes run again elsewhere.
  for (const ProbePoints::Point& point : points) {
    const fs::path dir = run.stage_dir(test.name) / "probes" / point.name;
    fs::create_directories(dir);
    if (point.state)
      write_state((dir / "point.state").string(), *point.state, "probe point " + test.name + "/" + point.name,
                  state_physics(deck));
    write_file_atomic(dir / kPointRecordName,
                      Json{{"step", point.row.step}, {"e1", point.row.e1}, {"reached", point.state != nullptr},
                           {"reason", point.missing}}.dump(1));
  }
  // The probes this run runs: those of options.probes by their number (1-based over the deck's tests, then every
  // point of the set, reference excluded, in probes.csv's order: probe_number_offset), with their points' references.
  std::vector<Job> jobs;
  const std::int64_t per_point = static_cast<std::int64_t>(directions.size()) - 1;
  const std::int64_t offset = probe_number_offset(deck, test);  // one numbering over the deck's tests
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (!points[p].state) continue;
    std::vector<Job> chosen;
    for (std::size_t k = 1; k < directions.size(); ++k) {
      const std::int64_t number = offset + static_cast<std::int64_t>(p) * per_point + static_cast<std::int64_t>(k);
      if (number >= options.probes.first && number <= options.probes.last) chosen.push_back({p, directions[k]});
    }
    if (chosen.empty()) continue;
    jobs.push_back({p, directions[0]});
    jobs.insert(jobs.end(), chosen.begin(), chosen.end());
  }

  // Side by side over the test's threads, each probe on one (its result does not depend on the count).
  const int workers = std::max(1, std::min<int>(omp_get_max_threads(), static_cast<int>(jobs.size())));
  std::atomic<std::size_t> next{0};
  std::atomic<std::int64_t> steps_done{0};
  std::mutex progress_mutex;
  Progress progress(test.name + " probes", options.progress, options.progress_interval);
  const std::int64_t steps_each = 2 * (def.steps + def.hold_steps);
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(workers));
  const auto work = [&](int w) {
    omp_set_num_threads(1);
    try {
      for (std::size_t j; (j = next.fetch_add(1)) < jobs.size();) {
        run_probe(run, deck, options, test, points[jobs[j].point], jobs[j].probe);
        const std::int64_t done = steps_done += steps_each;
        const std::lock_guard<std::mutex> lock(progress_mutex);
        progress.update(done, static_cast<double>(done) / static_cast<double>(steps_each * static_cast<std::int64_t>(jobs.size())));
      }
    } catch (...) {
      errors[static_cast<std::size_t>(w)] = std::current_exception();
      next = jobs.size();  // the others stop after their present probe
    }
  };
  std::vector<std::thread> threads;
  for (int w = 1; w < workers; ++w) threads.emplace_back(work, w);
  work(0);
  for (std::thread& t : threads) t.join();
  progress.finish();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  return tabulate_probes(run.stage_dir(test.name).parent_path(), deck, test);
}

Json tabulate_probes(const fs::path& run_dir, const Deck& deck, const TestDef& test) {
  const ProbeDef& def = *test.probes;
  const std::vector<ProbeDirection> directions = probe_directions(def);
  const fs::path probes_dir = run_dir / test.name / "probes";
  // probes.csv: each probe's response net of its point's reference, at the loaded and the unloaded ends.
  std::string csv = "point,point_step,point_e1,kind,probe,magnitude,angle_deg,d11,d22,d33,d12,d13,d23";
  const auto add_columns = [&](const std::array<const char*, 6>& names, const char* suffix) {
    for (const char* name : names) csv.append(",d").append(name).append(suffix);
  };
  add_columns(kStressNames, "");
  add_columns(kStrainNames, "");
  add_columns(kStrainNames, "_plastic");
  add_columns(kStrainNames, "_elastic");
  add_columns(kStressNames, "_residual");
  csv += ",controlled,status\n";
  Json summary = {{"kind", std::string(name_of(def.kind, kProbeKindNames))}, {"steps", def.steps},
                  {"hold_steps", def.hold_steps}, {"magnitudes", def.magnitudes}, {"points", Json::object()},
                  {"table", (fs::path(test.name) / "probes" / "probes.csv").string()}};
  if (def.kind == ProbeKind::Stress) summary["plane"] = std::string(name_of(def.plane, kProbePlaneNames));
  Json stiffness = {{"voigt_order", {"11", "22", "33", "12", "13", "23"}},
                    {"units", "Pa per unit strain; engineering shear strains g_ij; compression +"},
                    {"points", Json::object()}};
  for (const std::string& name : probe_point_names(def)) {
    const fs::path point_dir = probes_dir / name;
    if (!fs::exists(point_dir / kPointRecordName))
      throw RunError(point_dir.string() + ": no " + kPointRecordName + " (not a probed run folder)");
    const Json record = Json::parse(read_file((point_dir / kPointRecordName).string()));
    const double point_step = record.at("step").get<double>(), point_e1 = record.at("e1").get<double>();
    Json entry = {{"step", point_step}, {"e1", point_e1}};
    if (!record.at("reached").get<bool>()) {
      entry["status"] = "not run";
      entry["reason"] = record.at("reason");
      summary["points"][name] = entry;
      continue;
    }
    entry["state"] = (fs::path(test.name) / "probes" / name / "point.state").string();
    const std::optional<ProbeResult> reference_record = read_probe_result(point_dir / "reference");
    if (!reference_record) {
      entry["status"] = "not run here";
      entry["reason"] = "its probes were left to other jobs (--probes); `celldem merge` gathers them";
      entry["missing"] = static_cast<std::int64_t>(directions.size()) - 1;
      summary["points"][name] = entry;
      continue;
    }
    const ProbeResult& reference = *reference_record;
    if (!reference.ran) {
      entry["status"] = "failed";
      entry["reason"] = "the reference probe failed: " + reference.error;
      summary["points"][name] = entry;
      continue;
    }
    int ran = 0, controlled = 0, failed = 0;
    // Strain probes: per magnitude, the columns of the tangent and elastic stiffness.
    std::vector<Eigen::Matrix<double, 6, 6>> tangent(def.magnitudes.size(), Eigen::Matrix<double, 6, 6>::Zero()),
        elastic = tangent;
    // Stress probes: the strain response's length per direction and magnitude (linearity across magnitudes).
    std::vector<std::vector<double>> response(def.magnitudes.size());
    std::vector<std::vector<PlanePoint>> plastic(def.magnitudes.size());  // stress probes in a plane
    int missing = 0;
    for (std::size_t k = 1; k < directions.size(); ++k) {
      const ProbeDirection& d = directions[k];
      const std::optional<ProbeResult> record = read_probe_result(point_dir / d.name);
      if (!record) {  // another job's (--probes), not merged
        ++missing;
        continue;
      }
      const ProbeResult& r = *record;
      const std::size_t m = static_cast<std::size_t>(std::find(def.magnitudes.begin(), def.magnitudes.end(), d.magnitude) - def.magnitudes.begin());
      csv.append(name).append(",").append(fmt(point_step)).append(",").append(fmt(point_e1));
      csv.append(",").append(name_of(def.kind, kProbeKindNames)).append(",").append(d.name);
      csv.append(",").append(fmt(d.magnitude)).append(",").append(fmt(d.angle_deg));
      for (double x : d.direction) csv.append(",").append(fmt(x));
      if (!r.ran) {
        ++failed;
        for (int k = 0; k < 30; ++k) csv += ",";
        std::string why = r.error;
        std::replace(why.begin(), why.end(), ',', ';');
        std::replace(why.begin(), why.end(), '\n', ' ');
        csv.append(",false,failed: ").append(why).append("\n");
        continue;
      }
      ++ran;
      controlled += r.controlled;
      const Row6 ds = minus(stresses(r.loaded), stresses(reference.loaded));
      const Row6 de = minus(strains(r.loaded), strains(reference.loaded));
      const Row6 de_plastic = minus(strains(r.unloaded), strains(reference.unloaded));
      const Row6 ds_residual = minus(stresses(r.unloaded), stresses(reference.unloaded));
      const Row6 de_elastic = minus(de, de_plastic);
      for (const Row6* v : {&ds, &de, &de_plastic, &de_elastic, &ds_residual})
        for (double x : *v) csv.append(",").append(fmt(x));
      csv.append(r.controlled ? ",true,ok\n" : ",false,ok\n");
      if (def.kind == ProbeKind::Strain) {
        const int column = static_cast<int>(std::max_element(d.direction.begin(), d.direction.end()) - d.direction.begin());
        for (int i = 0; i < 6; ++i) {
          tangent[m](i, column) = ds[static_cast<std::size_t>(i)] / d.magnitude;
          elastic[m](i, column) = (ds[static_cast<std::size_t>(i)] - ds_residual[static_cast<std::size_t>(i)]) / d.magnitude;
        }
      } else {
        response[m].push_back(norm(de));
        if (def.plane != ProbePlane::List) {
          const auto [u1, u2] = plane_basis(def.plane);
          double p1 = 0.0, p2 = 0.0;
          for (int k = 0; k < 3; ++k) p1 += u1[k] * de_plastic[k], p2 += u2[k] * de_plastic[k];
          plastic[m].push_back({d.angle_deg * kPi / 180.0, p1, p2});
        }
      }
    }
    // What the set says (stiffness, linearity, the plastic reading) only from a whole set that held its controls:
    // a probe whose stress or strain left its target did not probe the direction it names.
    const bool whole = failed == 0 && missing == 0 && controlled == ran;
    entry["status"] = missing > 0 ? "partly run" : failed > 0 ? "ran with failures" : whole ? "ran" : "ran with uncontrolled probes";
    if (entry["status"] == "ran with uncontrolled probes")
      entry["reason"] = std::to_string(ran - controlled) + " probes lost their control (result.json control_errors): "
                        "the set's stiffness, linearity and plastic reading are not given";
    entry["probes"] = ran + failed;
    entry["failed"] = failed;
    if (missing > 0) {
      entry["missing"] = missing;
      entry["reason"] = std::to_string(missing) + " probes were left to other jobs (--probes); `celldem merge` gathers them";
    }
    entry["controlled"] = controlled;
    entry["folder"] = (fs::path(test.name) / "probes" / name).string();
    if (def.kind == ProbeKind::Strain && whole) {
      Json per_magnitude = Json::array();
      for (std::size_t m = 0; m < def.magnitudes.size(); ++m)
        per_magnitude.push_back({{"magnitude", def.magnitudes[m]}, {"tangent", matrix_json(tangent[m])},
                                 {"elastic", matrix_json(elastic[m])}, {"elastic_asymmetry", asymmetry(elastic[m])},
                                 {"tangent_asymmetry", asymmetry(tangent[m])}});
      stiffness["points"][name] = {{"step", point_step}, {"e1", point_e1}, {"magnitudes", per_magnitude}};
      entry["elastic_asymmetry"] = per_magnitude[0]["elastic_asymmetry"];
      const Json network = network_estimate(deck, test, read_state((point_dir / "point.state").string()), elastic.front());
      stiffness["points"][name]["network"] = network;
      if (network.contains("elastic_vs_network")) entry["elastic_vs_network"] = network["elastic_vs_network"];
    }
    if (def.kind == ProbeKind::Stress && def.magnitudes.size() > 1 && whole) {
      // Linear response scales with the magnitude: the median over directions of
      // |de(M_last)| / |de(M_first)| / (M_last / M_first) is 1 in the linear range.
      std::vector<double> ratios;
      const std::size_t last = def.magnitudes.size() - 1;
      for (std::size_t i = 0; i < response[0].size() && i < response[last].size(); ++i)
        ratios.push_back(response[last][i] / response[0][i] / (def.magnitudes[last] / def.magnitudes[0]));
      std::sort(ratios.begin(), ratios.end());
      if (!ratios.empty())
        entry["linearity"] = {{"median_ratio", ratios[ratios.size() / 2]},
                              {"meaning", "median over directions of |de| at the largest magnitude over |de| at the "
                                          "smallest, divided by the magnitudes' ratio: 1 where the response is linear"}};
    }
    if (def.kind == ProbeKind::Stress && def.plane != ProbePlane::List && whole)
      entry["plastic"] = plastic_response(plastic.back(), def.magnitudes.back());
    summary["points"][name] = entry;
  }
  write_file_atomic(probes_dir / "probes.csv", csv);
  if (def.kind == ProbeKind::Strain) {
    write_file_atomic(probes_dir / "stiffness.json", stiffness.dump(1));
    summary["stiffness"] = (fs::path(test.name) / "probes" / "stiffness.json").string();
  }
  return summary;
}

}  // namespace celldem
