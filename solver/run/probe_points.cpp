#include "run/probe_points.hpp"
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
namespace fs = std::filesystem;
using Json = nlohmann::json;
using namespace probe_files;

namespace {

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
  for (const double e1 : def.at_e1) names.push_back("e1_" + fmt10(e1));
  names.insert(names.end(), def.at.begin(), def.at.end());
  return names;
}

ProbePoints::ProbePoints(const ProbeDef& def, TestMeasure measure) : def_(def), peak_tracker_(measure) {
  const std::vector<std::string> names = probe_point_names(def);
  for (std::size_t k = 0; k < def.at_e1.size(); ++k) {
    Point p;
    p.name = names[k];
    p.missing = "the test ended before e1 reached " + fmt10(def.at_e1[k]);
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
  // The summary's peak: the first row of the largest value of the test's measure (after a resume, above every row
  // read back too: the state is this run's own).
  if (peak_tracker_.offer(row) && wants_peak) keep(peak_), peak_unsaved_ = true;
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
  peak_tracker_.seen(rows);
  for (std::size_t k = 0; k < e1_.size(); ++k) {
    const double target = def_.at_e1[k];
    const auto first = std::find_if(rows.begin(), rows.end(), [&](const SeriesRow& r) { return reaches(r, target); });
    if (first == rows.end()) continue;
    if (!kept(e1_[k]) || e1_[k].row.step != first->step) e1_[k] = Point{e1_[k].name, nullptr, {}, lost, true};
  }
  // The peak: the first row of the largest value of the measure among those read back.
  const auto peak = rows.empty() ? rows.end() : rows.begin() + static_cast<std::ptrdiff_t>(peak_row(peak_tracker_.measure(), rows));
  const bool wants_peak = std::find(def_.at.begin(), def_.at.end(), "peak") != def_.at.end();
  if (!wants_peak || peak == rows.end() || !kept(peak_) || peak_.row.step != peak->step)
    peak_ = Point{"peak", nullptr, {}, lost, false};
}

void ProbePoints::finish(const State& state, const SeriesRow& row) {
  end_.state = std::make_shared<const State>(state);
  end_.row = row;
}

std::vector<ProbePoints::Point> ProbePoints::points(bool peak_reached, const std::string& peak_evidence) const {
  std::vector<Point> out = e1_;
  for (const std::string& name : def_.at) {
    Point p = name == "peak" ? peak_ : end_;
    if (name == "peak" && !peak_reached) {
      p.state.reset();
      p.missing = "no peak reached: " + peak_evidence + " (summary.json peak_reached)";
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

}  // namespace celldem
