#include "run/health.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "core/plan.hpp"
#include "measure/micro.hpp"
#include "measure/quasi_static.hpp"
#include "run/errors.hpp"

namespace celldem {

namespace {
// The servo components that moved the cell by their cap in the last step: a runaway then names them first (a
// target the packing cannot carry, chased at the cap, shakes it as a too-large time step would).
std::string saturated_servos(const State& state, double cap) {
  std::string names;
  for (int k = 0; k < kComponents; ++k)
    if (state.servo_saturated[k]) names += (names.empty() ? "" : ", ") + component_name(k);
  if (names.empty()) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3g", cap);
  return "the servo of " + names + " moved the cell by its cap (servo.max_strain_increment " + buf +
         " per step) chasing a target the packing does not reach: lower the cap or the target; ";
}
}  // namespace

void RunawayMonitor::check(const Model& model, const State& state, const ContactMeasures& contacts) {
  const Particles& p = state.particles;
  const std::string where = "in stage '" + stage_ + "' at step " + std::to_string(state.control.stage_steps);
  const std::string servo_cause = saturated_servos(state, model.servo.max_strain_increment);
  // An explicit scheme has left its stable range when a particle moves a sizeable part of its radius in a
  // single step (quasi-static motion is orders of magnitude below this).
  double worst = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) worst = std::max(worst, p.velocity[i].norm() * model.dt / p.radius[i]);
  if (check_energy_) {
    // In a quasi-static test the packing's motion carries far less energy than its springs store (about
    // 1e-5 of it at the paper's settings). More kinetic than elastic energy means the scheme is unstable
    // or the loading is dynamic: the packing boils instead of deforming.
    // Only growth counts: a test may start from a packing that is still settling (kinetic energy decays).
    const double ke = contacts.kinetic_energy, ee = contacts.elastic_energy;
    const bool growing = previous_kinetic_energy_ >= 0.0 && ke > 2.0 * previous_kinetic_energy_;
    previous_kinetic_energy_ = ke;
    if (!quasi_static_cause_.empty()) {
      // Persisting over rows, not a spike; the first rows may still settle from the sample's preparation.
      const double unbalanced = contacts.unbalanced_force, ratio = ke / ee;
      const bool dynamic = !(unbalanced <= kMaxQuasiStaticUnbalanced) && !(ratio <= kMaxQuasiStaticKineticToElastic);
      dynamic_rows_ = rows_ >= kQuasiStaticSettleRows && dynamic ? dynamic_rows_ + 1 : 0;
      ++rows_;
      if (dynamic_rows_ >= kQuasiStaticRows) {
        char buf[256];
        std::snprintf(buf, sizeof buf, "for %d rows the unbalanced force ratio is above %.3g (now %.3g) and the "
                      "kinetic energy above %.3g of the elastic energy (now %.3g)", kQuasiStaticRows,
                      kMaxQuasiStaticUnbalanced, unbalanced, kMaxQuasiStaticKineticToElastic, ratio);
        throw RunError("not quasi-static " + where + ": " + buf + " - " + quasi_static_cause_ +
                       "; a test meant to be dynamic says \"dynamic\": true; the last checkpoint holds the last "
                       "good state");
      }
    }
    if (growing && !(ke <= kMaxKineticToElastic * ee)) {
      char buf[128];
      std::snprintf(buf, sizeof buf, "kinetic energy %.3g J exceeds %.3g x the elastic energy %.3g J", ke,
                    kMaxKineticToElastic, ee);
      throw RunError("runaway kinetic energy " + where + ": " + buf + " - " + start_cause_ + servo_cause +
                     "time step too large (`celldem plan` gives the stability limit per mode), damping too low "
                     "or loading too fast; the last checkpoint holds the last good state");
    }
  }
  if (!(worst <= kMaxStepMotion)) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "a particle moves %.3g of its radius per step (limit %.3g)", worst, kMaxStepMotion);
    throw RunError("runaway motion " + where + ": " + buf + " - " + start_cause_ + servo_cause + "time step too large, damping too low or loading "
                   "too fast; the last checkpoint holds the last good state");
  }
}

void check_row_finite(const SeriesRow& row, const std::string& stage, std::int64_t step) {
  for (const SeriesColumn& c : series_columns())
    if (c.must_be_finite && !std::isfinite(row.*c.field))
      throw RunError("non-finite values in stage '" + stage + "' at step " + std::to_string(step) + " (column " +
                     std::string(c.name) + " is " + std::to_string(row.*c.field) +
                     "; unstable time step or loading?); the last checkpoint holds the last good state");
}

std::vector<std::string> test_warnings(const TestDef& test, double inertia) {
  std::vector<std::string> out;
  if (inertia > kQuasiStaticInertia)
    out.push_back("test '" + test.name + "': inertial number " + std::to_string(inertia) +
                  " exceeds the quasi-static limit 1e-3: results depend on the loading rate");
  return out;
}

std::string not_quasi_static_cause(const Deck& deck, const TestDef& test) {
  const CriticalTimeStep limit = critical_time_steps(deck.sample, deck.contact);
  const double dt = deck.stage_time_step(test);
  const double fraction = dt / limit.value();
  char step[256];
  std::snprintf(step, sizeof step, "time step too large for the %s mode (time_step %.3g s is %.3g of its limit "
                "%.3g s, %s = %.3g)", limit.limiting().name, dt, fraction, limit.value(),
                limit.limiting().stiffness_name, limit.limiting().stiffness);
  const double p = first_leg_stress(test);
  const double inertia = std::isnan(p) ? 0.0 : inertial_number(loading_rate(deck, test), mean_diameter(deck.sample),
                                                               deck.sample.density, p);
  char rate[160];
  std::snprintf(rate, sizeof rate, "loading too fast (inertial number %.3g, quasi-static below %.3g)", inertia,
                kQuasiStaticInertia);
  const bool step_likely = fraction > kStableTimeStepFraction, rate_likely = inertia > kQuasiStaticInertia;
  if (step_likely && !rate_likely) return std::string("likely cause: ") + step;
  if (rate_likely && !step_likely) return std::string("likely cause: ") + rate;
  return std::string("likely causes: ") + step + ", or " + rate;
}

std::vector<std::string> deck_warnings(const Deck& deck) {
  std::vector<std::string> out;
  const CriticalTimeStep limit = critical_time_steps(deck.sample, deck.contact);
  const auto warn = [&](double time_step, const std::string& path) {
    for (const TimeStepFinding& f : time_step_findings(time_step, limit))
      if (!f.bound->refuse) out.push_back(path + " " + f.message);
  };
  warn(deck.time_step, "time_step");
  if (deck.prepare && deck.prepare->time_step) warn(*deck.prepare->time_step, "prepare.time_step");
  for (std::size_t i = 0; i < deck.tests.size(); ++i)
    if (deck.tests[i].time_step) warn(*deck.tests[i].time_step, "tests[" + std::to_string(i) + "].time_step");
  return out;
}

}  // namespace celldem
