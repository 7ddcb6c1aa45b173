// What a deck implies before anything runs, computed in one place for the runner, the translator, the bench
// and `celldem plan` (which the Python tools ask instead of re-deriving): the steps and strain per step of a
// test, the rows it writes, the properties and damping coefficients of each particle, the stability limit
// of the time step and the neighbour skin.
#pragma once
#include <cstdint>
#include <string>

#include "core/deck.hpp"
#include "core/types.hpp"

namespace celldem {

// Stage names the run directory uses itself; tests may not take them.
bool is_reserved_stage_name(const std::string& name);

// The preparation's default program: fast isotropic compression at fast_strain_increment to
// fast_solid_fraction, then the isotropic servo at target_pressure until equilibrium (or max_steps: error).
std::vector<Leg> preparation_legs(const PrepareDef& prepare);

// Steps of a leg that ends on a strain-driven axis's strain or on a step count, counted from the strain
// `from` of the end axis at the leg's start; -1 when only running the leg tells (a ratio or stress end, a
// strain reached by a stress-driven axis). Capped by end.max_steps.
std::int64_t leg_steps(const Leg& leg, double time_step, double from = 0.0);

// The largest |strain per step| of the leg's strain-driven axes (0 when none drives it).
double leg_driving_increment(const Leg& leg, double time_step);
// Whether a servo moves one of the leg's axes (stress, mean_stress or b).
bool leg_has_servo(const Leg& leg);
// The cap of the servo's strain per step in this leg: servo.max_strain_increment when the deck gives it, else
// max(kDefaultServoCap, kServoCapFactor x the leg's driving increment): a stress axis beside a driven one
// needs about 1 to 2 x the driving increment (its dilation), so the default cap follows the driving rate and
// a faster test does not saturate its servo. A leg with no driver (the preparation's servo) keeps 1e-6.
inline constexpr double kDefaultServoCap = 1e-6;
inline constexpr double kServoCapFactor = 10.0;
double servo_cap(const ServoDef& servo, const Leg& leg, double time_step);
// Below this multiple of the driving increment a leg's servo cannot follow (check and run refuse it).
inline constexpr double kMinServoCapRatio = 3.0;

// The steps of each leg of a program run from the test start (each strain leg from where the previous one
// left its end axis); -1 for a leg whose length only running tells, and for every leg after it. `from`, when
// given, receives each leg's starting strain of its end axis (NaN where unknown).
std::vector<std::int64_t> program_leg_steps(const std::vector<Leg>& legs, double time_step,
                                            std::vector<double>* from = nullptr);

struct TestPlan {
  std::int64_t steps = 0;        // all legs; -1 when a leg's length is known only by running it
  double strain_per_step = 0.0;  // the first leg's end axis, per step (compression +)
  double strain_rate = 0.0;      // the same per second [1/s]
  std::int64_t rows = 0;         // series rows: the first, one per output interval, and the last (-1: unknown)
};
TestPlan plan_test(const Deck& deck, const TestDef& test);

// The fastest strain rate [1/s] of the test's strain-driven axes over its legs (the inertial number's rate).
double loading_rate(const Deck& deck, const TestDef& test);

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
// The mean contact normal force [N] at mean stress p: pi d^2 p / (Z phi) with Z phi = 3.6 (d the mean size).
double mean_contact_force(const SampleDef& sample, double p);
// The Hertz overlap [m] under normal force `force` between spheres of effective radius r_eff.
double hertz_overlap(const ContactDef& contact, double force, double r_eff);

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

// The stable time step for the lightest particle, sqrt(m_min / k) with k the larger of the reference normal
// and rolling stiffnesses (no safety factor).
double critical_time_step(const SampleDef& sample, const ContactDef& contact);
// Above this fraction of critical_time_step the run is warned: the measured stability map (results/study)
// shows results drifting from about 0.55 of it and the packing boiling from 0.65 (kt ~ kn).
inline constexpr double kStableTimeStepFraction = 0.5;

// The neighbour-list skin in metres: neighbor_skin times the largest diameter.
double skin_length(const Deck& deck);

double mean_diameter(const SampleDef& sample);  // sizes are drawn with equal probability

}  // namespace celldem
