// What a deck implies before anything runs, computed in one place for the runner, the translator, the bench
// and `celldem plan` (which the Python tools ask instead of re-deriving): the steps and strain per step of a
// test, the rows it writes, the properties and damping coefficients of each particle, the stability limit
// of the time step and the neighbour skin.
#pragma once
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/types.hpp"

namespace celldem {

// Stage names the run directory uses itself; tests may not take them.
bool is_reserved_stage_name(const std::string& name);

// The preparation's default program: fast isotropic compression at fast_strain_increment to
// fast_solid_fraction, then the isotropic servo at target_pressure until equilibrium (or max_steps: error).
std::vector<Leg> preparation_legs(const PrepareDef& prepare);
// The legs the preparation runs from a start at `start_solid_fraction`: the deck's, except that the default
// program starts with its servo leg when the start already fills fast_solid_fraction (a fast leg there would
// end after no step). Its first leg's index in prepare.legs is `skipped` (0 or 1).
struct PreparationProgram {
  std::vector<Leg> legs;
  int skipped = 0;  // default legs left out at the start
};
PreparationProgram preparation_program(const PrepareDef& prepare, double start_solid_fraction);

// Steps of a leg that ends on a strain-driven axis's strain or on a step count, counted from the strain
// `from` of the end axis at the leg's start; -1 when only running the leg tells (a ratio or stress end, a
// strain reached by a stress-driven axis). Capped by end.max_steps.
std::int64_t leg_steps(const Leg& leg, double time_step, double from = 0.0);

// A leg that ends on the stress of a stress_ramp axis: the step at which the ramp's target reaches the end
// stress, ceil((end - from) / (rate dt)) (the run ends it when the measured stress does, within the servo's
// lag); -1 for any other leg.
std::int64_t ramp_target_steps(const Leg& leg, double time_step);

// The largest |strain per step| of the leg's strain-driven axes (0 when none drives it).
double leg_driving_increment(const Leg& leg, double time_step);
// The inertial number's strain-rate scale [1/s] of imposed strain rates `rate` (Voigt order: the normal rates e11,
// e22, e33 and the engineering shear rates g12, g13, g23; a component not driven by its strain counts 0): the
// deviatoric rate sqrt(3/2 e':e') = sqrt(((e11 - e22)^2 + (e22 - e33)^2 + (e33 - e11)^2) / 2 + 3/4 (g12^2 + g13^2
// + g23^2)), which is |e11| exactly with one driven axis (the axial tests: the scale they always had) and
// (sqrt 3 / 2) g for a simple shear g; a drive with no deviatoric part (an isotropic compression) its largest
// |normal rate| (docs/physics.md).
double inertial_strain_rate(const std::array<double, kComponents>& rate);
// The same of a leg's strain-driven axes at the deck's rate (strain increments over the time step, strain rates).
double leg_inertial_rate(const Leg& leg, double time_step);
// Whether a servo moves one of the leg's axes (stress, mean_stress or b).
bool leg_has_servo(const Leg& leg);
// The cap of the servo's strain per step in this leg: servo.max_strain_increment when the deck gives it, else
// max(kDefaultServoCap, kServoCapFactor x the leg's driving increment): a stress axis beside a driven one
// needs about 1 to 2 x the driving increment (its dilation), so the default cap follows the driving rate and
// a faster test does not saturate its servo. A leg with no driver (the preparation's servo) keeps 1e-6.
inline constexpr double kDefaultServoCap = 1e-6;
inline constexpr double kServoCapFactor = 10.0;
// rate_factor: an adaptive leg's factor on its deck rate (the cap follows the rate it runs at).
double servo_cap(const ServoDef& servo, const Leg& leg, double time_step, double rate_factor = 1.0);
// Below this multiple of the driving increment a leg's servo cannot follow (check and run refuse it).
inline constexpr double kMinServoCapRatio = 3.0;

// The steps of each leg of a program run from the test start (each strain leg from where the previous one
// left its end axis); -1 for a leg whose length only running tells, and for every leg after it. `from`, when
// given, receives each leg's starting strain of its end axis (NaN where unknown).
std::vector<std::int64_t> program_leg_steps(const std::vector<Leg>& legs, double time_step,
                                            std::vector<double>* from = nullptr);

// A range of steps: a leg that ends in equilibrium runs between its min_steps and max_steps; -1 where only
// running tells (a stress or ratio end).
struct StepRange {
  std::int64_t low = 0;
  std::int64_t high = 0;  // -1: unknown
  bool exact() const { return low == high; }
};

// One leg of a load program as `plan` lists it, a test's and the preparation's alike.
struct LegPlan {
  StepRange steps;                 // exact, a range (equilibrium), or high -1 where only running tells
  double driving_increment = 0.0;  // leg_driving_increment: the fastest strain-driven axis's |strain| per step
  double driving_rate = 0.0;       // the same per second [1/s]
  double servo_cap = 0.0;          // servo_cap: the servo's largest strain per step in this leg
  bool servo = false;              // leg_has_servo
  std::int64_t rows = -1;          // series rows the leg writes (the stage's first row counts in its first leg); -1: unknown
};
// The legs of a stage's program whose legs take `steps` (one range each). A stage writes a row at its start,
// at every output_interval-th stage step and at each leg's end (unless the interval has just written it), so a
// leg's rows are known while every leg up to it has an exact length.
// `servo` and `time_step` are the stage's (Deck::stage_servo, Deck::stage_time_step).
std::vector<LegPlan> plan_legs(const ServoDef& servo, const std::vector<Leg>& legs, const std::vector<StepRange>& steps,
                               std::int64_t output_interval, double time_step);

struct TestPlan {
  std::int64_t steps = 0;        // all legs; -1 when a leg's length is known only by running it
  double strain_per_step = 0.0;  // the first leg's end axis, per step (compression +)
  double strain_rate = 0.0;      // the same per second [1/s]
  std::int64_t rows = 0;         // series rows: the first, one per output interval, each leg's end (-1: unknown)
  std::vector<LegPlan> legs;     // plan_legs of the test's legs
};
TestPlan plan_test(const Deck& deck, const TestDef& test);
// The steps of a test's probes (tests[].probes) when the test reaches every point, at most: points x (the rest's
// budget + (the elastic check's seven probes of a stress set + the reference and each direction at each magnitude)
// x (two ramps and two holds)); 0 without probes.
struct ProbePlan {
  std::int64_t points = 0;
  std::int64_t probes_per_point = 0;  // the reference included
  std::int64_t check_probes_per_point = 0;  // a stress set's elastic check: its reference and six strain probes
  std::int64_t rest_steps_per_point = 0;    // the rest's budget
  std::int64_t steps_per_probe = 0;
  std::int64_t steps() const {
    return points * (rest_steps_per_point + (probes_per_point + check_probes_per_point) * steps_per_probe);
  }
};
ProbePlan plan_probes(const TestDef& test);

// The inertial number's strain-rate scale [1/s] of the test: the largest leg_inertial_rate over its legs.
double loading_rate(const Deck& deck, const TestDef& test);
// [Pa] the mean stress target of a test's first leg over its stress, mean_stress and stress_ramp axes (a ramp at
// its start): the stress of its planned inertial number. NaN when no axis holds a stress.
double first_leg_stress(const TestDef& test);

// The contact stiffnesses that set the time-step limit and the damping's critical values [N/m]: kn and kt of
// the linear laws; for hertz and mindlin the tangent stiffnesses 2 E* a and 8 G* a at the reference overlap of
// the two largest spheres (a = sqrt(R* overlap)); the rolling spring as given.
struct ContactStiffness {
  double normal = 0.0;
  double tangential = 0.0;
  double rolling = 0.0;
};
ContactStiffness reference_stiffness(const ContactDef& contact, const SampleDef& sample);

// The largest stress the deck names [Pa]: the preparation's target, stress and mean_stress axes, stress
// ends (0 when none).
double largest_deck_stress(const Deck& deck);
// The mean contact normal force [N] at mean stress p: pi d^2 p / (Z phi) with Z phi = kMeanContactZPhi (d the
// mean size). It is the mean stress of N_c = Z N / 2 contacts between N spheres in V, p = N_c <f l> / (3 V) =
// Z N <f l> / (6 V), with branch length l = d and N = phi V / (pi d^3 / 6): p = Z phi f / (pi d^2), at
// Z phi = 3.6 (Z about 6, phi about 0.6: a dense packing's).
inline constexpr double kMeanContactZPhi = 3.6;
double mean_contact_force(const SampleDef& sample, double p);
// The Hertz overlap [m] under normal force `force` between spheres of effective radius r_eff:
// (3 F / (4 E* sqrt(R*)))^(2/3), inverting F = 4/3 E* sqrt(R*) overlap^(3/2).
double hertz_overlap(const ContactDef& contact, double force, double r_eff);
// The overlap [m] under normal force `force` by the deck's normal law: F / kn (linear) or hertz_overlap.
double normal_overlap(const ContactDef& contact, double force, double r_eff);

// The mean contact under the deck's confining stress, largest_deck_stress() (the stress the reference overlap
// starts from): the mean contact force between two spheres of the mean diameter, its overlap by the deck's
// normal law, and the linear stiffnesses equivalent there (tools/sufficiency.py's hertz -> linear and
// mindlin -> linear_history switches).
struct MeanContact {
  double confining_stress = 0.0;    // [Pa] p, largest_deck_stress()
  double mean_diameter = 0.0;       // [m] d, mean_diameter()
  double effective_radius = 0.0;    // [m] R* = d / 4 of two spheres of diameter d
  double force = 0.0;               // [N] F = mean_contact_force(): pi d^2 p / (Z phi)
  double overlap = 0.0;             // [m] delta = normal_overlap(F, R*)
  double secant_normal_stiffness = 0.0;  // [N/m] F / delta
  double contact_radius = 0.0;      // [m] a = sqrt(R* delta)
  double mindlin_tangential_stiffness = 0.0;  // [N/m] 8 G* a; 0 when the law has no E and nu
};
// nullopt when the deck names no stress.
std::optional<MeanContact> mean_contact(const Deck& deck);
// Whether the law's stiffness follows the material (E, nu given: hertz, mindlin or mindlin_rescale), so that
// E* and G* (ContactDef::effective_modulus, effective_shear_modulus) are defined.
bool has_material_moduli(const ContactDef& contact);

// The default reference overlap [m]: the overlap of the two largest spheres under 10 times the mean contact
// force at 3 times the deck's largest stress (mean force pi d^2 p / (Z phi), Z phi = 3.6); 0 when the deck
// names no stress.
double default_reference_overlap(const Deck& deck);

// Mass, rotational inertia and body-damping coefficients of a solid sphere. Damping is a fraction of
// critical: c_t = translational 2 sqrt(m kn) on the fluctuating velocity, c_r = rotational 2 r sqrt(I kt) on
// the spin, with kn and kt from reference_stiffness().
struct BodyProperties {
  double volume = 0.0;             // [m^3]
  double mass = 0.0;               // [kg]
  double inertia = 0.0;            // [kg m^2]
  double translational_drag = 0.0; // c_t [kg/s]
  double rotational_drag = 0.0;    // c_r [kg m^2/s]
};
BodyProperties body_properties(double radius, double density, const DampingDef& damping,
                               const ContactStiffness& stiffness);

// The stability limit of the time step, per mode of a sticking contact between the two smallest spheres
// (equal, solid: mass m, radius r, inertia I = 0.4 m r^2), undamped, at the reference stiffnesses of
// reference_stiffness(). Each mode oscillates at omega; the leapfrog step is stable below 2/omega, and its
// limit here is t_c = sqrt(2)/omega (so the normal mode gives sqrt(m/kn), as before the other modes counted):
//   normal                 omega^2 = 2 kn / m                   (the relative normal motion, reduced mass m/2)
//   tangential-rotational  omega^2 = kt (1/mi + 1/mj + ri^2/Ii + rj^2/Ij) = 7 kt / m   (sliding and spinning
//                          together: both spheres take the same moment r ft, so the relative surface velocity
//                          dv - r (wi + wj) x n has this stiffness; the lever arm r bounds the contact point's)
//   rolling (sds)          omega^2 = k_roll R*^2 (1/Ii + 1/Ij) = 5 k_roll R*^2 / (m r^2) = 5 k_roll / (4 m)
//                          (the spring stretches by R* times the relative rotation and acts on the arm R*:
//                          a rotational spring k_roll R*^2 on wj - wi, R* = r / 2)
//   twisting (marshall)    omega^2 = k_tw (1/Ii + 1/Ij) = 5 k_tw / (m r^2), k_tw = 0.5 kt a^2 [N m/rad]
//                          (a: the contact radius at the reference overlap of the two largest spheres, or,
//                          with no reference overlap, the bound a = R* of those spheres)
// A mode the law does not have has no limit (+inf).
enum class ContactMode { Normal, TangentialRotational, Rolling, Twisting };
struct ModeLimit {
  ContactMode mode = ContactMode::Normal;
  const char* name = "";            // "normal", "tangential-rotational", "rolling", "twisting"
  const char* stiffness_name = "";  // "kn", "kt", "k_roll", "k_twist"
  double stiffness = 0.0;           // [N/m]; twisting [N m/rad]
  double omega = 0.0;               // [rad/s]; 0 when the law has no such spring
  double time_step = 0.0;           // sqrt(2)/omega [s]; +inf when omega is 0
  std::string describe() const;     // "tangential-rotational mode: kt = 1e+07 N/m"
};
struct CriticalTimeStep {
  std::array<ModeLimit, 4> modes;  // in ContactMode order
  const ModeLimit& limiting() const;  // the smallest limit (the first of equal ones)
  double value() const { return limiting().time_step; }
};
CriticalTimeStep critical_time_steps(const SampleDef& sample, const ContactDef& contact);
// critical_time_steps(...).value(): the time step's unit in every bound below.
double critical_time_step(const SampleDef& sample, const ContactDef& contact);

// The bounds of the time step, as fractions of critical_time_step; `check` and `run` apply them alike (the
// deck reader refuses, preflight warns) and `celldem plan` prints them.
// Refused above the stability limit of the stiffest mode.
inline constexpr double kMaxTimeStepFraction = 1.0;
// Warned above: the measured stability map (results/study, kt = kn) shows results drifting from about
// 0.55 sqrt(m/kn) and the packing boiling from 0.65 sqrt(m/kn); kt = kn limits at the tangential-rotational
// mode's sqrt(2m/(7kt)) = 0.5345 sqrt(m/kn), so the former warning at 0.5 sqrt(m/kn) is 0.935 of it.
inline constexpr double kStableTimeStepFraction = 0.93;
// Refused above this fraction of the normal mode's own limit sqrt(m/kn), whichever mode sets t_c: a pair is
// stable up to it, but a sphere pressed by several neighbours oscillates faster, and a packing boils from about
// 0.9 of it (measured with kt = kn/10, where the normal mode limits: docs/physics.md, the time-step sweep).
inline constexpr double kNormalModeFraction = 0.9;
// Warned below: the run takes many times the steps it needs.
inline constexpr double kSlowTimeStepFraction = 0.02;
// Refused below: a thousand times the steps it needs (a typo such as 1e-300 would otherwise spin for ever).
inline constexpr double kMinTimeStepFraction = 1e-3;

struct TimeStepBound {
  const char* name;  // "stability_limit", "stable_fraction", "slow", "minimum"
  bool refuse;       // refuse the deck (else warn)
  bool above;        // crossed when dt > fraction t_c (else when dt < fraction t_c)
  double fraction;   // of critical_time_step (of the normal mode's own limit with of_normal_mode)
  const char* why;
  bool of_normal_mode = false;
};
inline constexpr std::array<TimeStepBound, 5> kTimeStepBounds{{
    {"stability_limit", true, true, kMaxTimeStepFraction,
     "the leapfrog step is unstable for that mode of a sticking contact (2/omega = 1.41 t_c) and a packing's "
     "stiffer clusters fail earlier"},
    {"normal_mode", true, true, kNormalModeFraction,
     "a packing boils there although a pair is stable (measured on 300 spheres with kt = kn/10, where the normal "
     "mode limits: unbalanced force and kinetic energy jump from 0.9 of it; docs/physics.md)",
     true},
    {"stable_fraction", false, true, kStableTimeStepFraction,
     "results drift and the packing boils close to the limit (measured: with kt = kn, where the "
     "tangential-rotational mode limits, drift from 1.03 t_c and boiling from 1.2 t_c; with kt = kn/10, where "
     "the normal mode limits, boiling between 0.9 and 0.96 t_c)"},
    {"slow", false, false, kSlowTimeStepFraction, "the run takes many times the steps it needs"},
    {"minimum", true, false, kMinTimeStepFraction, "the run would take more than a thousand times the steps it needs"},
}};
// A bound the time step crosses, with the message that names the limiting mode, the value and the fraction.
struct TimeStepFinding {
  const TimeStepBound* bound;
  std::string message;  // "3e-06 s is 2.9 of the stability limit 1.03e-06 s (tangential-rotational mode: ...)"
};
std::vector<TimeStepFinding> time_step_findings(double time_step, const CriticalTimeStep& limit);
// The time step a bound is a fraction of: t_c, or the normal mode's own limit (+inf without a normal spring).
double bound_base(const TimeStepBound& bound, const CriticalTimeStep& limit);
// The largest time step the refusals suggest: under the warning close to t_c and under the normal mode's bound.
double suggested_time_step(const CriticalTimeStep& limit);

// The time step against the contact network's own limit 2/omega_max (measure/network_stiffness.hpp; judged by
// run/time_step_check on each stage's state, and on initial_state before a run; docs/physics.md). Warned above
// kNetworkWarnFraction of it: the margin kept as the fabric changes (the limit moved by up to 7 % within a test) and
// below where packings boil when the normal mode limits (about 1.0 of it). Refused above kNetworkRefuseFraction:
// every packing measured drifts or boils there (the paper's law, kt = kn, from 1.08 on 1000 spheres); between 1.0
// and it the sticking network is unstable and only its sliding contacts hold it.
inline constexpr double kNetworkWarnFraction = 0.9;
inline constexpr double kNetworkRefuseFraction = 1.1;
// Before a packing exists (--tolerance without a state), its network limit is estimated as this fraction of the pair
// formula's leapfrog limit 2/omega = sqrt(2) t_c (the modes a stage's friction keeps): the smallest ratio measured
// (the paper's prepared 8000 spheres with kt = kn: 0.454 / 0.756 = 0.600; kt = kn/10: 0.641; the suite's 300 spheres
// 0.606; normal springs only, a frictionless stage: see docs/physics.md).
inline constexpr double kNetworkOverPairEstimate = 0.600;
// That estimate [s] for a stage with `friction` (no tangential or twisting modes without sliding friction, no rolling
// mode without rolling friction).
double network_time_step_estimate(const SampleDef& sample, const ContactDef& contact, const Friction& friction);

// The neighbour-list skin in metres: neighbor_skin times the largest diameter.
double skin_length(const Deck& deck);

// [m] and [m^3] the mean diameter and sphere volume over the sizes a sphere draws: the listed sizes with
// equal probability, or a grading's number distribution (core/grading.hpp).
double mean_diameter(const SampleDef& sample);
double mean_sphere_volume(const SampleDef& sample);

// What a whole run costs, for `check` and `plan` before it starts, in StepRanges.
// The preparation's steps: an isotropic leg that ends on a solid fraction, such as the default program's fast
// compression, from the solid fraction where it starts (each axis at strain e0 + n d after n steps, so the
// fraction is the stage start's / (1 - e0 - n d)^3; the grid sample's from the mean sphere volume, a little
// off its drawn sizes'), then the servo leg's min_steps to max_steps; other legs as leg_steps() knows them,
// each strain end from the strain where the leg starts.
// With `start_solid_fraction` > 0 (a preparation from initial_state, as loaded and relaxed) the stage starts
// there (exact) instead of at the grid sample's.
StepRange preparation_steps(const Deck& deck, double start_solid_fraction = -1.0);
// The same leg by leg: the legs the preparation runs (preparation_program's from a loaded start) and each one's
// steps; preparation_steps is their sum. Empty without prepare.
struct PreparationPlan {
  std::vector<Leg> legs;
  std::vector<StepRange> steps;  // one per leg
  int skipped = 0;               // default legs left out at the start (preparation_program)
  std::vector<LegPlan> listed;   // plan_legs of them, at prepare.output_interval
};
PreparationPlan plan_preparation(const Deck& deck, double start_solid_fraction = -1.0);
StepRange test_steps(const Deck& deck, const TestDef& test);
// Memory and work of the run: about kBytesPerParticle per sphere (the arrays and the pair list at a packing's
// ~3 listed pairs per sphere, measured: 356-396 B at 8 k to 1 M spheres with the linear law; laws with
// rotational springs keep 28 B more per pair), and particle-steps over all stages.
inline constexpr double kBytesPerParticle = 400.0, kRotationalBytesPerParticle = 100.0;
// A conservative rate for the time estimate: one core of the 2-core development machine runs the paper's
// shear at 16 M particle-steps/s (README: Performance); other machines differ.
inline constexpr double kParticleStepsPerCoreSecond = 1.5e7;
struct RunEstimate {
  double bytes = 0.0;
  StepRange preparation;
  StepRange tests;                 // all tests together
  std::int64_t probe_steps = 0;    // all tests' probes, at most (plan_probes)
  double particle_steps_low = 0.0;
  double particle_steps_high = 0.0;  // negative: unknown
};
RunEstimate estimate_run(const Deck& deck, double start_solid_fraction = -1.0);

}  // namespace celldem
