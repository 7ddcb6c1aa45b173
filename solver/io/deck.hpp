// The deck: everything a run needs, parsed and validated from JSON (SI units).
// Parsing is the only place that knows JSON; the solver sees these plain structs.
#pragma once
#include <array>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace celldem {

// Bad input. The message names the JSON path of the offending key ("tests[1].axes.x2.stress: ...").
struct DeckError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

inline constexpr int kDeckFormatVersion = 1;

struct SampleDef {
  int count = 0;                   // number of spheres
  std::vector<double> diameters;   // [m] the distinct sizes, each drawn with equal probability
  double density = 0.0;            // [kg/m^3]
  std::uint64_t seed = 1;          // sizes and the initial jitter depend on it only
  double grid_spacing = 0.0;       // [m] spacing of the initial cubic grid (> largest diameter)
};

enum class TangentialRotation { Rotate, Project };  // keep |xi| when the tangent plane turns, or not (LAMMPS)
enum class MomentArm { ContactPoint, Radius };      // lever arm of the tangential force
enum class Kinematics { Affine, Lammps };           // contacts see the affine velocity difference, or not

struct ContactDef {
  double kn = 0.0;  // [N/m] normal spring
  double kt = 0.0;  // [N/m] tangential spring
  TangentialRotation rotation = TangentialRotation::Rotate;
  MomentArm moment_arm = MomentArm::ContactPoint;
};

struct DampingDef {
  double translational = 0.0;  // fraction of 2*sqrt(m*kn), on the fluctuating velocity
  double rotational = 0.0;     // fraction of 2*r*sqrt(I*kt), on the spin
};

// Stress servo: strain increment per step = gain * (target - stress) / K, K the affine stiffness of the
// axis measured from the contacts, capped at max_strain_increment (also used when there are no contacts).
struct ServoDef {
  double gain = 0.05;
  double integral_gain = 0.002;       // per step, fraction of the accumulated error added back
  double max_strain_increment = 1e-6;
};

enum class AxisMode { StrainIncrement, StrainRate, Stress };
struct AxisControl {
  AxisMode mode = AxisMode::StrainIncrement;
  double value = 0.0;  // per step [-] (compression +), rate [1/s] (compression +), or stress [Pa] (compression +)
};

struct EquilibriumDef {
  double pressure_tolerance = 0.005;      // |p - target| / target
  double stress_tolerance = 0.005;        // every controlled axis: |s_ii - target| / target
  double unbalanced_force_ratio = 1e-3;   // mean |net force| / mean contact normal force
  std::int64_t min_steps = 20000;         // at least this many steps in the relax phase
  std::int64_t check_interval = 1000;     // steps
  std::int64_t max_steps = 2000000;       // give up (error) after this many steps of stress control
};

struct PrepareDef {
  double friction = 0.0;                  // interparticle mu during preparation
  double target_pressure = 1e5;           // [Pa]
  double fast_solid_fraction = 0.45;      // strain-controlled compression up to this solid fraction
  double fast_strain_increment = 2e-5;    // per step, per axis, during the fast phase
  EquilibriumDef equilibrium;
  std::int64_t output_interval = 1000;
};

struct TestDef {
  std::string name;
  double friction = 0.0;
  std::array<AxisControl, 3> axes;
  int end_axis = 0;                 // 0-based axis whose strain ends the test
  double end_strain = 0.0;          // engineering strain of end_axis, compression +
  std::int64_t max_steps = 0;       // safety stop, 0 = derived from the end strain
  std::int64_t output_interval = 1000;
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
  std::int64_t checkpoint_interval = 100000;  // steps between checkpoints of a running stage
  double neighbor_skin = 0.01;              // neighbour-list skin, as a fraction of the largest diameter
  std::optional<PrepareDef> prepare;        // exactly one of prepare / initial_state
  std::optional<std::string> initial_state; // path, relative to the deck's folder
  std::vector<TestDef> tests;
};

// Parse and validate. Throws DeckError naming the key path on any problem.
Deck parse_deck(const std::string& json_text, const std::string& source = "<deck>");
Deck read_deck(const std::string& path);

// The neighbour-list skin in metres: neighbor_skin times the largest diameter.
double skin_length(const Deck& deck);

// The stable time step for the lightest particle, sqrt(m_min / kn) (no safety factor).
double critical_time_step(const SampleDef& sample, double kn);

}  // namespace celldem
