#include "run/preflight.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/model.hpp"
#include "core/number_text.hpp"
#include "core/plan.hpp"
#include "io/files.hpp"
#include "io/lammps_data.hpp"
#include "io/state_file.hpp"
#include "measure/micro.hpp"
#include "measure/quasi_static.hpp"
#include "neighbor/neighbor_list.hpp"
#include "run/health.hpp"
#include "run/sample.hpp"
#include "run/time_step_check.hpp"
#include "run/verify_rate.hpp"

namespace celldem {
namespace {


// The neighbour list needs every face width of the cell above 2 (largest diameter + skin).
double smallest_cell_width(const Deck& deck) {
  return 2.0 * (deck.sample.largest_diameter() + skin_length(deck));
}

void check_prepared_cell(const Deck& deck) {
  const SampleDef& s = deck.sample;
  int side = 1;
  while (static_cast<long long>(side) * side * side < s.count) ++side;
  const double solid = mean_sphere_volume(s);
  // A prepared random packing of spheres fills about 64 % of the cell.
  const double prepared = std::cbrt(s.count * solid / 0.64);
  const double needed = smallest_cell_width(deck);
  if (std::min(side * s.grid_spacing, prepared) <= needed)
    throw DeckError("sample.count: " + std::to_string(s.count) + " spheres make a cell about " + fmt(prepared) +
                    " m wide once compressed, too small for the largest diameter and the skin (the cell must "
                    "exceed " + fmt(needed) + " m): use more spheres");
}

// An imported packing whose spheres overlap deeply starts with forces far above its stress's: the first steps
// push them apart violently, and a run would stop with runaway motion or kinetic energy as if the time step
// were too large. Overlaps beyond kDeepOverlap of the smaller radius (a packing at its stress overlaps by
// about 1e-3 of a radius) are refused unless the preparation relaxes them first (prepare.relax_overlaps, at
// most kDeepOverlap); coincident centres are refused always (no dilation parts them).
inline constexpr double kDeepOverlap = keys::prepare_relax_overlaps.max;
inline constexpr double kCoincident = 1e-6;  // centre distance / (r_i + r_j)

// Returns the overlaps as loaded.
Overlaps check_overlaps(const Deck& deck, State state, const std::vector<std::int64_t>& atom_ids,
                        const std::string& path) {
  const auto name = [&](Index i) {
    return atom_ids.empty() ? "particle " + std::to_string(i) : "atom " + std::to_string(atom_ids[i]);
  };
  const OverlapRelaxation r = relax_overlaps(deck, state);
  const Overlaps& o = r.before;
  if (o.closest < kCoincident)
    throw DeckError("initial_state: " + name(o.closest_i) + " and " + name(o.closest_j) + " of " + path +
                    " lie at the same place (centre distance " + fmt(o.closest) + " of the sum of their radii): "
                    "remove one of them");
  if (r.max_overlap > 0.0 || o.worst <= kDeepOverlap) return o;
  const std::string where = deck.prepare ? "set \"prepare.relax_overlaps\" (e.g. 0.01)"
                                         : "prepare a sample from it (\"prepare\" beside \"initial_state\") with "
                                           "\"prepare.relax_overlaps\" (e.g. 0.01)";
  throw DeckError("initial_state: in " + path + " " + std::to_string(o.deep) + " of " + std::to_string(o.count) +
                  " touching pairs overlap by more than " + fmt(kDeepOverlap) + " of the smaller radius, the deepest " +
                  fmt(o.worst) + " (" + name(o.worst_i) + " and " + name(o.worst_j) + "): the first steps would push "
                  "them apart violently, which no time step cures; " + where + " to dilate the cell until no overlap "
                  "exceeds that fraction and let the preparation compress it back, or relax the packing first (e.g. "
                  "a LAMMPS run with fix nve/limit)");
}

// Each key of the two physics records whose values differ: "key: the deck says A, the state says B".
std::vector<std::string> physics_differences(const std::string& deck_record, const std::string& state_record) {
  const nlohmann::json d = nlohmann::json::parse(deck_record), s = nlohmann::json::parse(state_record);
  std::vector<std::string> out;
  nlohmann::json keys = d;
  keys.update(s);
  const auto text = [](const nlohmann::json& j, const std::string& k) {
    return !j.contains(k) ? std::string("none") : j[k].is_string() ? j[k].get<std::string>() : fmt(j[k].get<double>());
  };
  for (const auto& [key, unused] : keys.items()) {
    const bool same = d.contains(key) && s.contains(key) &&
                      (d[key].is_number() && s[key].is_number()
                           ? std::abs(d[key].get<double>() - s[key].get<double>()) <= 1e-12 * std::abs(s[key].get<double>())
                           : d[key] == s[key]);
    if (!same) out.push_back(key + ": the deck says " + text(d, key) + ", the state was made with " + text(s, key));
  }
  return out;
}

void check_physics(const Deck& deck, const InitialSample& sample, const std::string& path,
                   std::vector<std::string>& warnings) {
  const std::string& record = sample.physics;
  if (record.empty()) {  // a LAMMPS data file's density was checked as it was read; it has no contact law
    if (sample.state_file)
      warnings.push_back("initial_state: " + path + " records no physics (a state file of format 2 or 3, written "
                         "before states recorded the density and contact law they were made with): nothing was "
                         "checked, so make sure sample.density and the contact keys are the ones it was made with");
    return;
  }
  const std::vector<std::string> differences = physics_differences(state_physics(deck), record);
  if (differences.empty()) return;
  std::string list;
  for (const std::string& d : differences) list += (list.empty() ? "" : "; ") + d;
  if (!deck.override_state_physics)
    throw DeckError(list + " (initial_state " + path + "): make the deck agree with the state, or set "
                    "\"override_state_physics\": true to run it with the deck's physics on purpose");
  warnings.push_back("override_state_physics: initial_state " + path + " runs with the deck's physics: " + list);
}

// A packing of spheres at rest under a confining stress fills at least about 0.55 of its volume (random loose
// packing); a state below kLooseSolidFraction, or one whose spheres do not touch, is a gas, not a sample: a test
// from it measures nothing (a strain-driven test stops at the first contacts, whose energy jumps).
inline constexpr double kLooseSolidFraction = 0.5;

// Tests that start from initial_state without a preparation: warn of a start that is no packing, and point to
// `prepare`, which compresses the loaded state to its target first.
void warn_loose_start(const Deck& deck, const State& state, const Overlaps& o, const std::string& path,
                      std::vector<std::string>& warnings) {
  const double solid_fraction = make_model(deck, state.particles.radius).solid_volume / state.cell.volume();
  if (o.count > 0 && solid_fraction >= kLooseSolidFraction) return;
  warnings.push_back("initial_state: " + path + " fills " + fmt(solid_fraction) + " of its cell (solid fraction) with " +
                     std::to_string(o.count) + " touching pairs: the tests would start from a loose gas of spheres, not "
                     "a packing (spheres at rest under a stress touch and fill at least about 0.55); add \"prepare\" "
                     "beside \"initial_state\" to compress it to prepare.target_pressure first");
}

void check_state(const Deck& deck, const std::string& path, std::vector<std::string>& warnings) {
  const InitialSample sample = load_initial_sample(deck);
  const State& state = sample.state;
  const std::vector<std::int64_t>& atom_ids = sample.atom_ids;
  check_physics(deck, sample, path, warnings);
  const std::size_t n = state.particles.size();
  if (n != static_cast<std::size_t>(deck.sample.count))
    throw DeckError("sample.count: the deck says " + std::to_string(deck.sample.count) + " spheres, initial_state " +
                    path + " holds " + std::to_string(n));
  for (std::size_t i = 0; i < n; ++i) {
    const double d = 2.0 * state.particles.radius[i];
    if (const std::optional<GradingDef>& g = deck.sample.grading) {
      const double lo = g->sizes.front(), hi = g->sizes.back();
      if (d < lo * (1.0 - 1e-12) || d > hi * (1.0 + 1e-12))
        throw DeckError("sample.diameters.grading: initial_state " + path + " holds a sphere of diameter " + fmt(d) +
                        " m (particle " + std::to_string(i) + "), outside the grading's sizes [" + fmt(lo) + ", " +
                        fmt(hi) + "] m");
      continue;
    }
    const bool listed = std::any_of(deck.sample.diameters.begin(), deck.sample.diameters.end(),
                                    [d](double x) { return std::abs(x - d) <= 1e-12 * x; });
    if (!listed)
      throw DeckError("sample.diameters: initial_state " + path + " holds a sphere of diameter " + fmt(d) +
                      " m (particle " + std::to_string(i) + "), which is not one of the deck's diameters");
  }
  const double needed = smallest_cell_width(deck);
  const double width = state.cell.face_widths().minCoeff();
  if (width <= needed)
    throw DeckError("initial_state: the cell of " + path + " is " + fmt(width) + " m wide, too small for its "
                    "largest diameter and the skin (it must exceed " + fmt(needed) + " m)");
  const Overlaps o = check_overlaps(deck, state, atom_ids, path);
  if (!deck.prepare) warn_loose_start(deck, state, o, path, warnings);
}

// The largest axis-1 strain a test reaches at the ends of its legs; NaN unless every leg drives axis 1 by
// strain and ends on its strain or on a step count (otherwise only running the test tells).
double largest_e1(const Deck& deck, const TestDef& test) {
  const double dt = deck.stage_time_step(test);
  double e1 = 0.0, largest = 0.0;
  for (const Leg& leg : test.legs) {
    if (!leg.axes[0].strain_driven()) return std::nan("");
    if (leg.end.kind == LegEndKind::Strain && leg.end.axis == 0) e1 = leg.end.value;
    else if (leg.end.kind == LegEndKind::Steps) e1 += static_cast<double>(leg_steps(leg, dt)) *
                                                      leg.strain_per_step(0, dt);
    else return std::nan("");
    largest = std::max(largest, e1);
  }
  return largest;
}

// A strain leg whose end.max_steps stops it before its end strain does so silently at run time (the step count
// is its end): say so before the run, with the strain where it will stop. The strains of the axes are
// followed from leg to leg as the plan follows them; a leg whose length only running tells ends the scan.
void warn_capped_strain_legs(const Deck& deck, std::vector<std::string>& warnings) {
  for (std::size_t t = 0; t < deck.tests.size(); ++t) {
    const TestDef& test = deck.tests[t];
    const double dt = deck.stage_time_step(test);
    std::vector<double> from;  // where each leg starts on its end's axis (core/plan's rule)
    const std::vector<std::int64_t> steps = program_leg_steps(test.legs, dt, &from);
    for (std::size_t k = 0; k < test.legs.size(); ++k) {
      const Leg& leg = test.legs[k];
      const LegEnd& e = leg.end;
      const std::int64_t n = steps[k];
      if (n < 0) break;
      if (e.kind != LegEndKind::Strain || !leg.axes[e.axis].strain_driven() || e.max_steps <= 0 || n != e.max_steps)
        continue;
      const double reached = from[k] + static_cast<double>(n) * leg.strain_per_step(e.axis, dt);
      if (std::abs(reached - e.value) > 0.5 * std::abs(leg.strain_per_step(e.axis, dt)))
        warnings.push_back("tests[" + std::to_string(t) + "] (test '" + test.name + "', leg " + std::to_string(k) +
                           "): end.max_steps " + std::to_string(e.max_steps) + " stops the leg at x" +
                           std::to_string(e.axis + 1) + " strain " + fmt(reached) + ", short of its end strain " +
                           fmt(e.value));
    }
  }
}

// Snapshots at strains a test never reaches would be dropped silently: say so before the run.
void warn_unreached_snapshots(const Deck& deck, std::vector<std::string>& warnings) {
  for (std::size_t t = 0; t < deck.tests.size(); ++t) {
    const TestDef& test = deck.tests[t];
    const double reached = largest_e1(deck, test);
    if (!std::isfinite(reached)) continue;
    for (std::size_t k = 0; k < test.snapshots.e1.size(); ++k)
      if (test.snapshots.e1[k] > reached)
        warnings.push_back("tests[" + std::to_string(t) + "].snapshots.e1: " + fmt(test.snapshots.e1[k]) +
                           " lies beyond the largest e1 test '" + test.name + "' reaches (" + fmt(reached) +
                           "): no snapshot will be written there");
  }
}

// A servo axis beside an axis driven at d per step moves about d to 2d per step (its dilation): a cap below
// kMinServoCapRatio x d saturates the servo, and the control fails.
void check_servo_caps(const Deck& deck) {
  const auto check = [&](const std::vector<Leg>& legs, const ServoDef& servo, const std::string& cap_key, double dt,
                         const std::string& stage) {
    for (std::size_t j = 0; j < legs.size(); ++j) {
      const Leg& leg = legs[j];
      const double d = leg_driving_increment(leg, dt);
      const double cap = servo_cap(servo, leg, dt);
      if (leg_has_servo(leg) && d > 0.0 && cap < kMinServoCapRatio * d)
        throw DeckError(cap_key + ": " + fmt(cap) + " is below " + fmt(kMinServoCapRatio) +
                        " x the driving strain per step " + fmt(d) + " of " + stage + " leg " + std::to_string(j) +
                        " (the servo's axes need about 1 to 2 x it): raise it to at least " +
                        fmt(kMinServoCapRatio * d) + ", leave it out (the default follows each leg's rate) or "
                        "lower the strain rate");
    }
  };
  if (deck.prepare)
    check(deck.prepare->legs, deck.stage_servo(*deck.prepare),
          std::string(deck.prepare->servo_max_strain_increment ? keys::prepare_servo_max_strain_increment.path
                                                               : keys::servo_max_strain_increment.path),
          deck.stage_time_step(*deck.prepare), "the preparation");
  for (const TestDef& t : deck.tests)
    check(t.legs, deck.stage_servo(t), std::string(keys::servo_max_strain_increment.path), deck.stage_time_step(t),
          "test '" + t.name + "'");
}

// A moving target (a stress ramp, a principal-axis rotation) faster than the servo follows. The servo's
// proportional term removes `gain` of an error per step, so a target that moves by v per step lags it by about
// v / gain; the integral term removes a steady lag only over about 1/integral_gain steps (500 at the default),
// longer than a fast target's swing. A lag above kMovingTargetRefusal times the control's tolerance is not one the
// servo can make up: the control would fail (run/control_verdict.hpp), so check refuses the deck first.
constexpr double kMovingTargetRefusal = 10.0;
void check_moving_targets(const Deck& deck) {
  for (std::size_t i = 0; i < deck.tests.size(); ++i) {
    const TestDef& t = deck.tests[i];
    const double dt = deck.stage_time_step(t), gain = deck.stage_servo(t).gain;
    for (std::size_t j = 0; j < t.legs.size(); ++j) {
      const Leg& leg = t.legs[j];
      const std::string at = "tests[" + std::to_string(i) + "]" + (t.legs.size() > 1 ? " (leg " + std::to_string(j) + ")" : "");
      if (leg.rotation) {
        const PrincipalRotation& r = *leg.rotation;
        const double per_step = std::abs(r.per_step ? r.rate : r.rate * dt);  // [rad]
        const double lag = (r.sigma1 - r.sigma3) * per_step / gain;  // s_ii moves by up to 2 (r) d(theta) per step
        const double limit = kMovingTargetRefusal * kServoTolerance * r.sigma3;
        if (lag > limit)
          throw DeckError(at + ".rotate_principal_axes: the targets turn " + fmt(per_step * 180.0 / M_PI) +
                          " degrees per step: the servo (gain " + fmt(gain) + ") lags them by about " + fmt(lag) +
                          " Pa, " + fmt(lag / (kServoTolerance * r.sigma3)) + " x the stress tolerance of sigma3 (" +
                          fmt(kServoTolerance * r.sigma3) + " Pa); turn at most " +
                          fmt(limit / ((r.sigma1 - r.sigma3) / gain) * 180.0 / M_PI / dt) + " degrees/s");
      }
      for (int k = 0; k < 3; ++k) {
        const AxisControl& a = leg.axes[static_cast<std::size_t>(k)];
        if (a.mode != AxisMode::StressRamp) continue;
        const double lag = std::abs(a.rate) * dt / gain, limit = kMovingTargetRefusal * kServoTolerance * a.value;
        if (lag > limit)
          throw DeckError(at + ".axes." + std::string(kAxisNames[static_cast<std::size_t>(k)]) + ".stress_ramp.rate: " +
                          fmt(a.rate) + " Pa/s moves the target faster than the servo (gain " + fmt(gain) +
                          ") follows: it lags by about " + fmt(lag) + " Pa, " + fmt(lag / (kServoTolerance * a.value)) +
                          " x the tolerance at the ramp's start; ramp at most " + fmt(limit * gain / dt) + " Pa/s");
      }
    }
  }
}

}  // namespace

std::string describe_servo_caps(const Deck& deck) {
  double smallest = std::numeric_limits<double>::infinity();
  std::string where;
  std::size_t legs = 0;
  const auto scan = [&](const std::vector<Leg>& program, const ServoDef& servo, double dt, const std::string& stage) {
    for (std::size_t j = 0; j < program.size(); ++j) {
      const double d = leg_driving_increment(program[j], dt);
      if (!leg_has_servo(program[j]) || !(d > 0.0)) continue;
      ++legs;
      const double ratio = servo_cap(servo, program[j], dt) / d;
      if (ratio < smallest) smallest = ratio, where = stage + " leg " + std::to_string(j);
    }
  };
  if (deck.prepare)
    scan(deck.prepare->legs, deck.stage_servo(*deck.prepare), deck.stage_time_step(*deck.prepare), "the preparation's");
  for (const TestDef& t : deck.tests) scan(t.legs, deck.stage_servo(t), deck.stage_time_step(t), "test '" + t.name + "'");
  if (legs == 0) return "";
  return "servo: " + std::to_string(legs) + " leg(s) with a servo beside a driven axis; the tightest cap is " +
         fmt(smallest) + " x its driving strain per step (" + where + "); the servo's axes need about 1 to 2 x, " +
         "so it can follow" + (deck.servo.max_strain_increment_given ? "" : " (each leg's cap follows its rate)") +
         "; `celldem plan` lists every leg";
}

std::string describe_stage_time_steps(const Deck& deck) {
  const bool own = (deck.prepare && deck.prepare->time_step) ||
                   std::any_of(deck.tests.begin(), deck.tests.end(), [](const TestDef& t) { return t.time_step.has_value(); });
  if (!own) return "";
  const double limit = critical_time_step(deck.sample, deck.contact);
  const auto line = [&](const std::string& stage, double dt, bool given) {
    return "\n  " + stage + ": " + fmt(dt) + " s = " + fmt(dt / limit) + " of the limit" + (given ? "" : " (the deck's)");
  };
  std::string out = "time step per stage (stability limit " + fmt(limit) + " s):";
  if (deck.prepare) out += line("prepare", deck.stage_time_step(*deck.prepare), deck.prepare->time_step.has_value());
  for (const TestDef& t : deck.tests) out += line("test '" + t.name + "'", deck.stage_time_step(t), t.time_step.has_value());
  return out;
}

std::string describe_ramps_and_holds(const Deck& deck) {
  std::string out;
  double fastest = 0.0;
  std::string where;
  std::size_t ramps = 0;
  for (const TestDef& t : deck.tests)
    for (std::size_t j = 0; j < t.legs.size(); ++j) {
      const double dt = deck.stage_time_step(t);
      const Leg& leg = t.legs[j];
      const std::string at = "test '" + t.name + "' leg " + std::to_string(j);
      for (int k = 0; k < 3; ++k) {
        if (leg.axes[k].mode != AxisMode::StressRamp) continue;
        ++ramps;
        const double per_step = std::abs(leg.axes[k].rate) * dt;
        if (per_step > fastest) fastest = per_step, where = at + " x" + std::to_string(k + 1);
      }
      if (const std::int64_t n = ramp_target_steps(leg, dt); n >= 0)
        out += "\n  " + at + ": the ramp's target reaches end.stress " + fmt(leg.end.value) + " Pa after " +
               std::to_string(n) + " steps";
      if (leg.end.kind == LegEndKind::Equilibrium) {
        const EquilibriumDef& e = t.equilibrium;
        out += "\n  " + at + ": ends in equilibrium after " + std::to_string(e.min_steps) + " to " +
               std::to_string(leg.end.max_steps > 0 ? leg.end.max_steps : e.max_steps) + " steps (|dp| <= " +
               fmt(e.pressure_tolerance) + ", max|ds| <= " + fmt(e.stress_tolerance) + ", unbalanced <= " +
               fmt(e.unbalanced_force_ratio) + ", checked every " + std::to_string(e.check_interval) + ")";
      }
    }
  if (out.empty()) return "";
  std::string head = "stress ramps and holds:";
  if (ramps > 0)
    head += " " + std::to_string(ramps) + " ramp axis(es), the fastest " + fmt(fastest) + " Pa per step (" + where +
            "; a ramp needs about that over the packing's tangent modulus as strain per step, within the leg's "
            "servo cap: `celldem plan` lists it)";
  return head + out;
}

std::string fast_loading(const Deck& deck, const TestDef& test) {
  constexpr double kLargeStrainPerStep = 1e-4;  // the shipped decks drive 1e-6 to 1e-5 per step
  const double rate = loading_rate(deck, test);  // the inertial number's scale
  double per_step = 0.0;                          // the largest strain per step of a driven axis
  for (const Leg& leg : test.legs) per_step = std::max(per_step, leg_driving_increment(leg, deck.stage_time_step(test)));
  const double p = first_leg_stress(test);
  const double inertia =
      std::isnan(p) ? 0.0 : inertial_number(rate, mean_diameter(deck.sample), deck.sample.density, p);
  if (!(per_step > kLargeStrainPerStep) && !(inertia > 10.0 * kQuasiStaticInertia)) return "";
  char buf[360];
  std::snprintf(buf, sizeof buf, "the loading of test '%s', a strain of %.3g per step (%.3g /s deviatoric, inertial number %.3g; "
                "quasi-static below %.3g, `celldem plan` gives both), is faster than the packing can follow: lower "
                "its strain increment or rate", test.name.c_str(), per_step, rate, inertia, kQuasiStaticInertia);
  return buf;
}

std::string fast_loading_cause(const Deck& deck, const TestDef& test) {
  const std::string what = fast_loading(deck, test);
  return what.empty() ? what : "likely cause: " + what + "; otherwise ";
}

// Probe points a test never reaches, and stress probes far beyond the stresses they start from (a probe is a small
// step: one as large as the confining stress tells nothing of the point's stiffness, and may not hold its control).
void warn_probe_reach(const Deck& deck, std::vector<std::string>& warnings) {
  for (const TestDef& t : deck.tests) {
    if (!t.probes) continue;
    double e1_end = 0.0, confining = 0.0;
    for (const Leg& leg : t.legs) {
      if (leg.end.kind == LegEndKind::Strain && leg.end.axis == 0) e1_end = std::max(e1_end, std::abs(leg.end.value));
      for (const AxisControl& a : leg.axes)
        if (a.mode == AxisMode::Stress || a.mode == AxisMode::MeanStress) confining = std::max(confining, std::abs(a.value));
    }
    for (const double e1 : t.probes->at_e1)
      if (e1_end > 0.0 && std::abs(e1) > e1_end * (1.0 + 1e-9))
        warnings.push_back("tests[" + t.name + "].probes.at_e1: " + fmt(e1) + " is beyond the test's end (e1 " +
                           fmt(e1_end) + "): the point is never reached and its probes are not run");
    if (t.probes->kind == ProbeKind::Stress && confining > 0.0)
      for (const double m : t.probes->magnitudes) {
        const std::string what = "tests[" + t.name + "].probes.magnitudes: " + fmt(m) + " Pa is " +
                                 fmt(m / confining) + " times the test's confining stress (" + fmt(confining) +
                                 " Pa): a probe is a small stress step, a few per cent of it (e.g. " +
                                 fmt(0.02 * confining) + " Pa)";
        if (m > 10.0 * confining) throw DeckError(what);  // no sample carries it: every probe would fail
        if (m > 0.25 * confining) warnings.push_back(what + "; probes this large may lose their control");
      }
  }
}

// Tests that start from initial_state as it is (no preparation): each one's time step against that state's contact
// network with the test's friction (run/time_step_check), refused or warned as the run would at the test's start.
// With a preparation the tests' network is known only once prepared: run_stage judges it then.
void check_network_time_steps(const Deck& deck, std::vector<std::string>& warnings) {
  if (!deck.initial_state || deck.prepare || deck.tests.empty()) return;
  State state = load_initial_state(deck);
  state.pairs.skin = skin_length(deck);
  for (const TestDef& t : deck.tests) {
    const Model model = make_model(deck, state.particles.radius, deck.stage_time_step(t));
    const NetworkStepJudgement j = judge_network_time_step(
        model, state, t.stage_friction(), "test '" + t.name + "' from initial_state " + initial_state_path(deck),
        time_step_key(deck, t.name));
    if (j.verdict == NetworkStepVerdict::Refuse) throw DeckError(j.message);
    if (j.verdict == NetworkStepVerdict::Warn) warnings.push_back(j.message);
  }
}

std::vector<std::string> preflight(const Deck& deck) {
  check_servo_caps(deck);
  check_moving_targets(deck);
  if (deck.prepare) check_prepared_cell(deck);
  if (deck.initial_state) {
    const std::string path = initial_state_path(deck);
    if (!std::filesystem::exists(path)) throw DeckError("initial_state: no such file " + path);
    if (std::filesystem::is_directory(path))
      throw DeckError("initial_state: " + path + " is a folder, not a state file (a celldem .state or a LAMMPS data "
                      "file)");
  }
  std::vector<std::string> warnings = deck_warnings(deck);
  if (deck.initial_state) check_state(deck, initial_state_path(deck), warnings);
  check_network_time_steps(deck, warnings);
  warn_unreached_snapshots(deck, warnings);
  warn_capped_strain_legs(deck, warnings);
  warn_probe_reach(deck, warnings);
  for (const TestDef& t : deck.tests) {
    if (const std::string fast = fast_loading(deck, t); !fast.empty()) warnings.push_back(fast);
    (void)verify_rate_for(VerifyRateOptions{}, t);  // a test's own verify_rate key: refused where run refuses it
  }
  return warnings;
}

}  // namespace celldem
