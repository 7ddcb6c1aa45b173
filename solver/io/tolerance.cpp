#include "io/tolerance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/plan.hpp"
#include "io/deck_parts.hpp"
#include "io/deck_reader.hpp"
#include "measure/quasi_static.hpp"

#include <boost/math/distributions/normal.hpp>

namespace celldem {

// The table's text, compiled in (CMake writes it from io/time_to_answer_rules.json).
extern const char* const kTimeToAnswerRules;

namespace {

using deck_json::Json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double positive_number(const Json& level, const char* key, const std::string& at) {
  if (!level.contains(key) || !level[key].is_number() || !(level[key].get<double>() > 0.0) ||
      !std::isfinite(level[key].get<double>()))
    throw DeckError("time-to-answer rules: " + at + "." + key + ": expected a positive number");
  return level[key].get<double>();
}

// The axes' strain rates [1/s] (Voigt order, kComponentNames; 0 where no strain drives), the largest of them,
// and the inertial number's scale of them (core/plan inertial_strain_rate).
struct LegRates {
  std::array<double, kComponents> rate{};
  double driving = 0.0;   // the largest |strain_increment| / dt or |strain_rate|
  double inertial = 0.0;  // the deviatoric scale
};
LegRates leg_rates(const Json& axes, const Json* simple_shear, double time_step) {
  LegRates r;
  for (const auto& [name, axis] : axes.items()) {
    const auto at = std::find(kComponentNames.begin(), kComponentNames.end(), name);
    if (at == kComponentNames.end()) continue;
    double v = 0.0;
    if (axis.contains("strain_increment")) v = axis["strain_increment"].get<double>() / time_step;
    if (axis.contains("strain_rate")) v = axis["strain_rate"].get<double>();
    r.rate[static_cast<std::size_t>(at - kComponentNames.begin())] = v;
  }
  if (simple_shear && simple_shear->contains("gamma_increment"))  // its g12
    r.rate[3] = (*simple_shear)["gamma_increment"].get<double>() / time_step;
  if (simple_shear && simple_shear->contains("gamma_rate")) r.rate[3] = (*simple_shear)["gamma_rate"].get<double>();
  for (const double v : r.rate) r.driving = std::max(r.driving, std::abs(v));
  r.inertial = inertial_strain_rate(r.rate);
  return r;
}

// [Pa] the mean of the leg's stress targets (stress, mean_stress, a ramp's start); NaN without one.
double leg_stress(const Json& axes) {
  double sum = 0.0;
  int n = 0;
  for (const auto& [name, axis] : axes.items()) {
    for (const char* key : {"stress", "mean_stress"})
      if (axis.contains(key)) sum += axis[key].get<double>(), ++n;
    if (axis.contains("stress_ramp")) sum += axis["stress_ramp"]["from"].get<double>(), ++n;
  }
  return n ? sum / n : kNaN;
}

// A stage's time step: the level's fraction of the limit, down to three significant digits, so that the deck
// reads as a person would write it (the paper's 1e-6 s stays 1e-6 s) and stays below the level's fraction.
double stage_time_step(double fraction, double limit) {
  const double dt = fraction * limit;
  // digits / 10^k with 10^k exact: the nearest double to the decimal number, as the deck's literal would be
  const double scale = std::pow(10.0, 2.0 - std::floor(std::log10(dt)));
  return std::floor(dt * scale * (1.0 + 1e-12)) / scale;
}

std::int64_t scaled_count(std::int64_t n, double factor, std::int64_t at_least) {
  return std::max<std::int64_t>(at_least, std::llround(static_cast<double>(n) * factor));
}

// Every leg of a program, blocks {"repeat", "legs"} entered (each leg of a block once: they share the JSON).
template <class F>
void for_each_leg(Json& legs, F&& f) {
  for (Json& leg : legs) {
    if (leg.contains("repeat")) for_each_leg(leg["legs"], f);
    else f(leg);
  }
}

struct Resolver {
  const Deck& written;
  const RateBiasModel& model;
  ToleranceLevel level;
  double limit = 0.0;       // [s] the stability limit (core/plan critical_time_step)
  double largest_stress = 0.0;
  double fastest_step_factor = 1.0;  // the largest strain-per-step multiplier of any leg

  // One leg of a stage that runs at `dt` instead of `dt_written`. A strain-driven test leg (a simple_shear leg
  // too, by its g12): its rate from the level's inertial number at its confining stress; a strain-driven
  // preparation leg: its strain per step x the scale; any other leg keeps the time of its step ends (and a
  // principal-axis rotation its angle per unit time). Returns the leg's report and the strain-per-step factor
  // (0 for a leg without a strain-driven axis).
  Json leg(Json& leg, double dt_written, double dt, double stage_stress, bool preparation, double& step_factor) {
    // A simple_shear leg names no axes: its g12 drives it, its normal stress confines it.
    Json no_axes = Json::object();
    Json& axes = leg.contains("axes") ? leg["axes"] : no_axes;
    Json* simple_shear = leg.contains("simple_shear") ? &leg["simple_shear"] : nullptr;
    const LegRates rates = leg_rates(axes, simple_shear, dt_written);
    const double rate = rates.driving;
    Json report = {{"strain_driven", rate > 0.0}};
    double steps_factor = dt_written / dt;  // steps of the same physical time
    step_factor = 0.0;
    if (rate > 0.0) {
      double stress = leg_stress(axes);
      if (std::isnan(stress) && simple_shear) stress = (*simple_shear)["normal_stress"].get<double>();
      if (std::isnan(stress)) stress = stage_stress;
      if (std::isnan(stress) || stress <= 0.0) stress = largest_stress;
      const double d = mean_diameter(written.sample), rho = written.sample.density;
      // A test leg: the driving rate whose inertial scale, times its path's actual-to-imposed ratio, gives the
      // level's (actual) inertial number; the axes scaled together (to_inertial is exactly 1 with one driven axis).
      const double to_inertial = rates.inertial / rate;
      const PathRatio path = actual_to_imposed(model, axes, simple_shear != nullptr);
      const double new_rate = preparation
                                  ? rate * level.fast_strain_increment_scale * dt_written / dt
                                  : level.inertial_number / path.ratio / (d * std::sqrt(rho / stress)) / to_inertial;
      const double rate_factor = new_rate / rate;
      step_factor = rate_factor * dt / dt_written;
      for (auto& [name, axis] : axes.items()) {
        if (axis.contains("strain_increment")) axis["strain_increment"] = axis["strain_increment"].get<double>() * step_factor;
        if (axis.contains("strain_rate")) axis["strain_rate"] = axis["strain_rate"].get<double>() * rate_factor;
      }
      if (simple_shear && simple_shear->contains("gamma_increment"))
        (*simple_shear)["gamma_increment"] = (*simple_shear)["gamma_increment"].get<double>() * step_factor;
      if (simple_shear && simple_shear->contains("gamma_rate"))
        (*simple_shear)["gamma_rate"] = (*simple_shear)["gamma_rate"].get<double>() * rate_factor;
      steps_factor = 1.0 / step_factor;  // steps of the same strain
      fastest_step_factor = std::max(fastest_step_factor, step_factor);
      report["confining_stress"] = stress;
      report["strain_rate_written"] = rate;
      report["strain_rate"] = new_rate;
      report["driving_increment_written"] = rate * dt_written;
      report["driving_increment"] = new_rate * dt;
      if (stress > 0.0) {
        report["imposed_inertial_number_written"] = inertial_number(rate * to_inertial, d, rho, stress);
        report["imposed_inertial_number"] = inertial_number(new_rate * to_inertial, d, rho, stress);
      }
      // An adaptive rate speeds the leg up to its ceiling on the actual inertial number: no higher than T allows.
      if (!preparation && leg.contains("adaptive_rate") && leg["adaptive_rate"].is_object()) {
        Json& adaptive = leg["adaptive_rate"];
        const double ceiling = adaptive.value("inertial_number", keys::adaptive_inertial_number.fallback);
        adaptive["inertial_number"] = std::min(ceiling, level.inertial_number);
        report["adaptive_ceiling_written"] = ceiling;
        report["adaptive_ceiling"] = adaptive["inertial_number"];
      }
      if (stress > 0.0 && !preparation) {  // the laws' inertial number: the cell's actual one, predicted
        report["path"] = path.path;
        report["actual_to_imposed"] = path.ratio;
        report["actual_to_imposed_basis"] = path.basis;
        report["inertial_number_written"] = path.ratio * report["imposed_inertial_number_written"].get<double>();
        report["inertial_number"] = path.ratio * report["imposed_inertial_number"].get<double>();
      }
    }
    // A principal-axis rotation by angle per step keeps its angle per unit time, as its steps keep their time.
    if (leg.contains("rotate_principal_axes") && leg["rotate_principal_axes"].contains("angle_increment")) {
      Json& increment = leg["rotate_principal_axes"]["angle_increment"];
      increment = increment.get<double>() * dt / dt_written;
    }
    Json& end = leg["end"];
    for (const char* key : {"steps", "max_steps"})
      if (end.contains(key) && end[key].get<std::int64_t>() > 0)
        end[key] = scaled_count(end[key].get<std::int64_t>(), steps_factor, 1);
    return report;
  }

  // Equilibrium min_steps and check_interval at the stage's time step, from the values the deck gives it.
  static void equilibrium(Json& object, const EquilibriumDef& e, double time_factor) {
    if (!object.is_object()) object = Json::object();
    object["min_steps"] = scaled_count(e.min_steps, time_factor, 0);
    object["check_interval"] = scaled_count(e.check_interval, time_factor, 1);
  }

  // The rules' step of a stage with `friction`, capped (rounded down as stage_time_step) at kNetworkWarnFraction of
  // its contact network's limit, estimated before the packing exists (core/plan network_time_step_estimate): the
  // rules were measured on 1000 spheres, whose network limit is above a larger packing's. The report says so.
  double network_capped(double dt, const Friction& friction, Json& report) const {
    const double network = network_time_step_estimate(written.sample, written.contact, friction);
    const double cap = kNetworkWarnFraction * network;
    report["network_time_step_estimate"] = network;
    report["network_cap"] = cap;
    report["network_capped"] = dt > cap;
    if (!(dt > cap)) return dt;
    const double capped = stage_time_step(cap / limit, limit);
    report["time_step_rules"] = dt;
    report["time_step"] = capped;
    report["time_step_fraction"] = capped / limit;
    return capped;
  }

  static Json stage_time(double dt_written, double dt, double limit) {
    return {{"time_step_written", dt_written}, {"time_step", dt}, {"time_step_fraction_written", dt_written / limit},
            {"time_step_fraction", dt / limit}};
  }

  Json preparation(Json& j) {
    const PrepareDef& p = *written.prepare;
    const double dt_written = written.stage_time_step(p);
    Json report = stage_time(dt_written, stage_time_step(level.prepare_time_step_fraction, limit), limit);
    const double dt = network_capped(report["time_step"].get<double>(), p.stage_friction(), report);
    const double time_factor = dt_written / dt;
    j["time_step"] = dt;
    report["stage"] = "prepare";
    report["legs"] = Json::array();
    if (j.contains("legs")) {
      for_each_leg(j["legs"], [&](Json& leg) {
        double step_factor = 0.0;
        report["legs"].push_back(this->leg(leg, dt_written, dt, p.target_pressure, true, step_factor));
      });
    } else {
      // The fast leg keeps its strain rate (increment / dt) times the level's scale, as the servo leg below.
      const double fast_factor = level.fast_strain_increment_scale / time_factor;
      j["fast_strain_increment"] = p.fast_strain_increment * fast_factor;
      fastest_step_factor = std::max(fastest_step_factor, fast_factor);
      report["fast_strain_increment_written"] = p.fast_strain_increment;
      report["fast_strain_increment"] = j["fast_strain_increment"];
      // The servo leg compresses the loose packing at its cap per step until the contacts stiffen: the cap keeps
      // its strain rate (cap / dt), so the preparation follows the same schedule in time at the larger step.
      const ServoDef servo = written.stage_servo(p);
      const double cap_written = servo.max_strain_increment_given ? servo.max_strain_increment : kDefaultServoCap;
      j["servo_max_strain_increment"] = std::min(keys::prepare_servo_max_strain_increment.max, cap_written / time_factor);
      report["servo_max_strain_increment_written"] = cap_written;
      report["servo_max_strain_increment"] = j["servo_max_strain_increment"];
    }
    equilibrium(j["equilibrium"], p.equilibrium, time_factor);
    report["equilibrium"] = {{"min_steps_written", p.equilibrium.min_steps}, {"min_steps", j["equilibrium"]["min_steps"]},
                             {"check_interval_written", p.equilibrium.check_interval},
                             {"check_interval", j["equilibrium"]["check_interval"]}};
    j["output_interval"] = scaled_count(p.output_interval, time_factor, 1);
    report["output_interval_written"] = p.output_interval;
    report["output_interval"] = j["output_interval"];
    if (j.contains("snapshots") && j["snapshots"].contains("interval"))
      j["snapshots"]["interval"] = scaled_count(j["snapshots"]["interval"].get<std::int64_t>(), time_factor, 1);
    return report;
  }

  Json test(Json& j, const TestDef& t) {
    const double dt_written = written.stage_time_step(t);
    Json report = stage_time(dt_written, stage_time_step(level.time_step_fraction, limit), limit);
    const double dt = network_capped(report["time_step"].get<double>(), t.stage_friction(), report);
    const double time_factor = dt_written / dt;
    j["time_step"] = dt;
    report["stage"] = t.name;
    report["legs"] = Json::array();
    const double stress = first_leg_stress(t);
    double first_step_factor = 0.0;  // the first strain-driven leg's: the output interval keeps its rows per strain
    const auto one = [&](Json& leg) {
      double step_factor = 0.0;
      report["legs"].push_back(this->leg(leg, dt_written, dt, stress, false, step_factor));
      if (first_step_factor == 0.0) first_step_factor = step_factor;
    };
    if (j.contains("legs")) for_each_leg(j["legs"], one);
    else one(j);
    const double interval_factor = first_step_factor > 0.0 ? 1.0 / first_step_factor : time_factor;
    j["output_interval"] = scaled_count(t.output_interval, interval_factor, 1);
    report["output_interval_written"] = t.output_interval;
    report["output_interval"] = j["output_interval"];
    if (j.contains("snapshots") && j["snapshots"].contains("interval"))
      j["snapshots"]["interval"] = scaled_count(j["snapshots"]["interval"].get<std::int64_t>(), interval_factor, 1);
    const bool holds = std::any_of(t.legs.begin(), t.legs.end(), [](const Leg& l) { return l.end.kind == LegEndKind::Equilibrium; });
    if (holds) equilibrium(j["equilibrium"], t.equilibrium, time_factor);
    return report;
  }
};

}  // namespace

namespace {

double number_in(const Json& j, const char* key, const std::string& at) {
  if (!j.contains(key) || !j[key].is_number() || !std::isfinite(j[key].get<double>()))
    throw DeckError("time-to-answer rules: " + at + "." + key + ": expected a number");
  return j[key].get<double>();
}

RateBiasModel parse_rate_bias(const Json& j) {
  const std::string at = "rate_bias";
  if (!j.is_object() || !j.contains("laws") || !j["laws"].is_array() || j["laws"].empty())
    throw DeckError("time-to-answer rules: rate_bias: expected an object with a non-empty array \"laws\"");
  RateBiasModel m;
  m.reference_inertial_number = positive_number(j, "reference_inertial_number", at);
  m.particles = static_cast<int>(positive_number(j, "particles", at));
  m.floor_exponent = number_in(j, "floor_exponent", at);
  if (!j.contains("floor_exponent_interval") || !j["floor_exponent_interval"].is_array() ||
      j["floor_exponent_interval"].size() != 2)
    throw DeckError("time-to-answer rules: rate_bias.floor_exponent_interval: expected [low, high]");
  m.floor_exponent_low = j["floor_exponent_interval"][0].get<double>();
  m.floor_exponent_high = j["floor_exponent_interval"][1].get<double>();
  if (!(m.floor_exponent_low <= m.floor_exponent && m.floor_exponent <= m.floor_exponent_high &&
        m.floor_exponent_high <= 0.0))
    throw DeckError(
        "time-to-answer rules: rate_bias.floor_exponent_interval: expected low <= floor_exponent <= high <= 0");
  m.confidence = positive_number(j, "confidence", at);
  if (!(m.confidence >= 0.5 && m.confidence < 1.0))
    throw DeckError("time-to-answer rules: rate_bias.confidence: expected a number in [0.5, 1)");
  m.max_inertial_number = positive_number(j, "max_inertial_number", at);
  for (std::size_t i = 0; i < j["laws"].size(); ++i) {
    const Json& l = j["laws"][i];
    const std::string where = at + ".laws[" + std::to_string(i) + "]";
    RateBiasLaw law;
    if (!l.contains("quantity") || !l["quantity"].is_string())
      throw DeckError("time-to-answer rules: " + where + ".quantity: expected a string");
    law.quantity = l["quantity"].get<std::string>();
    law.floor = positive_number(l, "floor", where);
    law.log_coefficient = std::log(positive_number(l, "coefficient", where));
    law.order = positive_number(l, "order", where);
    if (!l.contains("covariance") || !l["covariance"].is_array() || l["covariance"].size() != 3)
      throw DeckError("time-to-answer rules: " + where + ".covariance: expected [var ln C, cov, var p]");
    law.var_log_coefficient = l["covariance"][0].get<double>();
    law.covariance = l["covariance"][1].get<double>();
    law.var_order = l["covariance"][2].get<double>();
    if (!(law.var_log_coefficient >= 0.0 && law.var_order >= 0.0))
      throw DeckError("time-to-answer rules: " + where + ".covariance: variances must not be negative");
    m.laws.push_back(law);
  }
  const std::string paths_at = at + ".actual_to_imposed.paths";
  if (j.contains("actual_to_imposed")) {
    m.path_margin = positive_number(j["actual_to_imposed"], "margin", at + ".actual_to_imposed");
    if (m.path_margin < 1.0)
      throw DeckError("time-to-answer rules: " + at + ".actual_to_imposed.margin: expected at least 1");
  }
  if (!j.contains("actual_to_imposed") || !j["actual_to_imposed"].contains("paths") ||
      !j["actual_to_imposed"]["paths"].is_array() || j["actual_to_imposed"]["paths"].empty())
    throw DeckError("time-to-answer rules: " + paths_at + ": expected a non-empty array");
  for (std::size_t i = 0; i < j["actual_to_imposed"]["paths"].size(); ++i) {
    const Json& p = j["actual_to_imposed"]["paths"][i];
    const std::string where = paths_at + "[" + std::to_string(i) + "]";
    if (!p.is_object() || !p.contains("path") || !p["path"].is_string())
      throw DeckError("time-to-answer rules: " + where + ".path: expected a string");
    MeasuredPath path;
    path.path = p["path"].get<std::string>();
    const auto count = [&](const char* key) {
      const double n = number_in(p, key, where);
      if (!(n >= 0.0 && n <= 3.0 && n == std::floor(n)))
        throw DeckError("time-to-answer rules: " + where + "." + key + ": expected 0 to 3 axes");
      return static_cast<int>(n);
    };
    path.normal_driven = count("normal_driven");
    path.normal_zero_strain = count("normal_zero_strain");
    path.normal_held = count("normal_held");
    path.shear_driven = p.contains("shear_driven") ? count("shear_driven") : 0;
    path.normal_b = p.contains("normal_b") ? count("normal_b") : 0;
    if (path.normal_b > 1) throw DeckError("time-to-answer rules: " + where + ".normal_b: at most one b axis");
    if (path.normal_b == 1) {
      path.b = number_in(p, "b", where);
      if (!(path.b >= 0.0 && path.b <= 1.0)) throw DeckError("time-to-answer rules: " + where + ".b: expected [0, 1]");
    }
    if (path.normal_driven + path.normal_zero_strain + path.normal_held + path.normal_b != 3)
      throw DeckError("time-to-answer rules: " + where + ": its normal axes must add up to 3");
    path.ratio = positive_number(p, "ratio", where);
    m.paths.push_back(path);
  }
  return m;
}

}  // namespace

// The smallest inertial number a tolerance is resolved to (below it a test would take 1e5 times the paper's steps).
constexpr double kMinInertialNumber = 1e-9;

double rate_bias_floors(const RateBiasModel& model, const RateBiasLaw& law, double inertial_number, double particles,
                        bool upper) {
  const double L = std::log(inertial_number / model.reference_inertial_number);
  double log_bias = law.log_coefficient + law.order * L;
  const double size = std::log(particles / model.particles);
  double exponent = model.floor_exponent;
  if (upper) {
    const double var = law.var_log_coefficient + 2.0 * law.covariance * L + law.var_order * L * L;
    log_bias += boost::math::quantile(boost::math::normal_distribution<double>(), model.confidence) *
                std::sqrt(std::max(0.0, var));
    // the narrowest floors the interval allows at this size: the steep end above the model's count, the shallow below
    exponent = size > 0.0 ? model.floor_exponent_low : model.floor_exponent_high;
  }
  return std::exp(log_bias - std::log(law.floor) - exponent * size);
}

RateForTolerance inertial_number_for_tolerance(const RateBiasModel& model, double tolerance, double particles) {
  RateForTolerance out{model.max_inertial_number, ""};
  for (const RateBiasLaw& law : model.laws) {
    // the upper bias grows with I over the range sought (the laws' orders are positive): bisection in log I
    double lo = std::log(kMinInertialNumber), hi = std::log(model.max_inertial_number);
    if (rate_bias_floors(model, law, std::exp(hi), particles, true) <= tolerance) continue;
    if (rate_bias_floors(model, law, std::exp(lo), particles, true) > tolerance) return {0.0, law.quantity};
    for (int k = 0; k < 100; ++k) {
      const double mid = 0.5 * (lo + hi);
      (rate_bias_floors(model, law, std::exp(mid), particles, true) <= tolerance ? lo : hi) = mid;
    }
    if (std::exp(lo) < out.inertial_number) out = {std::exp(lo), law.quantity};
  }
  return out;
}

PathRatio actual_to_imposed(const RateBiasModel& model, const Json& axes, bool simple_shear) {
  // A simple shear drives g12 with x1 and x3 at zero strain and x2 held by its normal stress.
  int driven = 0, zero = simple_shear ? 2 : 0, held = simple_shear ? 1 : 0, shear_driven = simple_shear ? 1 : 0;
  int b_axes = 0;
  double b = kNaN;
  bool other = false;
  for (std::size_t k = 0; k < kComponentNames.size() && !simple_shear; ++k) {
    const std::string name(kComponentNames[k]);
    const bool normal = k < 3;
    if (!axes.contains(name)) {  // a shear left out keeps its tilt (a normal axis is always named)
      if (normal) ++held;
      continue;
    }
    const Json& axis = axes[name];
    // held by the volume or by a ramp, not by a constant stress: not measured
    if (axis.contains("constant_volume") || axis.contains("stress_ramp")) other = true;
    const bool strain = axis.contains("strain_increment") || axis.contains("strain_rate");
    const double value = strain ? axis.value("strain_increment", axis.value("strain_rate", 0.0)) : 0.0;
    if (normal && axis.contains("b"))
      ++b_axes, b = axis["b"].get<double>();
    else if (normal)
      (strain ? (value != 0.0 ? driven : zero) : held) += 1;
    else if (!strain)
      other = true;  // a shear held by a servo
    else if (value != 0.0)
      ++shear_driven;
  }
  const double margin = model.path_margin;
  if (held == 0 && b_axes == 0)
    return {"strain-driven", 2.0 / std::sqrt(3.0),
            "every component strain-driven: sqrt(2 D':D') over sqrt(3/2 e':e') of one tensor, exactly 2/sqrt(3)"};
  // A path of the table: the same axes; with a b axis the measured b at or just below and at or just above its own,
  // the larger ratio of the two (the ratio grows with b where measured).
  const MeasuredPath* below = nullptr;
  const MeasuredPath* above = nullptr;
  for (const MeasuredPath& p : model.paths) {
    if (other || p.normal_driven != driven || p.normal_zero_strain != zero || p.normal_held != held ||
        p.normal_b != b_axes || p.shear_driven != shear_driven)
      continue;
    if (b_axes == 0)
      return {p.path, margin * p.ratio,
              "measured on its path, times the margin (io/time_to_answer_rules.json rate_bias.actual_to_imposed)"};
    if (p.b <= b && (!below || p.b > below->b)) below = &p;
    if (p.b >= b && (!above || p.b < above->b)) above = &p;
  }
  if (below && above) {
    const MeasuredPath& p = below->ratio >= above->ratio ? *below : *above;
    return {p.path, margin * p.ratio,
            "measured on its path at b = " + fmt(below->b) + " and " + fmt(above->b) +
                ", the larger of the two, times the margin"};
  }
  const auto largest = std::max_element(model.paths.begin(), model.paths.end(),
                                        [](const auto& x, const auto& y) { return x.ratio < y.ratio; });
  return {"unmeasured", margin * largest->ratio,
          "a path with servo-held components not measured: the largest measured path's ratio times the margin; the run "
          "checks it"};
}

Json ToleranceCheck::to_json() const {
  Json d = Json::object();
  for (const Distance& x : distances) d[x.quantity] = {x.central, x.upper};
  return {
      {"tolerance", tolerance},
      {"inertial_number_allowed", inertial_number_allowed},
      {"inertial_number", inertial_number},
      {"imposed_inertial_number", imposed_inertial_number},
      {"actual_to_imposed", imposed_inertial_number > 0.0 ? Json(inertial_number / imposed_inertial_number) : Json()},
      {"distance_floors", d},
      {"kept", kept}};
}

ToleranceCheck check_tolerance(const RateBiasModel& model, double tolerance, double particles, double inertial_number,
                               double imposed_inertial_number) {
  ToleranceCheck c;
  c.tolerance = tolerance;
  c.inertial_number_allowed = inertial_number_for_tolerance(model, tolerance, particles).inertial_number;
  c.inertial_number = inertial_number;
  c.imposed_inertial_number = imposed_inertial_number;
  c.kept = inertial_number > 0.0;
  for (const RateBiasLaw& law : model.laws) {
    ToleranceCheck::Distance x{law.quantity, 0.0, 0.0};
    if (inertial_number > 0.0) {
      x.central = rate_bias_floors(model, law, inertial_number, particles, false);
      x.upper = rate_bias_floors(model, law, inertial_number, particles, true);
    }
    c.kept = c.kept && x.upper <= tolerance * (1.0 + 1e-9);
    c.distances.push_back(x);
  }
  return c;
}

const std::string& time_to_answer_rules_text() {
  static const std::string text = kTimeToAnswerRules;
  return text;
}

const ToleranceRules& time_to_answer_rules() {
  static const ToleranceRules rules = parse_tolerance_rules(time_to_answer_rules_text());
  return rules;
}

ToleranceRules parse_tolerance_rules(const std::string& json_text) {
  Json j;
  try {
    j = Json::parse(json_text);
  } catch (const Json::exception& e) {
    throw DeckError(std::string("time-to-answer rules: not JSON: ") + e.what());
  }
  if (!j.is_object() || !j.contains("levels") || !j["levels"].is_array() || j["levels"].empty())
    throw DeckError("time-to-answer rules: expected an object with a non-empty array \"levels\"");
  ToleranceRules rules;
  if (j.contains("particles")) rules.particles = static_cast<int>(positive_number(j, "particles", "(top level)"));
  for (std::size_t i = 0; i < j["levels"].size(); ++i) {
    const Json& l = j["levels"][i];
    const std::string at = "levels[" + std::to_string(i) + "]";
    if (!l.is_object()) throw DeckError("time-to-answer rules: " + at + ": expected an object");
    ToleranceLevel level;
    level.tolerance = positive_number(l, "tolerance", at);
    level.time_step_fraction = positive_number(l, "time_step_fraction", at);
    level.prepare_time_step_fraction = positive_number(l, "prepare_time_step_fraction", at);
    level.inertial_number = positive_number(l, "inertial_number", at);
    level.fast_strain_increment_scale = positive_number(l, "fast_strain_increment_scale", at);
    level.damping_scale = positive_number(l, "damping_scale", at);
    if (level.time_step_fraction > kMaxTimeStepFraction || level.prepare_time_step_fraction > kMaxTimeStepFraction)
      throw DeckError("time-to-answer rules: " + at + ": a time step fraction above the stability limit (" +
                      fmt(kMaxTimeStepFraction) + ")");
    if (!rules.levels.empty() && level.tolerance <= rules.levels.back().tolerance)
      throw DeckError("time-to-answer rules: " + at + ".tolerance: the levels must ascend");
    rules.levels.push_back(level);
  }
  if (j.contains("rate_bias")) rules.rate_bias = parse_rate_bias(j["rate_bias"]);
  return rules;
}

ToleranceLevel interpolate_rules(const ToleranceRules& rules, double tolerance, const std::string& key_path) {
  const ToleranceLevel& lo = rules.levels.front();
  const ToleranceLevel& hi = rules.levels.back();
  if (!(tolerance >= lo.tolerance && tolerance <= hi.tolerance))
    throw DeckError(key_path + ": " + fmt(tolerance) + " is outside the time-to-answer rules' range [" +
                    fmt(lo.tolerance) + ", " + fmt(hi.tolerance) + "] noise floors (io/time_to_answer_rules.json)");
  std::size_t k = 0;
  while (k + 1 < rules.levels.size() && rules.levels[k + 1].tolerance <= tolerance) ++k;
  if (k + 1 == rules.levels.size() || rules.levels[k].tolerance == tolerance) {
    ToleranceLevel out = rules.levels[k];
    out.tolerance = tolerance;
    return out;
  }
  const ToleranceLevel& a = rules.levels[k];
  const ToleranceLevel& b = rules.levels[k + 1];
  const double w = (tolerance - a.tolerance) / (b.tolerance - a.tolerance);
  const auto mix = [w](double x, double y) { return std::exp((1.0 - w) * std::log(x) + w * std::log(y)); };
  ToleranceLevel out;
  out.tolerance = tolerance;
  out.time_step_fraction = mix(a.time_step_fraction, b.time_step_fraction);
  out.prepare_time_step_fraction = mix(a.prepare_time_step_fraction, b.prepare_time_step_fraction);
  out.inertial_number = mix(a.inertial_number, b.inertial_number);
  out.fast_strain_increment_scale = mix(a.fast_strain_increment_scale, b.fast_strain_increment_scale);
  out.damping_scale = mix(a.damping_scale, b.damping_scale);
  return out;
}

double calibration_tolerance(const ToleranceRules& rules, double tolerance, double particles) {
  if (rules.particles <= 0 || !(particles > rules.particles)) return tolerance;
  return tolerance * std::sqrt(rules.particles / particles);
}

namespace {

// What the floor model did to T, for the summary and the plan: the table's level (time steps, the preparation)
// is read at T carried to the table's scene, clamped to its range.
Json calibration_json(const ToleranceRules& rules, double tolerance, double particles, double at_calibration,
                      double at_table) {
  Json c = {{"particles", particles},
            {"tolerance", tolerance},
            {"tolerance_at_calibration", at_calibration},
            {"table_tolerance", at_table},
            {"model",
             "the table's levels (time steps, the preparation's knobs) are read at T sqrt(calibration_particles "
             "/ N) for a deck larger than their scene (floors as 1/sqrt(N)), T for a smaller one, clamped to "
             "the table's range; the strain-driven legs' rate comes from the rate bias laws (rate)"}};
  if (rules.particles > 0) c["calibration_particles"] = rules.particles;
  return c;
}

// The rate's promise and the written deck's distance from I -> 0, per quantity, in floors of this deck.
Json rate_json(const RateBiasModel& model, const RateForTolerance& rate, double tolerance, double particles,
               const Json& stages) {
  Json laws = Json::array();
  for (const RateBiasLaw& law : model.laws)
    laws.push_back({{"quantity", law.quantity},
                    {"bias_floors", rate_bias_floors(model, law, rate.inertial_number, particles, false)},
                    {"bias_floors_upper", rate_bias_floors(model, law, rate.inertial_number, particles, true)},
                    {"order", law.order},
                    {"floor_at_calibration", law.floor}});
  Json written = Json::array();
  for (const Json& stage : stages)
    for (const Json& leg : stage["legs"]) {
      if (!leg.contains("inertial_number_written")) continue;
      const double I = leg["inertial_number_written"].get<double>();
      Json d = {{"stage", stage["stage"]},
                {"inertial_number", I},
                {"slowed", I > rate.inertial_number * (1.0 + 1e-9)},
                {"rate_factor", rate.inertial_number / I}};
      for (const RateBiasLaw& law : model.laws)
        d["distance_floors"][law.quantity] = {rate_bias_floors(model, law, I, particles, false),
                                              rate_bias_floors(model, law, I, particles, true)};
      written.push_back(d);
    }
  char buf[1600];
  std::snprintf(
      buf, sizeof buf,
      "the mean over seeds of each quantity the laws cover is within %g floors of this deck's size (%g spheres) "
      "of its quasi-static value (I -> 0), by each law's one-sided %g %% upper bound and the floor model's "
      "exponent at the end of its interval that narrows the floors here; one run adds its own seed-to-seed "
      "scatter (one floor, a standard deviation): within T + %.2f floors at 95 %%. The laws were measured on "
      "the TTC of a 1000-sphere scene to e1 = 5 %%, against the cell's actual inertial number; other paths are "
      "extrapolated at the same actual inertial number, which each leg's path predicts before the run and the "
      "run measures (summary.json tests.<test>.tolerance says whether it kept T); the time step's own "
      "effect (0.917 of the limit) is not in the promise (not resolved from chaos by the study)",
      tolerance, particles, 100.0 * model.confidence,
      boost::math::quantile(boost::math::normal_distribution<double>(), 0.975));
  return {{"inertial_number", rate.inertial_number},
          {"limiting",
           rate.limiting.empty() ? Json("the laws' measured range (I capped at its top)") : Json(rate.limiting)},
          {"inertial_number_definition",
           "the cell's actual inertial number, gamma_dot d_mean sqrt(rho / p) with gamma_dot = sqrt(2 D':D') of its "
           "whole velocity gradient, servo-held axes included (the series' inertial_number), predicted before the "
           "run as the imposed one (imposed_inertial_number) times its path's ratio (actual_to_imposed) and checked "
           "after it (summary.json tests.<test>.tolerance)"},
          {"promise", buf},
          {"laws", laws},
          {"written", written}};
}

}  // namespace

Deck resolve_tolerance(const Deck& written, const std::string& json_text, double tolerance, const std::string& key_path) {
  if (!(tolerance > 0.0) || !std::isfinite(tolerance))
    throw DeckError(key_path + ": " + fmt(tolerance) + ": expected a positive number of noise floors");
  const ToleranceRules& rules = time_to_answer_rules();
  if (rules.rate_bias.laws.empty()) throw DeckError(key_path + ": the time-to-answer rules have no rate_bias laws");
  const double particles = written.sample.count;
  const double at_calibration = calibration_tolerance(rules, tolerance, particles);
  const double at_table = std::clamp(at_calibration, rules.levels.front().tolerance, rules.levels.back().tolerance);
  // The rules' time step unit: the stability limit, or where the normal mode limits (kt well below kn) the bound
  // check refuses above (core/plan.hpp kNormalModeFraction of the normal mode's own limit: packings boil there).
  const CriticalTimeStep modes = critical_time_steps(written.sample, written.contact);
  const double limit = std::min(modes.value(), kNormalModeFraction * modes.modes[0].time_step);
  Json j = deck_json::parse_json(json_text);
  j.erase("tolerance");
  Json calibration = calibration_json(rules, tolerance, particles, at_calibration, at_table);
  // The strain-driven legs' inertial number: T floors of this deck from I -> 0 by the rate bias laws.
  const RateForTolerance rate = inertial_number_for_tolerance(rules.rate_bias, tolerance, particles);
  if (!(rate.inertial_number > 0.0))
    throw DeckError(key_path + ": " + fmt(tolerance) + " noise floors of " + fmt(particles) +
                    " spheres cannot be "
                    "promised for " +
                    rate.limiting + " at any inertial number down to " + fmt(kMinInertialNumber) +
                    " by the rate bias laws (io/time_to_answer_rules.json rate_bias): ask for a larger tolerance");
  ToleranceLevel level = interpolate_rules(rules, at_table, key_path);
  level.inertial_number = rate.inertial_number;
  Resolver r{written, rules.rate_bias, level};
  r.limit = limit;
  r.largest_stress = largest_deck_stress(written);
  Json stages = Json::array();
  if (written.prepare) stages.push_back(r.preparation(j["prepare"]));
  for (std::size_t i = 0; i < written.tests.size(); ++i) stages.push_back(r.test(j["tests"][i], written.tests[i]));
  if (r.level.damping_scale != 1.0)
    for (const char* key : {"translational", "rotational"})
      j["damping"][key] = j["damping"][key].get<double>() * r.level.damping_scale;
  // An explicit servo cap rises with the fastest leg's strain per step (the default follows each leg's own).
  if (j.contains("servo") && j["servo"].contains("max_strain_increment") && r.fastest_step_factor > 1.0)
    j["servo"]["max_strain_increment"] = std::min(keys::servo_max_strain_increment.max,
                                                  j["servo"]["max_strain_increment"].get<double>() * r.fastest_step_factor);
  const std::string note = "rewritten by celldem for tolerance " + fmt(tolerance) + " noise floors from " + written.source;
  j["description"] = j.contains("description") ? j["description"].get<std::string>() + " [" + note + "]" : note;
  Deck d;
  try {
    d = parse_deck(j.dump(), written.source);
  } catch (const DeckError& e) {
    throw DeckError(key_path + " " + fmt(tolerance) + ": the rewritten deck is refused: " + e.what());
  }
  d.tolerance = tolerance;
  const ToleranceLevel& l = r.level;
  d.tolerance_settings = Json{
      {"tolerance", tolerance},
      {"calibration", calibration},
      {"rules",
       {{"time_step_fraction", l.time_step_fraction},
        {"prepare_time_step_fraction", l.prepare_time_step_fraction},
        {"inertial_number", l.inertial_number},
        {"fast_strain_increment_scale", l.fast_strain_increment_scale},
        {"damping_scale", l.damping_scale}}},
      {"stability_limit", r.limit},
      {"damping", {{"translational", d.damping.translational}, {"rotational", d.damping.rotational}}},
      {"rate", rate_json(rules.rate_bias, rate, tolerance, particles, stages)},
      {"stages", stages}}.dump();
  return d;
}

std::string resolved_deck_json(const Deck& deck) {
  Json j = Json::parse(deck.canonical);
  if (deck.initial_state)
    j["initial_state"] = std::filesystem::absolute(std::filesystem::path(deck.source).parent_path() / *deck.initial_state)
                             .lexically_normal()
                             .string();
  return j.dump(2) + "\n";
}

}  // namespace celldem
