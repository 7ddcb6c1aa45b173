// The deck: what a run is asked to do, as plain structs (SI units). io/deck_reader.cpp fills them from JSON;
// every default below comes from the key table in core/deck_schema.hpp, the single place that declares them.
#pragma once
#include <algorithm>
#include <cmath>
#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/deck_schema.hpp"
#include "core/grading.hpp"

namespace celldem {

// Bad input. The message names the JSON path of the offending key ("tests[1].axes.x2.stress: ...").
struct DeckError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline constexpr int kDeckFormatVersion = 1;

struct SampleDef {
  int count = 0;                   // number of spheres
  std::vector<double> diameters;   // [m] the listed sizes, each drawn with equal probability (empty with a grading)
  std::optional<GradingDef> grading;  // or sizes drawn from a grading curve (core/grading.hpp)
  double density = 0.0;            // [kg/m^3]
  std::uint64_t seed = static_cast<std::uint64_t>(keys::sample_seed.fallback);
  double grid_spacing = 0.0;       // [m] spacing of the initial cubic grid (> largest diameter)
  // [m] the smallest and largest sizes a sphere can get: of the list, or the grading's first and last sieve
  double smallest_diameter() const {
    return grading ? grading->sizes.front() : *std::min_element(diameters.begin(), diameters.end());
  }
  double largest_diameter() const {
    return grading ? grading->sizes.back() : *std::max_element(diameters.begin(), diameters.end());
  }
};

// The contact law: its sub-models and their parameters (contact/contact_law.hpp has the equations).
struct ContactDef {
  NormalModel normal = NormalModel::Linear;
  TangentialModel tangential = TangentialModel::LinearHistory;
  RollingModel rolling = RollingModel::None;
  TwistingModel twisting = TwistingModel::None;
  double kn = 0.0;                 // [N/m] normal spring (linear)
  double kt = 0.0;                 // [N/m] tangential spring (linear_history)
  double youngs_modulus = 0.0;     // [Pa] E (hertz, mindlin)
  double poisson_ratio = 0.0;      // [-] nu (hertz, mindlin)
  double rolling_stiffness = 0.0;  // [N/m] (sds)
  double rolling_damping = 0.0;    // [N s/m] (sds)
  double rolling_friction = 0.0;   // [-] the tests' default (sds)
  double reference_overlap = 0.0;  // [m] where hertz/mindlin stiffnesses set dt and damping (core/plan.hpp)
  TangentialRotation rotation = TangentialRotation::Rotate;
  MomentArm moment_arm = MomentArm::ContactPoint;
  // E* and G* of two spheres of this material.
  double effective_modulus() const { return youngs_modulus / (2.0 * (1.0 - poisson_ratio * poisson_ratio)); }
  double effective_shear_modulus() const {
    return youngs_modulus / (4.0 * (2.0 - poisson_ratio) * (1.0 + poisson_ratio));
  }
  bool rotational_history() const { return rolling != RollingModel::None || twisting != TwistingModel::None; }
  // The sub-model choices by their deck names (which keys they use: core/deck_schema.hpp's sub_models).
  SubModelSelection selection() const {
    return {name_of(normal, kNormalModelNames), name_of(tangential, kTangentialModelNames),
            name_of(rolling, kRollingModelNames), name_of(twisting, kTwistingModelNames)};
  }
  // The contact radius of each pair's last step is kept (mindlin_rescale).
  bool radius_history() const { return tangential == TangentialModel::MindlinRescale; }
};

// A number of the contact law, by its key. Whether a deck has it is the key table's rule (key_used on the
// key's sub_models), never restated: the reader fills, and the state files and summaries record, the ones the
// deck's choices use.
struct ContactParameter {
  const KeySpec* key;
  double ContactDef::*field;
  // A spring's stiffness or the elastic constants it follows: what a stored contact's spring means, so a
  // state file records it (state_physics) and a deck that continues the state must agree.
  bool elastic;
};
inline constexpr std::array<ContactParameter, 8> kContactParameters = {{
    {&keys::contact_kn, &ContactDef::kn, true},
    {&keys::contact_kt, &ContactDef::kt, true},
    {&keys::contact_youngs_modulus, &ContactDef::youngs_modulus, true},
    {&keys::contact_poisson_ratio, &ContactDef::poisson_ratio, true},
    {&keys::contact_rolling_stiffness, &ContactDef::rolling_stiffness, true},
    {&keys::contact_rolling_damping, &ContactDef::rolling_damping, false},
    {&keys::contact_rolling_friction, &ContactDef::rolling_friction, false},
    {&keys::contact_reference_overlap, &ContactDef::reference_overlap, false},
}};

// The friction coefficients of a stage: the sliders of the tangential and the rolling springs. A plain number
// converts to a sliding friction without rolling resistance.
struct Friction {
  Friction(double sliding_mu = 0.0, double rolling_mu = 0.0) : sliding(sliding_mu), rolling(rolling_mu) {}  // NOLINT
  double sliding;  // [-] mu
  double rolling;  // [-] mu_roll (with contact.rolling = sds)
};

struct DampingDef {
  double translational = 0.0;  // fraction of 2*sqrt(m*kn), on the fluctuating velocity
  double rotational = 0.0;     // fraction of 2*r*sqrt(I*kt), on the spin
};

// Stress servo (cell/control.hpp has the law).
struct ServoDef {
  double gain = keys::servo_gain.fallback;
  double integral_gain = keys::servo_integral_gain.fallback;
  double max_strain_increment = keys::servo_max_strain_increment.fallback;
  bool max_strain_increment_given = false;  // false: each leg's cap follows its driving rate (core/plan servo_cap)
};

struct AxisControl {
  AxisMode mode = AxisMode::Held;  // (a leg names every normal axis: Held is a shear axis it does not name)
  // StrainIncrement: per step [-]; StrainRate [1/s]; Stress, MeanStress [Pa]; B [-] (compression +);
  // StressRamp: the target at the leg start [Pa]; ConstantVolume: unused.
  double value = 0.0;
  double rate = 0.0;  // StressRamp: [Pa/s] the target moves by rate x (time since the leg start)
  bool strain_driven() const { return mode == AxisMode::StrainIncrement || mode == AxisMode::StrainRate; }
  bool stress_driven() const {
    return mode == AxisMode::Stress || mode == AxisMode::MeanStress || mode == AxisMode::B || mode == AxisMode::StressRamp;
  }
  // The stress target of a stress or stress_ramp axis at `leg_time` [s] after the leg start.
  double stress_target(double leg_time) const { return mode == AxisMode::StressRamp ? value + rate * leg_time : value; }
};

// A rotation of the principal stress axes at fixed principal values (the hollow-cylinder path) in one plane of
// the cell: its two normal axes and its shear axis are stress-controlled to the targets of principal values
// sigma1 (major) and sigma3 at the angle theta(t) = from + rate t of sigma1 from the plane's first axis towards
// its second (compression +; m = (sigma1 + sigma3)/2, r = (sigma1 - sigma3)/2):
//   s_ii = m + r cos 2 theta,  s_jj = m - r cos 2 theta,  s_ij = r sin 2 theta.
struct PrincipalRotation {
  int plane = 0;        // kPlaneNames: the shear axis of the plane, whose entries (kShearAxisEntries) are i, j
  double sigma1 = 0.0;  // [Pa]
  double sigma3 = 0.0;  // [Pa]
  double from = 0.0;    // [rad] theta at the leg start
  double rate = 0.0;    // [rad/s], or [rad] per step with per_step (angle_increment)
  bool per_step = false;
  // The angle theta at `leg_time` [s] after the leg start, and the targets s_ii, s_jj, s_ij there.
  double angle(double leg_time, double dt) const { return from + (per_step ? rate * (leg_time / dt) : rate * leg_time); }
  std::array<double, 3> targets(double leg_time, double dt) const;
};

// A leg's adaptive loading rate (tests[].adaptive_rate): every `check_interval` steps the leg's strain-driven
// axes run at `factor` times their deck rate, the factor raised while the measured quasi-static indicators sit
// well under their targets and lowered when one exceeds its target (run/program.cpp's adapt_rate has the rule).
struct AdaptiveRate {
  double min_factor = keys::adaptive_min_factor.fallback;  // the slowest, times the deck's rate (<= 1)
  double max_factor = keys::adaptive_max_factor.fallback;  // the fastest (>= 1)
  double unbalanced_force_ratio = keys::adaptive_unbalanced_force_ratio.fallback;  // target
  double kinetic_to_elastic = keys::adaptive_kinetic_to_elastic.fallback;          // target
  double inertial_number = keys::adaptive_inertial_number.fallback;  // ceiling: rate d_mean sqrt(rho / p)
  std::int64_t check_interval = static_cast<std::int64_t>(keys::adaptive_check_interval.fallback);  // [steps]
};

struct LegEnd {
  LegEndKind kind = LegEndKind::Strain;
  int axis = 0;                // Strain: the component (kComponentNames, 0-based); Stress: the normal axis
  double value = 0.0;          // Strain [-] relative to the test start; Ratio s11/s33; Stress [Pa];
                               // SolidFraction
  std::int64_t steps = 0;      // Steps: the leg's length
  std::int64_t max_steps = 0;  // a Strain leg ends here at the latest; any other leg that has not ended by
                               // then stops the run with an error (0: no limit)
};

// One leg of a load program: the axis controls, held until the end condition.
struct Leg {
  // The six components x1, x2, x3, x12, x13, x23 (kComponentNames). The normal axes are always named; a shear
  // axis is strain_increment, strain_rate or stress (a shear stress of either sign), or Held when the leg does
  // not name it (its tilt kept as it stands).
  std::array<AxisControl, kComponents> axes = {AxisControl{AxisMode::StrainIncrement}, AxisControl{AxisMode::StrainIncrement}, AxisControl{AxisMode::StrainIncrement},
                                               AxisControl{AxisMode::Held}, AxisControl{AxisMode::Held},
                                               AxisControl{AxisMode::Held}};
  LegEnd end;
  // A principal-axis rotation (rotate_principal_axes): its plane's two normal axes and its shear axis are Stress,
  // their values the targets at the leg start, and the targets move as PrincipalRotation says; the other two
  // shear axes are Stress at 0 (the principal axes stay in the plane).
  std::optional<PrincipalRotation> rotation;
  // The adaptive loading rate; none: the strain-driven axes keep the deck's rate.
  std::optional<AdaptiveRate> adaptive;
  // The strain per step of component k when the leg drives it by its strain (increments, or rates times the
  // time step), else 0.
  double strain_per_step(int k, double time_step) const {
    const AxisControl& a = axes[static_cast<std::size_t>(k)];
    return a.mode == AxisMode::StrainIncrement ? a.value : a.mode == AxisMode::StrainRate ? a.value * time_step : 0.0;
  }
  // The strain per step of the end's component when the leg ends on the strain of a component it drives, else 0.
  double end_strain_per_step(double time_step) const {
    return end.kind == LegEndKind::Strain ? strain_per_step(end.axis, time_step) : 0.0;
  }
  // Whether the leg ends on the strain of a component it drives by its strain: its steps are known from where it starts.
  bool ends_on_driven_strain() const {
    return end.kind == LegEndKind::Strain && axes[static_cast<std::size_t>(end.axis)].strain_driven();
  }
};

struct EquilibriumDef {
  double pressure_tolerance = keys::equilibrium_pressure_tolerance.fallback;
  double stress_tolerance = keys::equilibrium_stress_tolerance.fallback;
  double unbalanced_force_ratio = keys::equilibrium_unbalanced_force_ratio.fallback;
  std::int64_t min_steps = static_cast<std::int64_t>(keys::equilibrium_min_steps.fallback);
  std::int64_t check_interval = static_cast<std::int64_t>(keys::equilibrium_check_interval.fallback);
  std::int64_t max_steps = static_cast<std::int64_t>(keys::equilibrium_max_steps.fallback);
};

// When a stage writes particle and contact snapshots (none by default).
struct SnapshotDef {
  std::int64_t interval = 0;       // steps; 0: none by interval
  std::vector<double> e1;          // strains of axis 1 at which to write one, ascending
  SnapshotFormat format = SnapshotFormat::Binary;  // how the VTK files store their arrays
  bool any() const { return interval > 0 || !e1.empty(); }
};

struct PrepareDef {
  double friction = keys::prepare_friction.fallback;  // interparticle mu during preparation
  double rolling_friction = keys::prepare_rolling_friction.fallback;
  double target_pressure = 1e5;                       // [Pa] (required in a deck without legs)
  double fast_solid_fraction = keys::prepare_fast_solid_fraction.fallback;
  double fast_strain_increment = keys::prepare_fast_strain_increment.fallback;
  std::optional<double> servo_max_strain_increment;  // the preparation's own servo cap (Deck::stage_servo)
  double relax_overlaps = 0.0;  // with initial_state: largest overlap / smaller radius after the soft start; 0: none
  EquilibriumDef equilibrium;
  std::int64_t output_interval = static_cast<std::int64_t>(keys::prepare_output_interval.fallback);
  SnapshotDef snapshots;
  bool dynamic = false;  // not held to quasi-static (run/health.hpp)
  std::optional<double> time_step;  // [s] the stage's own time step; nullopt: the deck's (Deck::stage_time_step)
  Friction stage_friction() const { return {friction, rolling_friction}; }
  // The program; when a deck gives none, the two legs above: fast isotropic compression to the solid
  // fraction, then the isotropic servo at the target pressure to equilibrium (preparation_legs()).
  std::vector<Leg> legs;
  bool default_legs = true;  // legs are preparation_legs(): the fast leg is dropped when the start is denser
};

// A test's own rate check (tests[].verify_rate; run/verify_rate.hpp runs it).
struct VerifyRateDef {
  std::vector<double> rungs = {0.5, 0.25};  // the slower rungs' rates over the test's, descending
  int twins = 2;                            // runs at 1.001, 1.002 ... times the rate (0: none)
};

// A test's incremental response probes (tests[].probes; run/probes.hpp runs them).
struct ProbeDef {
  std::vector<std::string> at;  // named points, kProbePointNames
  std::vector<double> at_e1;    // points at strains of axis 1, ascending
  ProbeKind kind = ProbeKind::Stress;
  ProbePlane plane = ProbePlane::Rendulic;
  int directions = static_cast<int>(keys::probes_directions.fallback);
  std::vector<std::array<double, 3>> list;  // plane List: unit directions (ds11, ds22, ds33)
  std::vector<double> magnitudes;           // [Pa] stress, [-] strain; scaled: factors of the point's scale
  bool scaled = false;                      // magnitudes left out: they follow the point's stiffness
  std::int64_t steps = static_cast<std::int64_t>(keys::probes_steps.fallback);
  std::int64_t hold_steps = static_cast<std::int64_t>(keys::probes_hold_steps.fallback);
  double target_strain = keys::probes_target_strain.fallback;       // [-]
  double rest_fraction = keys::probes_rest_fraction.fallback;       // [-] of target_strain per probe's steps
  std::int64_t rest_max_steps = static_cast<std::int64_t>(keys::probes_rest_max_steps.fallback);
  double drift_limit = keys::probes_drift_limit.fallback;           // [-] of the smallest response
  double elastic_factor = keys::probes_elastic_factor.fallback;     // [-]
  double asymmetry_limit = keys::probes_asymmetry_limit.fallback;   // [-]
};

// A loading test: a load program of one or more legs from the prepared state.
struct TestDef {
  std::string name;
  double friction = 0.0;
  double rolling_friction = 0.0;  // contact.rolling_friction unless the test says
  std::vector<Leg> legs;
  EquilibriumDef equilibrium;  // legs that end in equilibrium: the test's keys, else the preparation's
  std::int64_t output_interval = static_cast<std::int64_t>(keys::test_output_interval.fallback);
  SnapshotDef snapshots;
  bool dynamic = false;  // not held to quasi-static (run/health.hpp)
  std::optional<VerifyRateDef> verify_rate;  // the deck asks for the rate check of this test
  std::optional<ProbeDef> probes;            // incremental response probes from points of the test
  std::optional<double> time_step;  // [s] the stage's own time step; nullopt: the deck's (Deck::stage_time_step)
  Friction stage_friction() const { return {friction, rolling_friction}; }
};

struct Deck {
  int format = kDeckFormatVersion;
  std::string source;                       // path it was read from (for reports)
  std::string canonical;                    // the deck as compact JSON (compared on --resume)
  SampleDef sample;
  ContactDef contact;
  DampingDef damping;
  Kinematics kinematics = Kinematics::Affine;
  double time_step = 0.0;                   // [s]
  ServoDef servo;
  ControlFailure control_failure = ControlFailure::Stop;
  std::int64_t checkpoint_interval = static_cast<std::int64_t>(keys::checkpoint_interval.fallback);
  double neighbor_skin = keys::neighbor_skin.fallback;  // fraction of the largest diameter
  bool energy_budget = false;                           // keep the energy budget in every stage (docs/energy.md)
  std::optional<PrepareDef> prepare;        // at least one of prepare / initial_state
  std::optional<std::string> initial_state; // path, relative to the deck's folder; with prepare: its start
  bool override_state_physics = false;      // run a state made with other physics (differences are warned)
  std::vector<TestDef> tests;
  // The deck's `tolerance` key as read; after io/tolerance resolved it (read_deck), the tolerance the deck was
  // rewritten for, with the resolved settings per stage as JSON text (the run's summary.json records them).
  std::optional<double> tolerance;
  std::string tolerance_settings;
  // The time step a stage runs with: its own (prepare.time_step, tests[].time_step), else the deck's. A test
  // that starts from a state made at another time step just continues: velocities and spins are physical.
  double stage_time_step(const PrepareDef& p) const { return p.time_step.value_or(time_step); }
  double stage_time_step(const TestDef& t) const { return t.time_step.value_or(time_step); }
  // The servo a stage runs with: the deck's, with the preparation's own cap when it gives one.
  ServoDef stage_servo(const PrepareDef& p) const {
    ServoDef s = servo;
    if (p.servo_max_strain_increment) s.max_strain_increment = *p.servo_max_strain_increment, s.max_strain_increment_given = true;
    return s;
  }
  const ServoDef& stage_servo(const TestDef&) const { return servo; }
};

inline std::array<double, 3> PrincipalRotation::targets(double leg_time, double dt) const {
  const double m = 0.5 * (sigma1 + sigma3), r = 0.5 * (sigma1 - sigma3), two_theta = 2.0 * angle(leg_time, dt);
  return {m + r * std::cos(two_theta), m - r * std::cos(two_theta), r * std::sin(two_theta)};
}

}  // namespace celldem
