#include "core/plan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/number_text.hpp"

namespace celldem {

bool is_reserved_stage_name(const std::string& name) { return name == "prepare" || name == "figures"; }

std::vector<Leg> preparation_legs(const PrepareDef& prep) {
  Leg fast, servo;
  std::fill_n(fast.axes.begin(), 3, AxisControl{AxisMode::StrainIncrement, prep.fast_strain_increment});  // (tilts held)
  fast.end = {.kind = LegEndKind::SolidFraction, .value = prep.fast_solid_fraction};
  std::fill_n(servo.axes.begin(), 3, AxisControl{AxisMode::Stress, prep.target_pressure});
  servo.end = {.kind = LegEndKind::Equilibrium, .max_steps = prep.equilibrium.max_steps};
  return {fast, servo};
}

PreparationProgram preparation_program(const PrepareDef& prep, double start_solid_fraction) {
  PreparationProgram p{prep.legs, 0};
  if (prep.default_legs && p.legs.size() == 2 && start_solid_fraction >= prep.fast_solid_fraction) {
    p.legs.erase(p.legs.begin());
    p.skipped = 1;
  }
  return p;
}

std::int64_t leg_steps(const Leg& leg, double time_step, double from) {
  const LegEnd& e = leg.end;
  std::int64_t n = -1;
  if (e.kind == LegEndKind::Steps) n = e.steps;
  if (leg.ends_on_driven_strain())  // a normal axis's strain, or a shear axis's (g = g(leg start) + n d likewise)
    n = std::max<std::int64_t>(0, std::llround((e.value - from) / leg.end_strain_per_step(time_step)));
  if (n >= 0 && e.max_steps > 0) n = std::min(n, e.max_steps);
  return n;
}

double leg_driving_increment(const Leg& leg, double time_step) {
  double d = 0.0;
  for (int k = 0; k < kComponents; ++k) d = std::max(d, std::abs(leg.strain_per_step(k, time_step)));  // shear drives too
  return d;
}

double inertial_strain_rate(const std::array<double, kComponents>& e) {
  // In differences: an isotropic drive gives an exact 0, and one normal rate with the rest 0 gives (e11^2 + e11^2) / 2
  // = fl(e11^2) exactly, whose square root is |e11| exactly.
  const double a = e[0] - e[1], b = e[1] - e[2], c = e[2] - e[0];
  const double j = 0.5 * (a * a + b * b + c * c) + 0.75 * (e[3] * e[3] + e[4] * e[4] + e[5] * e[5]);
  if (j > 0.0) return std::sqrt(j);
  return std::max({std::abs(e[0]), std::abs(e[1]), std::abs(e[2])});  // isotropic: no deviatoric part
}

double leg_inertial_rate(const Leg& leg, double time_step) {
  std::array<double, kComponents> rate{};
  for (int k = 0; k < kComponents; ++k) {
    const AxisControl& a = leg.axes[static_cast<std::size_t>(k)];
    rate[static_cast<std::size_t>(k)] = a.mode == AxisMode::StrainIncrement ? a.value / time_step
                                        : a.mode == AxisMode::StrainRate     ? a.value
                                                                             : 0.0;
  }
  return inertial_strain_rate(rate);
}

std::int64_t ramp_target_steps(const Leg& leg, double time_step) {
  const LegEnd& e = leg.end;
  if (e.kind != LegEndKind::Stress) return -1;
  const AxisControl& a = leg.axes[e.axis];
  if (a.mode != AxisMode::StressRamp) return -1;
  return static_cast<std::int64_t>(std::ceil((e.value - a.value) / (a.rate * time_step) * (1.0 - 1e-12)));
}

bool leg_has_servo(const Leg& leg) {
  return std::any_of(leg.axes.begin(), leg.axes.end(), [](const AxisControl& a) { return a.stress_driven(); });
}

double servo_cap(const ServoDef& servo, const Leg& leg, double time_step, double rate_factor) {
  if (servo.max_strain_increment_given) return servo.max_strain_increment;
  return std::max(kDefaultServoCap, kServoCapFactor * leg_driving_increment(leg, time_step) * rate_factor);
}

std::vector<std::int64_t> program_leg_steps(const std::vector<Leg>& legs, double time_step,
                                            std::vector<double>* from) {
  std::vector<std::int64_t> steps;
  // A leg starts where the previous one ended: its end component from the previous strain end of that
  // component. A component a leg holds by a servo (or a constant volume) goes where only running tells.
  Vec6 strain = Vec6::Zero();
  std::array<bool, kComponents> strain_known = {true, true, true, true, true, true};
  bool known = true;
  if (from) from->clear();
  for (const Leg& leg : legs) {
    const LegEnd& e = leg.end;
    const bool on_strain = e.kind == LegEndKind::Strain;
    const bool start_known = known && (!on_strain || strain_known[static_cast<std::size_t>(e.axis)]);
    const double start = on_strain ? strain[e.axis] : 0.0;
    if (from) from->push_back(start_known ? start : std::numeric_limits<double>::quiet_NaN());
    const std::int64_t n = start_known || (known && !leg.ends_on_driven_strain()) ? leg_steps(leg, time_step, start) : -1;
    steps.push_back(n);
    if (n < 0) {
      known = false;
      continue;
    }
    for (int k = 0; k < kComponents; ++k) {
      strain[k] += n * leg.strain_per_step(k, time_step);
      const AxisControl& a = leg.axes[static_cast<std::size_t>(k)];
      if (!a.strain_driven() && a.mode != AxisMode::Held) strain_known[static_cast<std::size_t>(k)] = false;
    }
    if (on_strain && n != e.max_steps) strain[e.axis] = e.value, strain_known[static_cast<std::size_t>(e.axis)] = true;
  }
  return steps;
}

namespace {
StepRange add(StepRange a, StepRange b) {
  return {a.low + b.low, a.high < 0 || b.high < 0 ? -1 : a.high + b.high};
}
}  // namespace

std::vector<LegPlan> plan_legs(const ServoDef& servo, const std::vector<Leg>& legs, const std::vector<StepRange>& steps,
                               std::int64_t output_interval, double time_step) {
  std::vector<LegPlan> out;
  std::int64_t at = 0;  // the stage step where the leg starts; -1 once unknown
  for (std::size_t k = 0; k < legs.size(); ++k) {
    const Leg& leg = legs[k];
    LegPlan p;
    p.steps = steps[k];
    p.driving_increment = leg_driving_increment(leg, time_step);
    p.driving_rate = p.driving_increment / time_step;
    p.servo_cap = servo_cap(servo, leg, time_step);
    p.servo = leg_has_servo(leg);
    if (at >= 0 && p.steps.exact()) {
      const std::int64_t end = at + p.steps.low;
      // The interval's rows in (at, end], the leg's end row unless the interval wrote it, the stage's first row.
      p.rows = end / output_interval - at / output_interval + (end % output_interval != 0) + (k == 0);
      at = end;
    } else {
      at = -1;
    }
    out.push_back(p);
  }
  return out;
}

TestPlan plan_test(const Deck& deck, const TestDef& test) {
  TestPlan p;
  const Leg& first = test.legs.front();
  const double dt = deck.stage_time_step(test);
  p.strain_per_step = first.end_strain_per_step(dt);
  p.strain_rate = p.strain_per_step / dt;
  std::vector<StepRange> steps;
  const std::vector<std::int64_t> at_deck_rate = program_leg_steps(test.legs, dt);
  for (std::size_t k = 0; k < test.legs.size(); ++k) {
    const std::int64_t n = at_deck_rate[k];
    const std::optional<AdaptiveRate>& adaptive = test.legs[k].adaptive;
    if (n < 0) steps.push_back(StepRange{0, -1});
    else if (!adaptive) steps.push_back(StepRange{n, n});
    else  // between its fastest and its slowest rate (run/program.hpp adapted_rate_factor)
      steps.push_back(StepRange{static_cast<std::int64_t>(std::ceil(static_cast<double>(n) / adaptive->max_factor)),
                                static_cast<std::int64_t>(std::ceil(static_cast<double>(n) / adaptive->min_factor))});
  }
  p.legs = plan_legs(deck.stage_servo(test), test.legs, steps, test.output_interval, dt);
  for (const LegPlan& leg : p.legs) {
    if (leg.rows < 0) {
      p.steps = p.rows = -1;
      return p;
    }
    p.steps += leg.steps.low;
    p.rows += leg.rows;
  }
  return p;
}

double first_leg_stress(const TestDef& test) {
  double sum = 0.0;
  int n = 0;
  for (int k = 0; k < 3; ++k) {  // the normal axes (a shear target is no confining stress)
    const AxisControl& a = test.legs.front().axes[static_cast<std::size_t>(k)];
    if (a.mode == AxisMode::Stress || a.mode == AxisMode::MeanStress || a.mode == AxisMode::StressRamp)
      sum += a.value, ++n;  // a ramp's value is its start
  }
  return n ? sum / n : std::numeric_limits<double>::quiet_NaN();
}

double loading_rate(const Deck& deck, const TestDef& test) {
  double rate = 0.0;
  for (const Leg& leg : test.legs) rate = std::max(rate, leg_inertial_rate(leg, deck.stage_time_step(test)));
  return rate;
}

namespace {
double largest_radius(const SampleDef& sample) {
  return 0.5 * sample.largest_diameter();
}
}  // namespace

ContactStiffness reference_stiffness(const ContactDef& c, const SampleDef& sample) {
  const double r_eff = 0.5 * largest_radius(sample);  // R* of the two largest spheres
  const double a = std::sqrt(r_eff * c.reference_overlap);
  ContactStiffness k;
  k.normal = c.normal == NormalModel::Linear ? c.kn : 2.0 * c.effective_modulus() * a;
  k.tangential = c.tangential == TangentialModel::LinearHistory ? c.kt : 8.0 * c.effective_shear_modulus() * a;
  k.rolling = c.rolling == RollingModel::Sds ? c.rolling_stiffness : 0.0;
  return k;
}

double largest_deck_stress(const Deck& deck) {
  double p = 0.0;
  const auto scan = [&p](const std::vector<Leg>& legs) {
    for (const Leg& leg : legs) {
      for (int k = 0; k < 3; ++k) {  // the normal axes
        const AxisControl& a = leg.axes[static_cast<std::size_t>(k)];
        if (a.mode == AxisMode::Stress || a.mode == AxisMode::MeanStress || a.mode == AxisMode::StressRamp)
          p = std::max(p, std::abs(a.value));  // a ramp's start (its end, when a stress, is the leg's end below)
      }
      if (leg.end.kind == LegEndKind::Stress) p = std::max(p, std::abs(leg.end.value));
    }
  };
  if (deck.prepare) {
    p = std::max(p, deck.prepare->target_pressure);
    scan(deck.prepare->legs);
  }
  for (const TestDef& t : deck.tests) scan(t.legs);
  return p;
}

double mean_contact_force(const SampleDef& sample, double p) {
  const double d = mean_diameter(sample);
  return M_PI * d * d * p / kMeanContactZPhi;
}

double hertz_overlap(const ContactDef& c, double force, double r_eff) {
  return std::pow(3.0 * force / (4.0 * c.effective_modulus() * std::sqrt(r_eff)), 2.0 / 3.0);
}

double normal_overlap(const ContactDef& c, double force, double r_eff) {
  if (c.normal == NormalModel::Linear) return force / c.kn;
  return hertz_overlap(c, force, r_eff);
}

bool has_material_moduli(const ContactDef& c) { return key_used(keys::contact_youngs_modulus, c.selection()); }

std::optional<MeanContact> mean_contact(const Deck& deck) {
  MeanContact m;
  m.confining_stress = largest_deck_stress(deck);
  if (m.confining_stress == 0.0) return std::nullopt;
  const ContactDef& c = deck.contact;
  m.mean_diameter = mean_diameter(deck.sample);
  m.effective_radius = m.mean_diameter / 4.0;
  m.force = mean_contact_force(deck.sample, m.confining_stress);
  m.overlap = normal_overlap(c, m.force, m.effective_radius);
  m.secant_normal_stiffness = m.force / m.overlap;
  m.contact_radius = std::sqrt(m.effective_radius * m.overlap);
  m.mindlin_tangential_stiffness = has_material_moduli(c) ? 8.0 * c.effective_shear_modulus() * m.contact_radius : 0.0;
  return m;
}

double default_reference_overlap(const Deck& deck) {
  const double p = largest_deck_stress(deck);
  if (p == 0.0) return 0.0;
  const double force = 10.0 * mean_contact_force(deck.sample, 3.0 * p);
  return normal_overlap(deck.contact, force, 0.5 * largest_radius(deck.sample));
}

BodyProperties body_properties(double r, double density, const DampingDef& damping, const ContactStiffness& k) {
  BodyProperties b;
  b.volume = 4.0 / 3.0 * M_PI * r * r * r;
  b.mass = density * b.volume;
  b.inertia = 0.4 * b.mass * r * r;  // solid sphere
  b.translational_drag = damping.translational * 2.0 * std::sqrt(b.mass * k.normal);
  b.rotational_drag = damping.rotational * 2.0 * r * std::sqrt(b.inertia * k.tangential);
  return b;
}

namespace {
ModeLimit mode_limit(ContactMode mode, const char* name, const char* stiffness_name, double stiffness,
                     double omega2) {
  ModeLimit l{mode, name, stiffness_name, stiffness, std::sqrt(omega2), 0.0};
  l.time_step = omega2 > 0.0 ? std::sqrt(2.0 / omega2) : std::numeric_limits<double>::infinity();
  return l;
}

}  // namespace

std::string ModeLimit::describe() const {
  return std::string(name) + " mode: " + stiffness_name + " = " + fmt3(stiffness) +
         (mode == ContactMode::Twisting ? " N m/rad" : " N/m");
}

const ModeLimit& CriticalTimeStep::limiting() const {
  const ModeLimit* best = &modes[0];
  for (const ModeLimit& m : modes)
    if (m.time_step < best->time_step) best = &m;
  return *best;
}

CriticalTimeStep critical_time_steps(const SampleDef& sample, const ContactDef& contact) {
  const double r = 0.5 * sample.smallest_diameter();
  const double m = body_properties(r, sample.density, {}, {}).mass;  // two equal spheres of the smallest size
  const ContactStiffness k = reference_stiffness(contact, sample);
  const double r_eff = 0.5 * r;                                       // R* of the pair
  // The contact radius of the twisting spring: at the reference overlap of the two largest spheres (as the
  // reference stiffnesses), or its bound R* when the deck has none (linear laws).
  const double r_eff_max = 0.5 * largest_radius(sample);
  const double a2 = contact.reference_overlap > 0.0 ? r_eff_max * contact.reference_overlap : r_eff_max * r_eff_max;
  const double k_twist = contact.twisting == TwistingModel::Marshall ? 0.5 * k.tangential * a2 : 0.0;
  CriticalTimeStep c;
  c.modes[0] = mode_limit(ContactMode::Normal, "normal", "kn", k.normal, 2.0 * k.normal / m);
  c.modes[1] = mode_limit(ContactMode::TangentialRotational, "tangential-rotational", "kt", k.tangential,
                          7.0 * k.tangential / m);
  c.modes[2] = mode_limit(ContactMode::Rolling, "rolling", "k_roll", k.rolling,
                          5.0 * k.rolling * r_eff * r_eff / (m * r * r));
  c.modes[3] = mode_limit(ContactMode::Twisting, "twisting", "k_twist", k_twist, 5.0 * k_twist / (m * r * r));
  return c;
}

double network_time_step_estimate(const SampleDef& sample, const ContactDef& contact, const Friction& friction) {
  const CriticalTimeStep c = critical_time_steps(sample, contact);
  double pair = c.modes[0].time_step;
  if (friction.sliding > 0.0) pair = std::min({pair, c.modes[1].time_step, c.modes[3].time_step});
  if (friction.rolling > 0.0) pair = std::min(pair, c.modes[2].time_step);
  return kNetworkOverPairEstimate * std::sqrt(2.0) * pair;
}

double critical_time_step(const SampleDef& sample, const ContactDef& contact) {
  return critical_time_steps(sample, contact).value();
}

double bound_base(const TimeStepBound& bound, const CriticalTimeStep& limit) {
  return bound.of_normal_mode ? limit.modes[0].time_step : limit.value();
}

double suggested_time_step(const CriticalTimeStep& limit) {
  // a little under the normal mode's bound, since the message rounds the value it prints
  return std::min(kStableTimeStepFraction * limit.value(), 0.99 * kNormalModeFraction * limit.modes[0].time_step);
}

std::vector<TimeStepFinding> time_step_findings(double time_step, const CriticalTimeStep& limit) {
  std::vector<TimeStepFinding> out;
  for (const TimeStepBound& b : kTimeStepBounds) {
    const double base = bound_base(b, limit);
    if (!std::isfinite(base)) continue;  // no normal spring
    const double fraction = time_step / base;
    if (b.above ? !(fraction > b.fraction) : !(fraction < b.fraction)) continue;
    const ModeLimit& mode = b.of_normal_mode ? limit.modes[0] : limit.limiting();
    std::string msg = fmt3(time_step) + " s is " + fmt3(fraction) + " of " +
                      (b.of_normal_mode ? "the normal mode's limit " : "the stability limit ") + fmt3(base) + " s (" +
                      mode.describe() + "), " + (b.above ? "above " : "below ") + fmt3(b.fraction) + " of it: " + b.why;
    if (b.refuse && b.above) msg += "; use at most " + fmt3(suggested_time_step(limit)) + " s";
    else if (!b.refuse && b.above) msg += "; use at most " + fmt3(std::min(b.fraction * base, suggested_time_step(limit))) + " s";
    out.push_back({&b, std::move(msg)});
  }
  return out;
}

double skin_length(const Deck& deck) {
  return deck.neighbor_skin * deck.sample.largest_diameter();
}

double mean_diameter(const SampleDef& sample) {
  if (sample.grading) return SizeDistribution(*sample.grading).mean_power(1);
  double d_mean = 0.0;
  for (double d : sample.diameters) d_mean += d / static_cast<double>(sample.diameters.size());
  return d_mean;
}

double mean_sphere_volume(const SampleDef& sample) {
  if (sample.grading) return M_PI / 6.0 * SizeDistribution(*sample.grading).mean_power(3);
  double solid = 0.0;  // sizes are drawn with equal probability
  for (double d : sample.diameters) solid += M_PI / 6.0 * d * d * d / static_cast<double>(sample.diameters.size());
  return solid;
}

PreparationPlan plan_preparation(const Deck& deck, double start_solid_fraction) {
  PreparationPlan plan;
  if (!deck.prepare) return plan;
  const PrepareDef& prep = *deck.prepare;
  const EquilibriumDef& eq = prep.equilibrium;
  const double dt = deck.stage_time_step(prep);
  const SampleDef& s = deck.sample;
  int side = 1;  // the grid sample's (run/sample.cpp)
  while (static_cast<long long>(side) * side * side < s.count) ++side;
  const double solid = mean_sphere_volume(s);
  // The solid fraction at the stage's start (the grid sample's for the mean sphere volume: its drawn sizes make
  // it differ a little), and the axes' strains since then while the legs so far tell them.
  double reference = s.count * solid / std::pow(side * s.grid_spacing, 3);
  // A generated sample runs the deck's legs as they are; a loaded one may leave the fast leg out.
  plan.legs = prep.legs;
  if (start_solid_fraction > 0.0) {
    reference = start_solid_fraction;
    const PreparationProgram program = preparation_program(prep, reference);
    plan.legs = program.legs;
    plan.skipped = program.skipped;
  }
  Vec3 strain = Vec3::Zero();
  bool strain_known = true;
  for (const Leg& leg : plan.legs) {
    const LegEnd& e = leg.end;
    std::int64_t n = e.kind == LegEndKind::Steps || strain_known ? leg_steps(leg, dt, strain[e.axis]) : -1;
    const double d = leg.strain_per_step(0, dt);
    const bool isotropic = std::all_of(leg.axes.begin(), leg.axes.begin() + 3, [](const AxisControl& a) { return a.strain_driven(); }) &&
                           std::all_of(leg.axes.begin() + 3, leg.axes.end(), [](const AxisControl& a) { return a.mode == AxisMode::Held; }) &&
                           leg.strain_per_step(1, dt) == d && leg.strain_per_step(2, dt) == d;
    if (n < 0 && e.kind == LegEndKind::SolidFraction && isotropic && d > 0.0 && strain_known &&
        strain[1] == strain[0] && strain[2] == strain[0]) {
      // Every axis follows h = L (1 - (e0 + n d)) (cell/control.cpp), so the solid fraction after n steps is
      // reference / (1 - e0 - n d)^3: the leg ends at the first n where that reaches the end's.
      const double x = (1.0 - std::cbrt(reference / e.value) - strain[0]) / d;
      n = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(x * (1.0 - 1e-12))));
    }
    if (n >= 0) {
      plan.steps.push_back({n, n});
      for (int k = 0; k < 3; ++k) {
        if (!leg.axes[k].strain_driven()) strain_known = false;
        strain[k] += static_cast<double>(n) * leg.strain_per_step(k, dt);
      }
      if (e.kind == LegEndKind::Strain && n != e.max_steps) strain[e.axis] = e.value;
    } else if (e.kind == LegEndKind::Equilibrium) {
      plan.steps.push_back({eq.min_steps, e.max_steps > 0 ? e.max_steps : eq.max_steps});
      strain_known = false;
    } else {
      plan.steps.push_back({0, -1});
      strain_known = false;
    }
  }
  plan.listed = plan_legs(deck.stage_servo(prep), plan.legs, plan.steps, prep.output_interval, dt);
  return plan;
}

StepRange preparation_steps(const Deck& deck, double start_solid_fraction) {
  StepRange total;
  for (const StepRange& r : plan_preparation(deck, start_solid_fraction).steps) total = add(total, r);
  return total;
}

ProbePlan plan_probes(const TestDef& test) {
  ProbePlan p;
  if (!test.probes) return p;
  const ProbeDef& d = *test.probes;
  p.points = static_cast<std::int64_t>(d.at.size() + d.at_e1.size());
  const std::size_t directions = d.kind == ProbeKind::Strain ? 6 : d.plane == ProbePlane::List ? d.list.size()
                                                                                                 : static_cast<std::size_t>(d.directions);
  p.probes_per_point = 1 + static_cast<std::int64_t>(directions * d.magnitudes.size());
  p.steps_per_probe = 2 * (d.steps + d.hold_steps);
  p.check_probes_per_point = d.kind == ProbeKind::Stress ? 7 : 0;
  p.rest_steps_per_point = (d.rest_max_steps + p.steps_per_probe - 1) / p.steps_per_probe * p.steps_per_probe;
  return p;
}

StepRange test_steps(const Deck& deck, const TestDef& test) {
  const std::int64_t n = plan_test(deck, test).steps;
  return n >= 0 ? StepRange{n, n} : StepRange{0, -1};
}

RunEstimate estimate_run(const Deck& deck, double start_solid_fraction) {
  RunEstimate e;
  const double n = deck.sample.count;
  e.bytes = n * (kBytesPerParticle + (deck.contact.rotational_history() ? kRotationalBytesPerParticle : 0.0));
  e.preparation = preparation_steps(deck, start_solid_fraction);
  for (const TestDef& t : deck.tests) e.tests = add(e.tests, test_steps(deck, t));
  for (const TestDef& t : deck.tests) e.probe_steps += plan_probes(t).steps();
  const StepRange all = add(add(e.preparation, e.tests), StepRange{e.probe_steps, e.probe_steps});
  e.particle_steps_low = n * static_cast<double>(all.low);
  e.particle_steps_high = all.high < 0 ? -1.0 : n * static_cast<double>(all.high);
  return e;
}

}  // namespace celldem
