// Every deck key, declared once: its type, range, default, unit and meaning. The reader
// (io/deck_reader.cpp) takes range and default from here, the structs in core/deck.hpp their defaults,
// `celldem schema` prints the table (docs/deck.md's key table is generated from it), and the translator
// names keys through it.
#pragma once
#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <string_view>

#include "core/choices.hpp"

namespace celldem {

enum class KeyKind { Object, Number, Integer, String, Choice, Array, Boolean };

// A choice of a contact sub-model: the contact key that makes it ("normal", "tangential", "rolling",
// "twisting") and one of that key's choices; an empty choice stands for every one of them.
struct SubModelChoice {
  std::string_view sub_model;
  std::string_view choice;
};
// The sub-model choices that use a key, in table order; unused entries are empty.
using SubModelUses = std::array<SubModelChoice, 3>;
constexpr SubModelUses used_by(SubModelChoice a, SubModelChoice b = {}, SubModelChoice c = {}) { return {a, b, c}; }

struct KeySpec {
  std::string_view path;     // JSON path; "tests[]" stands for every test, "xK" for x1, x2 and x3,
                             // "xIJ" for the shear axes x12, x13 and x23
  KeyKind kind = KeyKind::Number;
  double min = -std::numeric_limits<double>::infinity();  // inclusive bounds (numbers and integers)
  double max = std::numeric_limits<double>::infinity();
  bool positive = false;     // strictly > 0
  bool required = true;      // missing = error (unless the meaning says when it may be left out)
  double fallback = 0.0;     // default of an optional number or integer
  std::string_view default_text = {};  // default as the table prints it, when it is not `fallback`
  std::span<const std::string_view> choices = {};  // KeyKind::Choice
  // The contact sub-model choices whose key this is (empty: a key of no sub-model). The reader refuses the key,
  // naming the choice it belongs to, when the deck makes none of them, and with `required_when_used` requires
  // it when the deck makes one; `celldem schema` prints both, and the tools take them from there.
  SubModelUses sub_models = {};
  bool required_when_used = false;
  std::string_view unit = {};
  std::string_view meaning = {};

  // The key's own name: the last component of the path.
  constexpr std::string_view name() const { return path.substr(path.rfind('.') + 1); }
};

namespace keys {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMaxCount = 1125899906842624.0;  // 2^50: counts of steps and rows
constexpr double kMaxSeed = 9007199254740992.0;   // 2^53: seeds a double still holds exactly
constexpr std::size_t kMaxTestNameLength = 64;     // a folder and file prefix: far below any NAME_MAX

// The choices whose stiffness follows the material (E, nu): Hertz's normal law and both Mindlin laws.
inline constexpr SubModelUses kMaterialLaws =
    used_by({"normal", "hertz"}, {"tangential", "mindlin"}, {"tangential", "mindlin_rescale"});

// clang-format off
inline constexpr KeySpec format{.path = "format", .kind = KeyKind::Integer, .min = 1, .max = 1000,
    .meaning = "deck format version (this celldem reads 1)"};
inline constexpr KeySpec description{.path = "description", .kind = KeyKind::String, .required = false,
    .default_text = "none", .meaning = "free text, for people"};

inline constexpr KeySpec sample{.path = "sample", .kind = KeyKind::Object,
    .meaning = "the spheres of a new sample (also required with `initial_state`: the state must agree with it)"};
inline constexpr KeySpec sample_count{.path = "sample.count", .kind = KeyKind::Integer, .min = 1, .max = 50'000'000,
    .meaning = "number of spheres"};
inline constexpr KeySpec sample_diameters{.path = "sample.diameters", .kind = KeyKind::Object,
    .meaning = "sizes: `list` or `min`/`max`/`count` (each sphere drawing one of them with equal probability), or "
               "`grading` (one of the three forms)"};
inline constexpr KeySpec sample_diameters_list{.path = "sample.diameters.list", .kind = KeyKind::Array,
    .required = false, .unit = "m", .meaning = "the sizes, each a finite number > 0"};
inline constexpr KeySpec sample_diameters_min{.path = "sample.diameters.min", .kind = KeyKind::Number,
    .positive = true, .required = false, .unit = "m", .meaning = "smallest of `count` evenly spaced sizes"};
inline constexpr KeySpec sample_diameters_max{.path = "sample.diameters.max", .kind = KeyKind::Number,
    .positive = true, .required = false, .unit = "m", .meaning = "largest size, >= `min`"};
inline constexpr KeySpec sample_diameters_count{.path = "sample.diameters.count", .kind = KeyKind::Integer,
    .min = 1, .max = 100000, .required = false, .meaning = "number of evenly spaced sizes (> 1 when max > min)"};
inline constexpr KeySpec sample_diameters_grading{.path = "sample.diameters.grading", .kind = KeyKind::Object,
    .required = false, .default_text = "none",
    .meaning = "a grading curve: percent passing `passing` at sieve sizes `sizes`, by mass or by number (`by`), "
               "linear in log d between sieves (the semi-log grading plot); each sphere's diameter is drawn by "
               "inverse transform of the number distribution it implies (by mass: the number density is the mass "
               "density / d^3), from `seed`. `celldem plan` and the report give the realised curve"};
inline constexpr KeySpec sample_diameters_grading_by{.path = "sample.diameters.grading.by", .kind = KeyKind::Choice,
    .default_text = "required with `grading`", .choices = kGradingBasisNames, .meaning = "what the percentages count: `mass` (a sieve curve) or `number`"};
inline constexpr KeySpec sample_diameters_grading_sizes{.path = "sample.diameters.grading.sizes",
    .kind = KeyKind::Array, .default_text = "required with `grading`", .unit = "m",
    .meaning = "sieve sizes, at least 2, each > 0, strictly increasing; the first and last bound every sphere"};
inline constexpr KeySpec sample_diameters_grading_passing{.path = "sample.diameters.grading.passing",
    .kind = KeyKind::Array, .default_text = "required with `grading`", .unit = "%",
    .meaning = "percent passing each size (one per size): non-decreasing from 0 at the first to 100 at the last"};
inline constexpr KeySpec sample_density{.path = "sample.density", .kind = KeyKind::Number, .positive = true,
    .unit = "kg/m^3", .meaning = "particle density"};
inline constexpr KeySpec sample_seed{.path = "sample.seed", .kind = KeyKind::Integer, .min = 0, .max = kMaxSeed,
    .required = false, .fallback = 1, .meaning = "sizes and the initial jitter depend on it only"};
inline constexpr KeySpec sample_grid_spacing{.path = "sample.grid_spacing", .kind = KeyKind::Number,
    .positive = true, .required = false, .default_text = "1.1 x largest diameter", .unit = "m",
    .meaning = "spacing of the initial cubic grid; refused unless it exceeds the largest diameter (a grading's "
               "largest size; the spheres would overlap)"};

inline constexpr KeySpec contact{.path = "contact", .kind = KeyKind::Object, .meaning = "the contact law"};
inline constexpr KeySpec contact_normal{.path = "contact.normal", .kind = KeyKind::Choice, .required = false,
    .choices = kNormalModelNames,
    .sub_models = used_by({"normal", ""}), .meaning = "normal law: `linear` (kn overlap) or `hertz` (4/3 E* sqrt(R*) overlap^3/2, from `youngs_modulus` "
               "and `poisson_ratio`)"};
inline constexpr KeySpec contact_tangential{.path = "contact.tangential", .kind = KeyKind::Choice, .required = false,
    .choices = kTangentialModelNames,
    .sub_models = used_by({"tangential", ""}), .meaning = "tangential spring: `linear_history` (kt), `mindlin` (8 G* a, a = sqrt(R* overlap)) or `mindlin_rescale` "
               "(mindlin, its displacement scaled by a / a_old whenever a shrinks, as LAMMPS's); Coulomb-capped. "
               "Neither Mindlin law is conservative: a spring stretched by xi at stiffness k1, stiffened to k2 by a "
               "larger overlap and let back returns 1/2 (k2 - k1) xi^2 more than it took (as LAMMPS documents for "
               "`mindlin`); `mindlin_rescale` does the same, since it rescales only while the contact unloads, where "
               "it makes the spring lose energy instead"};
inline constexpr KeySpec contact_rolling{.path = "contact.rolling", .kind = KeyKind::Choice, .required = false,
    .choices = kRollingModelNames,
    .sub_models = used_by({"rolling", ""}), .meaning = "rolling resistance: `none` or `sds` (spring-dashpot-slider on the rolling displacement, as LAMMPS "
               "`rolling sds`)"};
inline constexpr KeySpec contact_twisting{.path = "contact.twisting", .kind = KeyKind::Choice, .required = false,
    .choices = kTwistingModelNames,
    .sub_models = used_by({"twisting", ""}), .meaning = "twisting resistance: `none` or `marshall` (0.5 kt a^2, capped at 2/3 a mu fn, as LAMMPS `twisting "
               "marshall`)"};
inline constexpr KeySpec contact_kn{.path = "contact.kn", .kind = KeyKind::Number, .positive = true,
    .required = false, .default_text = "required with `normal: linear`",
    .sub_models = used_by({"normal", "linear"}), .required_when_used = true, .unit = "N/m",
    .meaning = "normal spring stiffness"};
inline constexpr KeySpec contact_kt{.path = "contact.kt", .kind = KeyKind::Number, .min = 0, .required = false,
    .default_text = "required with `tangential: linear_history`",
    .sub_models = used_by({"tangential", "linear_history"}), .required_when_used = true, .unit = "N/m",
    .meaning = "tangential spring stiffness"};
inline constexpr KeySpec contact_youngs_modulus{.path = "contact.youngs_modulus", .kind = KeyKind::Number,
    .positive = true, .required = false, .default_text = "required with `hertz`, `mindlin`, `mindlin_rescale`",
    .sub_models = kMaterialLaws, .required_when_used = true, .unit = "Pa",
    .meaning = "Young's modulus E of the particles (E* = E / (2 (1 - nu^2)))"};
inline constexpr KeySpec contact_poisson_ratio{.path = "contact.poisson_ratio", .kind = KeyKind::Number, .min = 0,
    .max = 0.49, .required = false, .default_text = "required with `hertz`, `mindlin`, `mindlin_rescale`",
    .sub_models = kMaterialLaws, .required_when_used = true, .meaning = "Poisson's ratio nu of the particles (G* = E / (4 (2 - nu) (1 + nu)))"};
inline constexpr KeySpec contact_rolling_stiffness{.path = "contact.rolling_stiffness", .kind = KeyKind::Number,
    .positive = true, .required = false, .default_text = "required with `rolling: sds`",
    .sub_models = used_by({"rolling", "sds"}), .required_when_used = true, .unit = "N/m",
    .meaning = "rolling spring: force -k_roll xi_roll, its moment R* n x f_roll"};
inline constexpr KeySpec contact_rolling_damping{.path = "contact.rolling_damping", .kind = KeyKind::Number,
    .min = 0, .required = false, .fallback = 0.0, .sub_models = used_by({"rolling", "sds"}), .unit = "N s/m",
    .meaning = "rolling dashpot on the rolling velocity (LAMMPS's gamma_roll)"};
inline constexpr KeySpec contact_rolling_friction{.path = "contact.rolling_friction", .kind = KeyKind::Number,
    .min = 0, .max = 1e3, .required = false, .default_text = "required with `rolling: sds`",
    .sub_models = used_by({"rolling", "sds"}), .required_when_used = true, .meaning = "rolling slider: |f_roll| <= mu_roll fn in every test (`tests[].rolling_friction` overrides)"};
inline constexpr KeySpec contact_reference_overlap{.path = "contact.reference_overlap", .kind = KeyKind::Number,
    .positive = true, .required = false,
    .default_text = "overlap under 10 x the mean contact force at 3 x the deck's largest stress",
    .sub_models = kMaterialLaws, .unit = "m",
    .meaning = "hertz/mindlin: the overlap whose stiffnesses set the time-step limit and the damping's critical "
               "values (the largest expected)"};
inline constexpr KeySpec contact_tangential_rotation{.path = "contact.tangential_rotation", .kind = KeyKind::Choice,
    .required = false, .choices = kTangentialRotationNames, .sub_models = used_by({"tangential", ""}),
    .meaning = "when the tangent plane turns, `rotate` the spring keeping its length (as LAMMPS pair granular's "
               "`linear_history` and `mindlin`, which do it once the spring's normal part exceeds 1e-10 of the "
               "Coulomb limit), or `project` it (as LAMMPS gran/hooke/history, gran/hertz/history and LIGGGHTS's "
               "tangential history)"};
inline constexpr KeySpec contact_moment_arm{.path = "contact.moment_arm", .kind = KeyKind::Choice,
    .required = false, .choices = kMomentArmNames, .sub_models = used_by({"tangential", ""}),
    .meaning = "lever arm of the tangential force and of the spin in the slip: `contact_point` (r - overlap/2, as "
               "LIGGGHTS) or `radius` (as LAMMPS gran/hooke/history and gran/hertz/history); LAMMPS pair granular "
               "matches neither (full radii in the slip, r - overlap/2 for the moment)"};

inline constexpr KeySpec damping{.path = "damping", .kind = KeyKind::Object, .meaning = "body damping"};
inline constexpr KeySpec damping_translational{.path = "damping.translational", .kind = KeyKind::Number, .min = 0,
    .max = 10, .meaning = "fraction of 2 sqrt(m kn), on the fluctuating velocity"};
inline constexpr KeySpec damping_rotational{.path = "damping.rotational", .kind = KeyKind::Number, .min = 0,
    .max = 10, .meaning = "fraction of 2 r sqrt(I kt), on the spin"};

inline constexpr KeySpec kinematics{.path = "kinematics", .kind = KeyKind::Choice, .required = false,
    .choices = kKinematicsNames,
    .meaning = "`affine`: contacts see the affine velocity difference between periodic images; `lammps`: they do "
               "not (as LAMMPS/LIGGGHTS with `fix deform remap x`)"};
// The bounds' fractions are core/plan.hpp's kTimeStepBounds (which this header cannot include); test_core's
// TimeStepBounds test fails when this text and that table disagree.
inline constexpr KeySpec time_step{.path = "time_step", .kind = KeyKind::Number, .positive = true, .unit = "s",
    .meaning = "refused above the stability limit t_c (the smallest over the contact's normal, tangential-rotational, "
               "rolling and twisting modes: `celldem plan`), above 0.9 t_c(normal) (the normal mode's own limit "
               "sqrt(m/kn), where packings boil) and below 1e-3 t_c; warned about above 0.93 t_c and below 0.02 t_c; against the "
               "contact network's own limit 2/omega_max (each stage's starting state, and initial_state before a run): "
               "warned about above 0.9 of it, refused above 1.1"};

inline constexpr KeySpec tolerance{.path = "tolerance", .kind = KeyKind::Number, .positive = true, .required = false,
    .default_text = "none (the deck as written)", .unit = "noise floors",
    .meaning = "ask for a mean over seeds within this many seed-to-seed noise floors of this deck's size of the "
               "quasi-static answer (I -> 0), whatever rate the deck is written at: the strain-driven legs run at the "
               "inertial number where the fitted rate bias laws (at their 95 % upper bound) reach T floors, slowed or "
               "sped up from the deck's (the cell's actual I, predicted per path and checked after each test: "
               "summary.json tests.<test>.tolerance); time steps, preparation schedule and output intervals follow the rules "
               "(io/time_to_answer_rules.json; one run adds its own seed-to-seed scatter; `celldem plan --tolerance` "
               "shows the distance of the deck as written and the cost); `run --tolerance` overrides it"};

inline constexpr KeySpec servo{.path = "servo", .kind = KeyKind::Object, .required = false,
    .default_text = "defaults", .meaning = "the stress servo (docs/physics.md: Mixed control)"};
inline constexpr KeySpec servo_gain{.path = "servo.gain", .kind = KeyKind::Number, .min = 0, .max = 1,
    .required = false, .fallback = 0.05, .meaning = "fraction of the stress error one affine step removes"};
inline constexpr KeySpec servo_integral_gain{.path = "servo.integral_gain", .kind = KeyKind::Number, .min = 0,
    .max = 1, .required = false, .fallback = 0.002,
    .meaning = "per step, fraction of the accumulated error added back (not both gains 0)"};
inline constexpr KeySpec servo_max_strain_increment{.path = "servo.max_strain_increment", .kind = KeyKind::Number,
    .min = 1e-12, .max = 1e-2, .required = false, .fallback = 1e-6,
    .default_text = "per leg: max(1e-6, 10 x the leg's largest strain per step of a strain-driven axis)",
    .meaning = "cap of a stress-driven axis's strain per step; a stress axis needs about 1 to 2 x the driving "
               "strain per step, so `check` and `run` refuse a cap below 3 x it in a leg with servo axes"};
inline constexpr KeySpec control_failure{.path = "control_failure", .kind = KeyKind::Choice, .required = false,
    .choices = kControlFailureNames,
    .meaning = "a control that stays outside its tolerance after a leg's first 0.2 % of driving strain: `stop` the "
               "stage (exit 1), or `warn` and mark the test `\"controlled\": false` in summary.json"};

inline constexpr KeySpec neighbor_skin{.path = "neighbor_skin", .kind = KeyKind::Number, .min = 1e-4, .max = 1,
    .required = false, .fallback = 0.01,
    .meaning = "neighbour-list skin as a fraction of the largest diameter; changes speed only, never results"};
inline constexpr KeySpec checkpoint_interval{.path = "checkpoint_interval", .kind = KeyKind::Integer, .min = 1,
    .max = kMaxCount, .required = false, .fallback = 100000, .meaning = "steps between checkpoints"};

inline constexpr KeySpec energy_budget{.path = "energy_budget", .kind = KeyKind::Boolean, .required = false,
    .default_text = "false",
    .meaning = "`true`: keep every stage's energy budget (boundary work, stored, kinetic, friction and damping, the "
               "closure error: the series' energy_* columns, summary.json's `energy`, docs/energy.md); it costs "
               "the pair loop its shear sums and the dissipation sums, so it is kept only when asked"};

inline constexpr KeySpec prepare{.path = "prepare", .kind = KeyKind::Object, .required = false,
    .default_text = "none",
    .meaning = "make a sample: fast strain-controlled compression, then the servo to equilibrium; from a new grid "
               "sample, or with `initial_state` from that state (at least one of `prepare` and `initial_state`)"};
inline constexpr KeySpec prepare_friction{.path = "prepare.friction", .kind = KeyKind::Number, .min = 0, .max = 1e3,
    .required = false, .fallback = 0.0, .meaning = "interparticle friction coefficient while preparing"};
inline constexpr KeySpec prepare_rolling_friction{.path = "prepare.rolling_friction", .kind = KeyKind::Number,
    .min = 0, .max = 1e3, .required = false, .fallback = 0.0, .sub_models = used_by({"rolling", "sds"}),
    .meaning = "rolling friction coefficient while preparing (with `contact.rolling: sds`)"};
inline constexpr KeySpec prepare_target_pressure{.path = "prepare.target_pressure", .kind = KeyKind::Number,
    .positive = true, .required = false, .default_text = "required without `legs`", .unit = "Pa",
    .meaning = "isotropic stress of the prepared sample"};
inline constexpr KeySpec prepare_fast_solid_fraction{.path = "prepare.fast_solid_fraction", .kind = KeyKind::Number,
    .min = 0.01, .max = 0.6, .required = false, .fallback = 0.45,
    .meaning = "strain-controlled compression up to this solid fraction"};
inline constexpr KeySpec prepare_fast_strain_increment{.path = "prepare.fast_strain_increment",
    .kind = KeyKind::Number, .min = 1e-9, .max = 1e-2, .required = false, .fallback = 2e-5,
    .meaning = "strain per step and axis in the fast phase"};
inline constexpr KeySpec prepare_relax_overlaps{.path = "prepare.relax_overlaps", .kind = KeyKind::Number,
    .max = 0.05, .positive = true, .required = false, .default_text = "none",
    .meaning = "with `initial_state`: a soft start for an imported sample whose spheres overlap; the cell is first "
               "dilated (scaled isotropically, scaled positions kept) by the smallest factor that brings every "
               "overlap to at most this fraction of the smaller radius, and the preparation compresses it back. "
               "Without it, overlaps beyond 0.05 of the smaller radius are refused"};
inline constexpr KeySpec prepare_time_step{.path = "prepare.time_step", .kind = KeyKind::Number, .positive = true,
    .required = false, .default_text = "`time_step`", .unit = "s",
    .meaning = "the preparation's own time step, with the bounds of `time_step` (`check` and `plan` give its fraction "
               "of the stability limit)"};
inline constexpr KeySpec prepare_servo_max_strain_increment{.path = "prepare.servo_max_strain_increment",
    .kind = KeyKind::Number, .min = 1e-12, .max = 1e-2, .required = false,
    .default_text = "`servo.max_strain_increment`'s rule",
    .meaning = "the preparation's own cap of a stress-driven axis's strain per step: its isotropic servo compresses "
               "a loose packing at this cap until the contacts stiffen, so the cap sets how long that takes "
               "(`--tolerance` keeps its strain rate, cap / time step, when it raises the preparation's time step)"};
inline constexpr KeySpec prepare_output_interval{.path = "prepare.output_interval", .kind = KeyKind::Integer,
    .min = 1, .max = kMaxCount, .required = false, .fallback = 1000, .meaning = "steps between series rows"};
inline constexpr KeySpec prepare_equilibrium{.path = "prepare.equilibrium", .kind = KeyKind::Object,
    .required = false, .default_text = "defaults",
    .meaning = "when the servo stage ends (docs/physics.md: Preparation)"};
inline constexpr KeySpec equilibrium_pressure_tolerance{.path = "prepare.equilibrium.pressure_tolerance",
    .kind = KeyKind::Number, .min = 1e-9, .max = 1, .required = false, .fallback = 0.005,
    .meaning = "|p - target| / target"};
inline constexpr KeySpec equilibrium_stress_tolerance{.path = "prepare.equilibrium.stress_tolerance",
    .kind = KeyKind::Number, .min = 1e-9, .max = 1, .required = false, .fallback = 0.005,
    .meaning = "every axis: |s_kk - target| / target"};
inline constexpr KeySpec equilibrium_unbalanced_force_ratio{.path = "prepare.equilibrium.unbalanced_force_ratio",
    .kind = KeyKind::Number, .min = 1e-12, .max = 1, .required = false, .fallback = 1e-3,
    .meaning = "mean |net contact force| / mean contact normal force"};
inline constexpr KeySpec equilibrium_min_steps{.path = "prepare.equilibrium.min_steps", .kind = KeyKind::Integer,
    .min = 0, .max = kMaxCount, .required = false, .fallback = 20000, .meaning = "servo steps at least"};
inline constexpr KeySpec equilibrium_check_interval{.path = "prepare.equilibrium.check_interval",
    .kind = KeyKind::Integer, .min = 1, .max = kMaxCount, .required = false, .fallback = 1000,
    .meaning = "servo steps between checks"};
inline constexpr KeySpec equilibrium_max_steps{.path = "prepare.equilibrium.max_steps", .kind = KeyKind::Integer,
    .min = 1, .max = kMaxCount, .required = false, .fallback = 2000000,
    .meaning = "servo steps before the run stops with an error"};

inline constexpr KeySpec prepare_legs{.path = "prepare.legs", .kind = KeyKind::Array, .required = false,
    .default_text = "fast compression, then the servo",
    .meaning = "instead of the two default legs: a load program as in `tests[].legs`, whose legs may also end on "
               "`solid_fraction`, and end on `equilibrium` by `prepare.equilibrium` (`target_pressure` and the fast "
               "keys are then not used)"};
inline constexpr KeySpec end_solid_fraction{.path = "prepare.legs[].end.solid_fraction", .kind = KeyKind::Number,
    .min = 0.01, .max = 0.9, .required = false, .default_text = "-",
    .meaning = "the leg ends when the spheres fill this fraction of the cell"};
inline constexpr KeySpec end_equilibrium{.path = "prepare.legs[].end.equilibrium", .kind = KeyKind::Boolean,
    .required = false, .default_text = "-",
    .meaning = "`true`: the leg ends in equilibrium (`prepare.equilibrium`) at its stress targets"};

inline constexpr KeySpec initial_state{.path = "initial_state", .kind = KeyKind::String, .required = false,
    .default_text = "none",
    .meaning = "the sample to test (path relative to the deck), or with `prepare` the state the preparation starts "
               "from: a celldem state file or a LAMMPS data file (`atom_style sphere`, orthogonal box, one density equal to `sample.density`; no "
               "contact history)"};
inline constexpr KeySpec override_state_physics{.path = "override_state_physics", .kind = KeyKind::Boolean,
    .required = false, .default_text = "false",
    .meaning = "`true`: run (or prepare) an `initial_state` with the deck's density and contact law although the state was made "
               "with others (the run's warnings and summary list each difference); otherwise a difference is an error"};

inline constexpr KeySpec tests{.path = "tests", .kind = KeyKind::Array, .required = false, .default_text = "[]",
    .meaning = "loading tests, each from the prepared state (at least one without `prepare`)"};
inline constexpr KeySpec test_name{.path = "tests[].name", .kind = KeyKind::String,
    .meaning = "letters, digits, `_` or `-`, at most 64; unique; not `prepare`"};
inline constexpr KeySpec test_friction{.path = "tests[].friction", .kind = KeyKind::Number, .min = 0, .max = 1e3,
    .meaning = "interparticle friction coefficient"};
inline constexpr KeySpec test_rolling_friction{.path = "tests[].rolling_friction", .kind = KeyKind::Number,
    .min = 0, .max = 1e3, .required = false, .default_text = "`contact.rolling_friction`",
    .sub_models = used_by({"rolling", "sds"}), .meaning = "rolling friction coefficient of this test (with `contact.rolling: sds`)"};
inline constexpr KeySpec test_legs{.path = "tests[].legs", .kind = KeyKind::Array, .required = false,
    .default_text = "one leg: `axes`, `end`",
    .meaning = "instead of `axes` and `end`: a load program, legs `{\"axes\", \"end\"}` run in order, each from where "
               "the previous one ended, or blocks `{\"repeat\": n, \"legs\": [...]}`"};
inline constexpr KeySpec leg_repeat{.path = "tests[].legs[].repeat", .kind = KeyKind::Integer, .min = 1,
    .max = 100000, .required = false, .default_text = "-", .meaning = "times the block's `legs` run in a row"};
inline constexpr KeySpec test_axes{.path = "tests[].axes", .kind = KeyKind::Object,
    .meaning = "`x1`, `x2`, `x3`: each exactly one of the controls below; the shear axes `x12`, `x13`, `x23` "
               "optional (`xIJ` below; an axis left out keeps its tilt)"};
inline constexpr KeySpec axis_strain_increment{.path = "tests[].axes.xK.strain_increment", .kind = KeyKind::Number,
    .min = -0.01, .max = 0.01, .required = false, .default_text = "-",
    .meaning = "engineering strain per step relative to the test start, compression +"};
inline constexpr KeySpec axis_strain_rate{.path = "tests[].axes.xK.strain_rate", .kind = KeyKind::Number,
    .min = -1e6, .max = 1e6, .required = false, .default_text = "-", .unit = "1/s",
    .meaning = "engineering strain rate, compression +"};
inline constexpr KeySpec axis_stress{.path = "tests[].axes.xK.stress", .kind = KeyKind::Number, .positive = true,
    .required = false, .default_text = "-", .unit = "Pa", .meaning = "servo-controlled stress, compression +"};
inline constexpr KeySpec axis_b{.path = "tests[].axes.xK.b", .kind = KeyKind::Number, .min = 0, .max = 1,
    .required = false, .default_text = "-",
    .meaning = "servo to s_minor + b (s_major - s_minor): s_major of the one strain-driven axis, s_minor of the one "
               "other stress-driven axis"};
inline constexpr KeySpec axis_mean_stress{.path = "tests[].axes.xK.mean_stress", .kind = KeyKind::Number,
    .positive = true, .required = false, .default_text = "-", .unit = "Pa",
    .meaning = "servo so that the mean stress stays at this value (the same on every such axis; with a `b` axis, "
               "b and p are held together)"};
inline constexpr KeySpec axis_constant_volume{.path = "tests[].axes.xK.constant_volume", .kind = KeyKind::Boolean,
    .required = false, .default_text = "-",
    .meaning = "`true`: the axis's strain keeps the cell volume at the leg's start (equal strains on two such axes)"};
inline constexpr KeySpec axis_stress_ramp{.path = "tests[].axes.xK.stress_ramp", .kind = KeyKind::Object,
    .required = false, .default_text = "-",
    .meaning = "servo-controlled stress whose target moves during the leg: `from` + `rate` t, t the time since the "
               "leg start (not beside `b` or `mean_stress` axes; relative error as `stress`)"};
inline constexpr KeySpec axis_stress_ramp_from{.path = "tests[].axes.xK.stress_ramp.from", .kind = KeyKind::Number,
    .positive = true, .unit = "Pa",
    .meaning = "the target at the leg start, compression + (the stress the axis holds there, or the servo chases "
               "the difference)"};
inline constexpr KeySpec axis_stress_ramp_rate{.path = "tests[].axes.xK.stress_ramp.rate", .kind = KeyKind::Number,
    .min = -1e15, .max = 1e15, .unit = "Pa/s",
    .meaning = "the target's rate, non-zero (negative: unloading; the run stops if the target falls to 0)"};
inline constexpr KeySpec shear_axis_strain_increment{.path = "tests[].axes.xIJ.strain_increment",
    .kind = KeyKind::Number, .min = -0.01, .max = 0.01, .required = false, .default_text = "-",
    .meaning = "engineering shear strain per step, g_ij = -(h_ij - h_ij(start)) / h_jj(start) (the tilt xy, xz or yz "
               "over the stage-start length of axis j; sign: a positive g_ij raises the compression-signed s_ij), "
               "relative to the test start; exactly one of `strain_increment`, `strain_rate`, `stress` per shear axis"};
inline constexpr KeySpec shear_axis_strain_rate{.path = "tests[].axes.xIJ.strain_rate", .kind = KeyKind::Number,
    .min = -1e6, .max = 1e6, .required = false, .default_text = "-", .unit = "1/s",
    .meaning = "engineering shear strain rate dg_ij/dt"};
inline constexpr KeySpec shear_axis_stress{.path = "tests[].axes.xIJ.stress", .kind = KeyKind::Number,
    .min = -1e12, .max = 1e12, .required = false, .default_text = "-", .unit = "Pa",
    .meaning = "servo-controlled contact shear stress s_ij (either sign, 0 allowed), its stiffness (1/V) sum kn "
               "(n_i l_j)^2 from the contacts; error relative to max(|target|, p)"};
inline constexpr KeySpec test_zero_shear_stress{.path = "tests[].zero_shear_stress", .kind = KeyKind::Boolean,
    .required = false, .default_text = "false",
    .meaning = "`true`: the leg (beside `axes`; in `legs`, per leg) servo-holds s12, s13 and s23 at 0, so the "
               "principal stresses stay on the axes (e.g. with `b` and `mean_stress` axes); not beside shear axes"};
inline constexpr KeySpec test_adaptive_rate{.path = "tests[].adaptive_rate", .kind = KeyKind::Object,
    .required = false, .default_text = "none (the deck's rate)",
    .meaning = "an adaptive loading rate (beside `axes` or `simple_shear`; in `legs`, per leg): the leg's strain-driven "
               "axes run at a factor times their rate, 1 at the leg start and over its first 0.2 % of driving strain "
               "(the start's transient), then checked every `check_interval` steps: "
               "x 1.25 while the unbalanced force ratio and the kinetic-to-elastic energy ratio both sit under half "
               "their targets, x max(1/2, 1/u) when one exceeds its target (u its value over the target), within "
               "`min_factor`..`max_factor` and under the `inertial_number` ceiling; the series records it "
               "(`rate_factor`, `strain_rate`, `inertial_number`, `kinetic_to_elastic`). Not with stress ramps, "
               "rotations or a `steps` end; LAMMPS decks keep the deck's rate"};
inline constexpr KeySpec adaptive_min_factor{.path = "tests[].adaptive_rate.min_factor", .kind = KeyKind::Number,
    .min = 1e-3, .max = 1.0, .required = false, .fallback = 0.25,
    .meaning = "the slowest rate, times the deck's"};
inline constexpr KeySpec adaptive_max_factor{.path = "tests[].adaptive_rate.max_factor", .kind = KeyKind::Number,
    .min = 1.0, .max = 1000.0, .required = false, .fallback = 8.0,
    .meaning = "the fastest rate, times the deck's"};
inline constexpr KeySpec adaptive_unbalanced_force_ratio{.path = "tests[].adaptive_rate.unbalanced_force_ratio",
    .kind = KeyKind::Number, .max = 1.0, .positive = true, .required = false, .fallback = 0.003,
    .meaning = "target of the unbalanced force ratio (series `unbalanced_force`; the paper's TTC and PSC at their "
               "rate: 0.0008-0.0019)"};
inline constexpr KeySpec adaptive_kinetic_to_elastic{.path = "tests[].adaptive_rate.kinetic_to_elastic",
    .kind = KeyKind::Number, .max = 1.0, .positive = true, .required = false, .fallback = 3e-4,
    .meaning = "target of the kinetic over the elastic energy of the contacts (series `kinetic_to_elastic`)"};
inline constexpr KeySpec adaptive_inertial_number{.path = "tests[].adaptive_rate.inertial_number",
    .kind = KeyKind::Number, .max = 1.0, .positive = true, .required = false, .fallback = 5e-4,
    .meaning = "ceiling on the inertial number gamma_dot d_mean sqrt(rho / p) of the cell's actual deformation "
               "(series `inertial_number`: gamma_dot = sqrt(2 D':D') of the cell's velocity gradient, servo-held axes "
               "included, docs/physics.md; p the mean stress), measured at each check and scaled with the factor; "
               "the default is half the quasi-static limit 1e-3"};
inline constexpr KeySpec adaptive_check_interval{.path = "tests[].adaptive_rate.check_interval",
    .kind = KeyKind::Integer, .min = 1, .max = kMaxCount, .required = false, .fallback = 200,
    .meaning = "steps between the rate's checks"};
inline constexpr KeySpec test_simple_shear{.path = "tests[].simple_shear", .kind = KeyKind::Object,
    .required = false, .default_text = "-",
    .meaning = "instead of `axes` (beside `end`; in `legs`, per leg): direct simple shear in the x1-x2 plane, g12 "
               "driven by `gamma_increment` or `gamma_rate`, s22 held at `normal_stress` by the servo, e1 = e3 = 0 "
               "and the tilts xz, yz held (end it on `steps`)"};
inline constexpr KeySpec simple_shear_gamma_increment{.path = "tests[].simple_shear.gamma_increment",
    .kind = KeyKind::Number, .min = -0.01, .max = 0.01, .required = false, .default_text = "-",
    .meaning = "engineering shear strain g12 per step (as `axes.x12.strain_increment`); this or `gamma_rate`"};
inline constexpr KeySpec simple_shear_gamma_rate{.path = "tests[].simple_shear.gamma_rate", .kind = KeyKind::Number,
    .min = -1e6, .max = 1e6, .required = false, .default_text = "-", .unit = "1/s",
    .meaning = "engineering shear strain rate dg12/dt (as `axes.x12.strain_rate`)"};
inline constexpr KeySpec simple_shear_normal_stress{.path = "tests[].simple_shear.normal_stress",
    .kind = KeyKind::Number, .positive = true, .unit = "Pa",
    .meaning = "the normal stress s22 on the shear plane, compression + (as `axes.x2.stress`)"};
inline constexpr KeySpec test_rotate_principal_axes{.path = "tests[].rotate_principal_axes", .kind = KeyKind::Object,
    .required = false, .default_text = "-",
    .meaning = "principal-axis rotation at fixed principal values (hollow-cylinder path), beside `axes` (in `legs`, "
               "per leg), which then names neither the plane's two axes nor its shear axis: they are servo-held at "
               "s_ii = m + r cos 2t, s_jj = m - r cos 2t, s_ij = r sin 2t (m, r the mean and half difference of "
               "`sigma1` and `sigma3`, t the angle of sigma1 from axis i towards j); end it on `steps`"};
inline constexpr KeySpec rotation_plane{.path = "tests[].rotate_principal_axes.plane", .kind = KeyKind::Choice,
    .default_text = "required", .choices = kPlaneNames, .meaning = "the plane of the rotation: `x1x2`, `x1x3` or `x2x3`"};
inline constexpr KeySpec rotation_sigma1{.path = "tests[].rotate_principal_axes.sigma1", .kind = KeyKind::Number,
    .positive = true, .unit = "Pa", .meaning = "the major principal stress held in the plane, compression +"};
inline constexpr KeySpec rotation_sigma3{.path = "tests[].rotate_principal_axes.sigma3", .kind = KeyKind::Number,
    .positive = true, .unit = "Pa", .meaning = "the minor principal stress held in the plane, <= `sigma1`"};
inline constexpr KeySpec rotation_from{.path = "tests[].rotate_principal_axes.from", .kind = KeyKind::Number,
    .min = -360, .max = 360, .required = false, .fallback = 0, .unit = "deg",
    .meaning = "the angle of sigma1 from the plane's first axis at the leg start"};
inline constexpr KeySpec rotation_rate{.path = "tests[].rotate_principal_axes.rate", .kind = KeyKind::Number,
    .min = -1e9, .max = 1e9, .required = false, .default_text = "-", .unit = "deg/s",
    .meaning = "the angle's rate, non-zero; this or `angle_increment`"};
inline constexpr KeySpec rotation_angle_increment{.path = "tests[].rotate_principal_axes.angle_increment",
    .kind = KeyKind::Number, .min = -1, .max = 1, .required = false, .default_text = "-", .unit = "deg",
    .meaning = "the angle's change per step, non-zero"};
inline constexpr KeySpec test_end{.path = "tests[].end", .kind = KeyKind::Object,
    .meaning = "when the leg ends: exactly one of `strain`, `ratio`, `stress`, `steps`, `equilibrium`"};
inline constexpr KeySpec test_end_axis{.path = "tests[].end.axis", .kind = KeyKind::Choice, .required = false,
    .choices = kEndAxisNames,
    .meaning = "the axis of a `strain` or `stress` end; a `strain` end may name a shear axis `x12`, `x13`, `x23` that "
               "the leg drives by its strain (`axes.xIJ` or `simple_shear`)"};
inline constexpr KeySpec test_end_strain{.path = "tests[].end.strain", .kind = KeyKind::Number, .min = -0.9,
    .max = 0.9, .required = false, .default_text = "-",
    .meaning = "engineering strain of the axis relative to the test start (either direction: unloading too); of a "
               "shear axis its engineering shear strain g_ij (series `g12`, `g13`, `g23`), its steps known ahead"};
inline constexpr KeySpec test_end_ratio{.path = "tests[].end.ratio", .kind = KeyKind::Number, .positive = true,
    .required = false, .default_text = "-", .meaning = "s11/s33 reaches this value (from either side)"};
inline constexpr KeySpec test_end_stress{.path = "tests[].end.stress", .kind = KeyKind::Number, .positive = true,
    .required = false, .default_text = "-", .unit = "Pa", .meaning = "the axis's stress reaches this value"};
inline constexpr KeySpec test_end_steps{.path = "tests[].end.steps", .kind = KeyKind::Integer, .min = 1,
    .max = kMaxCount, .required = false, .default_text = "-", .meaning = "the leg's length in steps"};
inline constexpr KeySpec test_end_equilibrium{.path = "tests[].end.equilibrium", .kind = KeyKind::Boolean,
    .required = false, .default_text = "-",
    .meaning = "`true`: the leg ends in equilibrium (`tests[].equilibrium`) at its stress targets (every axis on "
               "`stress` or `mean_stress`: a consolidation or hold leg)"};
inline constexpr KeySpec test_equilibrium{.path = "tests[].equilibrium", .kind = KeyKind::Object, .required = false,
    .default_text = "`prepare.equilibrium`",
    .meaning = "when a leg that ends in `equilibrium` ends: the keys of `prepare.equilibrium`, each defaulting to the "
               "deck's `prepare.equilibrium` value (or its default)"};
inline constexpr KeySpec test_end_max_steps{.path = "tests[].end.max_steps", .kind = KeyKind::Integer, .min = 0,
    .max = kMaxCount, .required = false, .fallback = 0,
    .meaning = "a `strain` leg ends here at the latest; any other leg not ended by then stops the run (0: none)"};
inline constexpr KeySpec snapshots{.path = "tests[].snapshots", .kind = KeyKind::Object, .required = false,
    .default_text = "none",
    .meaning = "particle and contact snapshots of the stage (also `prepare.snapshots`) into `<stage>/snapshots/`: "
               "VTK `.vtu`/`.vtp` with `.pvd` collections (ParaView) and LAMMPS-style `.dump` (OVITO)"};
inline constexpr KeySpec snapshots_interval{.path = "tests[].snapshots.interval", .kind = KeyKind::Integer, .min = 1,
    .max = kMaxCount, .required = false, .fallback = 0, .default_text = "none",
    .meaning = "a snapshot every this many steps (and at the stage's start and end)"};
inline constexpr KeySpec snapshots_e1{.path = "tests[].snapshots.e1", .kind = KeyKind::Array, .required = false,
    .default_text = "none", .meaning = "a snapshot at the first step whose e1 reaches each of these strains (e1 >= a strain >= 0, e1 <= "
               "a negative one)"};
inline constexpr KeySpec snapshots_format{.path = "tests[].snapshots.format", .kind = KeyKind::Choice, .required = false,
    .choices = kSnapshotFormatNames,
    .meaning = "how the `.vtu`/`.vtp` arrays are stored: `binary` (raw, appended after the XML), `zlib` (the same, "
               "compressed) or `ascii` (text, %.17g); ParaView reads all three, the `.dump` is always text"};
inline constexpr KeySpec test_time_step{.path = "tests[].time_step", .kind = KeyKind::Number, .positive = true,
    .required = false, .default_text = "`time_step`", .unit = "s",
    .meaning = "this test's own time step, with the bounds of `time_step`; a test from a state prepared at another "
               "time step continues it (velocities are physical)"};
inline constexpr KeySpec test_output_interval{.path = "tests[].output_interval", .kind = KeyKind::Integer, .min = 1,
    .max = kMaxCount, .required = false, .fallback = 1000, .meaning = "steps between series rows"};
inline constexpr KeySpec test_dynamic{.path = "tests[].dynamic", .kind = KeyKind::Boolean, .required = false,
    .default_text = "false", .meaning = "`true`: the test is meant to be dynamic; otherwise a test whose unbalanced "
    "force and kinetic energy stay high (not quasi-static) stops the run, naming the likely cause"};
inline constexpr KeySpec test_verify_rate{.path = "tests[].verify_rate", .kind = KeyKind::Object, .required = false,
    .default_text = "none (`celldem run --verify-rate` checks every test)",
    .meaning = "the test checks its own convergence by a ladder of rates: it runs again from the same starting state "
               "over its whole path at each rung's rate, and at 1.001, 1.002 ... times its rate (the twins, whose spread "
               "is the chaos of one run); each quantity is fitted as Q0 + C r^p over the rates (the order p fitted) and "
               "its distance C from I -> 0 is judged in noise floors at 95 % (summary.json `verify_rate`, "
               "`<test>/verify/rung-<k>/`, `<test>/verify/twin-<k>/`; docs/outputs.md); the command line's "
               "`--verify-*` values, when given, replace these"};
inline constexpr KeySpec verify_rate_rungs{.path = "tests[].verify_rate.rungs", .kind = KeyKind::Array,
    .required = false, .default_text = "[0.5, 0.25]",
    .meaning = "the slower rungs' driving rates over the test's (at least two, each in [0.001, 0.999], no two equal): "
               "strain increments and rates of the strain-driven axes, stress ramps' and rotations' rates (step ends "
               "and the output interval follow); a rung at f costs 1/f times the test's steps"};
inline constexpr KeySpec verify_rate_rate_factor{.path = "tests[].verify_rate.rate_factor", .kind = KeyKind::Number,
    .min = 1e-3, .max = 0.999, .required = false, .fallback = 0.5, .default_text = "none",
    .meaning = "shorthand for `rungs` [f, f^2] (not with `rungs`; f^2 at least 0.001)"};
inline constexpr KeySpec verify_rate_twins{.path = "tests[].verify_rate.twins", .kind = KeyKind::Integer,
    .min = 2, .max = 8, .required = false, .fallback = 2,
    .meaning = "the twins (the test again at 1.001, 1.002 ... times its rate), whose spread with the test is one run's "
               "chaos, with as many degrees of freedom (not with `twin`)"};
inline constexpr KeySpec verify_rate_twin{.path = "tests[].verify_rate.twin", .kind = KeyKind::Boolean,
    .required = false, .default_text = "true",
    .meaning = "`false`: no twins; one run's chaos is then unknown and a single run's check is unresolved (the seeds "
               "of an ensemble judge the mean: ensemble.json `verify_rate`)"};
inline constexpr KeySpec test_probes{.path = "tests[].probes", .kind = KeyKind::Object, .required = false,
    .default_text = "none",
    .meaning = "incremental response probes: from the exact state at each point of the test, small stress or strain "
               "loadings in several directions, each followed by its unloading, beside a probe of no loading whose "
               "response (creep) is subtracted; `<test>/probes/` (`probes.csv`, `stiffness.json`; docs/outputs.md); "
               "the test's own series are untouched"};
inline constexpr KeySpec probes_at{.path = "tests[].probes.at", .kind = KeyKind::Array, .required = false,
    .default_text = "[]", .choices = kProbePointNames,
    .meaning = "named points: `peak` (the first row of the largest driven measure, summary.json `driven_measure`: "
               "s11/s33, s33/s11 of an extension, abs(s_ij)/s_jj of a shear; not run where no peak was reached) and "
               "`end` (the last row)"};
inline constexpr KeySpec probes_at_e1{.path = "tests[].probes.at_e1", .kind = KeyKind::Array, .required = false,
    .default_text = "[]", .meaning = "points at the first row whose e1 reaches each of these strains (at least one "
                                     "point in `at` or `at_e1`)"};
inline constexpr KeySpec probes_kind{.path = "tests[].probes.kind", .kind = KeyKind::Choice, .required = false,
    .default_text = "stress", .choices = kProbeKindNames,
    .meaning = "`stress`: the three normal stresses follow a ramp to s + M d and back, shear strains held; "
               "`strain`: the six strains (e11, e22, e33, g12, g13, g23) one at a time by M and back, the others "
               "held (the tangent stiffness and its elastic part)"};
inline constexpr KeySpec probes_plane{.path = "tests[].probes.plane", .kind = KeyKind::Choice, .required = false,
    .default_text = "rendulic", .choices = kProbePlaneNames,
    .meaning = "stress probes' directions d: `rendulic` (cos a, sin a / sqrt 2, sin a / sqrt 2), `pi` (the "
               "deviatoric plane at constant p: cos a (2, -1, -1) / sqrt 6 + sin a (0, 1, -1) / sqrt 2), a = 360 "
               "deg k / `directions`; or `list`"};
inline constexpr KeySpec probes_directions{.path = "tests[].probes.directions", .kind = KeyKind::Integer, .min = 1,
    .max = 720, .required = false, .fallback = 16, .meaning = "stress probes in the `rendulic` or `pi` plane: how many, "
                                                              "equally spaced from a = 0"};
inline constexpr KeySpec probes_list{.path = "tests[].probes.list", .kind = KeyKind::Array, .required = false,
    .default_text = "required with `list`",
    .meaning = "stress probes' directions (ds11, ds22, ds33), each normalised to length 1"};
inline constexpr KeySpec probes_magnitudes{.path = "tests[].probes.magnitudes", .kind = KeyKind::Array,
    .required = false, .default_text = "from target_strain",
    .meaning = "the probes' sizes M, each a probe set: [Pa] the stress increment's length (stress), [-] the strain "
               "(strain, at most 0.01); two show the linear range. Left out, they follow the point's stiffness: "
               "strain probes M = target_strain; stress probes M = 1 and 2 times target_strain over the largest "
               "compliance |C^-1 d| of the set's directions (C: the tangent stiffness of the point's strain probes, "
               "its elastic part where the tangent is not positive definite)"};
inline constexpr KeySpec probes_target_strain{.path = "tests[].probes.target_strain", .kind = KeyKind::Number,
    .min = 1e-8, .max = 1e-3, .required = false, .fallback = 1e-5,
    .meaning = "the probes' strain scale: the strain of the stress set's elastic check (six strain probes from the "
               "same rested state), the stress probes' size where `magnitudes` is left out, and the response that "
               "the rest goal is a fraction of"};
inline constexpr KeySpec probes_rest_fraction{.path = "tests[].probes.rest_fraction", .kind = KeyKind::Number,
    .min = 1e-4, .max = 1.0, .required = false, .fallback = 0.1,
    .meaning = "before probing, the point rests at its stresses (normal stresses held, tilts held) in windows of one "
               "probe's steps until the strain it creeps in a window, |de| over the six strains, is below this "
               "fraction of target_strain (a probe from equilibrium)"};
inline constexpr KeySpec probes_rest_max_steps{.path = "tests[].probes.rest_max_steps", .kind = KeyKind::Integer,
    .min = 0, .max = kMaxCount, .required = false, .fallback = 120000,
    .meaning = "the rest's budget of steps: a point that has not reached the rest goal by then is probed as it "
               "stands, with the status `not at rest` (0: probed without resting)"};
inline constexpr KeySpec probes_drift_limit{.path = "tests[].probes.drift_limit", .kind = KeyKind::Number,
    .min = 1e-4, .max = 10.0, .required = false, .fallback = 0.25,
    .meaning = "the reference probe's drift over a probe (|de| from its start to its end; strain sets |ds|) above "
               "this fraction of the point's smallest probe response gives the status `drifting`"};
inline constexpr KeySpec probes_elastic_factor{.path = "tests[].probes.elastic_factor", .kind = KeyKind::Number,
    .min = 1.0, .max = 1000.0, .required = false, .fallback = 3.0,
    .meaning = "stress probes: each probe's recovered (elastic) strain against C_elastic^-1 ds from the elastic "
               "check at the same state; a ratio of lengths beyond this factor either way, or an angle between "
               "them above 60 deg, gives the status `elastic mismatch`"};
inline constexpr KeySpec probes_asymmetry_limit{.path = "tests[].probes.asymmetry_limit", .kind = KeyKind::Number,
    .min = 0.0, .max = 2.0, .required = false, .fallback = 0.1,
    .meaning = "the elastic stiffness (strain probes, or a stress set's elastic check) with |C - C^T| / |C| above "
               "this gives the status `elastic asymmetric`; one whose symmetric part has an eigenvalue <= 0, "
               "`elastic not positive definite`"};
inline constexpr KeySpec probes_steps{.path = "tests[].probes.steps", .kind = KeyKind::Integer, .min = 1,
    .max = kMaxCount, .required = false, .fallback = 3000, .meaning = "steps of the loading ramp, and of the "
                                                                      "unloading ramp"};
inline constexpr KeySpec probes_hold_steps{.path = "tests[].probes.hold_steps", .kind = KeyKind::Integer, .min = 1,
    .max = kMaxCount, .required = false, .fallback = 1000,
    .meaning = "steps held after the loading and after the unloading (the response is read at their ends)"};
// clang-format on

// Every key in table order (the order of docs/deck.md's table).
inline constexpr auto kAll = std::to_array<const KeySpec*>({&format,
                                                            &description,
                                                            &sample,
                                                            &sample_count,
                                                            &sample_diameters,
                                                            &sample_diameters_list,
                                                            &sample_diameters_min,
                                                            &sample_diameters_max,
                                                            &sample_diameters_count,
                                                            &sample_diameters_grading,
                                                            &sample_diameters_grading_by,
                                                            &sample_diameters_grading_sizes,
                                                            &sample_diameters_grading_passing,
                                                            &sample_density,
                                                            &sample_seed,
                                                            &sample_grid_spacing,
                                                            &contact,
                                                            &contact_normal,
                                                            &contact_tangential,
                                                            &contact_rolling,
                                                            &contact_twisting,
                                                            &contact_kn,
                                                            &contact_kt,
                                                            &contact_youngs_modulus,
                                                            &contact_poisson_ratio,
                                                            &contact_rolling_stiffness,
                                                            &contact_rolling_damping,
                                                            &contact_rolling_friction,
                                                            &contact_reference_overlap,
                                                            &contact_tangential_rotation,
                                                            &contact_moment_arm,
                                                            &damping,
                                                            &damping_translational,
                                                            &damping_rotational,
                                                            &kinematics,
                                                            &time_step,
                                                            &tolerance,
                                                            &servo,
                                                            &servo_gain,
                                                            &servo_integral_gain,
                                                            &servo_max_strain_increment,
                                                            &control_failure,
                                                            &neighbor_skin,
                                                            &checkpoint_interval,
                                                            &energy_budget,
                                                            &prepare,
                                                            &prepare_friction,
                                                            &prepare_rolling_friction,
                                                            &prepare_target_pressure,
                                                            &prepare_fast_solid_fraction,
                                                            &prepare_fast_strain_increment,
                                                            &prepare_relax_overlaps,
                                                            &prepare_time_step,
                                                            &prepare_servo_max_strain_increment,
                                                            &prepare_output_interval,
                                                            &prepare_equilibrium,
                                                            &equilibrium_pressure_tolerance,
                                                            &equilibrium_stress_tolerance,
                                                            &equilibrium_unbalanced_force_ratio,
                                                            &equilibrium_min_steps,
                                                            &equilibrium_check_interval,
                                                            &equilibrium_max_steps,
                                                            &prepare_legs,
                                                            &end_solid_fraction,
                                                            &end_equilibrium,
                                                            &initial_state,
                                                            &override_state_physics,
                                                            &tests,
                                                            &test_name,
                                                            &test_friction,
                                                            &test_rolling_friction,
                                                            &test_legs,
                                                            &leg_repeat,
                                                            &test_axes,
                                                            &axis_strain_increment,
                                                            &axis_strain_rate,
                                                            &axis_stress,
                                                            &axis_b,
                                                            &axis_mean_stress,
                                                            &axis_constant_volume,
                                                            &axis_stress_ramp,
                                                            &axis_stress_ramp_from,
                                                            &axis_stress_ramp_rate,
                                                            &shear_axis_strain_increment,
                                                            &shear_axis_strain_rate,
                                                            &shear_axis_stress,
                                                            &test_zero_shear_stress,
                                                            &test_adaptive_rate,
                                                            &adaptive_min_factor,
                                                            &adaptive_max_factor,
                                                            &adaptive_unbalanced_force_ratio,
                                                            &adaptive_kinetic_to_elastic,
                                                            &adaptive_inertial_number,
                                                            &adaptive_check_interval,
                                                            &test_simple_shear,
                                                            &simple_shear_gamma_increment,
                                                            &simple_shear_gamma_rate,
                                                            &simple_shear_normal_stress,
                                                            &test_rotate_principal_axes,
                                                            &rotation_plane,
                                                            &rotation_sigma1,
                                                            &rotation_sigma3,
                                                            &rotation_from,
                                                            &rotation_rate,
                                                            &rotation_angle_increment,
                                                            &test_end,
                                                            &test_end_axis,
                                                            &test_end_strain,
                                                            &test_end_ratio,
                                                            &test_end_stress,
                                                            &test_end_steps,
                                                            &test_end_equilibrium,
                                                            &test_end_max_steps,
                                                            &test_equilibrium,
                                                            &snapshots,
                                                            &snapshots_interval,
                                                            &snapshots_e1,
                                                            &snapshots_format,
                                                            &test_time_step,
                                                            &test_output_interval,
                                                            &test_dynamic,
                                                            &test_verify_rate,
                                                            &verify_rate_rungs,
                                                            &verify_rate_rate_factor,
                                                            &verify_rate_twins,
                                                            &verify_rate_twin,
                                                            &test_probes,
                                                            &probes_at,
                                                            &probes_at_e1,
                                                            &probes_kind,
                                                            &probes_plane,
                                                            &probes_directions,
                                                            &probes_list,
                                                            &probes_magnitudes,
                                                            &probes_steps,
                                                            &probes_hold_steps,
                                                            &probes_target_strain,
                                                            &probes_rest_fraction,
                                                            &probes_rest_max_steps,
                                                            &probes_drift_limit,
                                                            &probes_elastic_factor,
                                                            &probes_asymmetry_limit});

// The keys that choose the contact sub-models; a SubModelSelection names each one's choice in this order.
inline constexpr auto kSubModels = std::to_array<const KeySpec*>({&contact_normal, &contact_tangential,
                                                                 &contact_rolling, &contact_twisting});
}  // namespace keys

// The choice a deck makes for each contact sub-model, by its deck name, in keys::kSubModels order.
using SubModelSelection = std::array<std::string_view, keys::kSubModels.size()>;

// The index in keys::kSubModels of the sub-model named `sub_model` ("normal", ...); kSubModels.size() when
// there is none.
constexpr std::size_t sub_model_index(std::string_view sub_model) {
  std::size_t k = 0;
  while (k < keys::kSubModels.size() && keys::kSubModels[k]->name() != sub_model) ++k;
  return k;
}

// Whether the selection makes the sub-model choice `use` (an empty choice: any choice of that sub-model).
constexpr bool makes(const SubModelSelection& selection, const SubModelChoice& use) {
  const std::size_t k = sub_model_index(use.sub_model);
  return k < selection.size() && (use.choice.empty() || selection[k] == use.choice);
}

// The first of the key's sub-model choices that the selection makes; nullptr when it makes none, or when the
// key belongs to no sub-model.
constexpr const SubModelChoice* chosen_use(const KeySpec& key, const SubModelSelection& selection) {
  for (const SubModelChoice& use : key.sub_models)
    if (!use.sub_model.empty() && makes(selection, use)) return &use;
  return nullptr;
}

// Whether the deck's sub-model choices use the key: always for a key of no sub-model.
constexpr bool key_used(const KeySpec& key, const SubModelSelection& selection) {
  return key.sub_models[0].sub_model.empty() || chosen_use(key, selection) != nullptr;
}

// Every key's sub-model choices name a sub-model key and one of its choices, the used entries first.
constexpr bool sub_model_uses_valid() {
  for (const KeySpec* k : keys::kAll) {
    bool ended = false;
    for (const SubModelChoice& use : k->sub_models) {
      if (use.sub_model.empty()) {
        if (!use.choice.empty()) return false;
        ended = true;
        continue;
      }
      const std::size_t by = sub_model_index(use.sub_model);
      if (ended || by == keys::kSubModels.size()) return false;
      bool known = use.choice.empty();
      for (const std::string_view c : keys::kSubModels[by]->choices) known = known || c == use.choice;
      if (!known) return false;
    }
    if (k->required_when_used && k->sub_models[0].sub_model.empty()) return false;
  }
  return true;
}
static_assert(sub_model_uses_valid(), "a key's sub_models name an unknown sub-model or choice");

}  // namespace celldem
