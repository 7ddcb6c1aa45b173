// What the files of the translation share (internal to io/; the API is io/translate.hpp):
//   translate.cpp              target codes, file names, atom types, servo constants, the data file, and the
//                              deck as the target codes see it (numbers, axes, program features, damping, law)
//   translate_program.cpp      the load-program writer: each leg's controls and how its run ends
//   translate_scripts.cpp      the LAMMPS and LIGGGHTS input scripts around it
//   translate_differences.cpp  the catalogue of what a target code cannot express
#pragma once
#include <charconv>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "io/translate.hpp"

namespace celldem::translation {

// ---- the deck as the target codes see it (translate.cpp) ----

// Shortest text that reads back to the same double: exact, and short for round deck values (1e+06, 0.05).
inline std::string num(double x) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, res.ptr);
}

inline const char* const kAxisName[3] = {"x", "y", "z"};

// What the programs of a script (or of every test of a deck) use, for the differences and notes they imply.
struct ProgramFeatures {
  bool stress = false;   // a stress-driven axis (stress, b, mean_stress)
  bool coupled = false;  // b or mean_stress axes: targets from the measured stresses
  bool volume = false;   // constant-volume axes
  bool halts = false;    // a leg whose end only running tells (ratio, stress, strain of a servo axis, solid fraction)
  bool programs = false; // more than one leg
  void add(const std::vector<Leg>& legs) {
    programs = programs || legs.size() > 1;
    for (const Leg& leg : legs) {
      for (const AxisControl& a : leg.axes) {
        stress = stress || a.stress_driven();
        coupled = coupled || a.mode == AxisMode::B || a.mode == AxisMode::MeanStress;
        volume = volume || a.mode == AxisMode::ConstantVolume;
      }
      const LegEnd& e = leg.end;
      halts = halts || e.kind == LegEndKind::Ratio || e.kind == LegEndKind::Stress ||
              e.kind == LegEndKind::SolidFraction ||
              (e.kind == LegEndKind::Strain && !leg.axes[e.axis].strain_driven());
    }
  }
};

ProgramFeatures test_features(const Deck& d);

std::string axis_text(const AxisControl& a);

// Per-type fix langevin / fix viscous constants that give exactly c_r on the spin and c_t on the velocity
// (LAMMPS 29Sep2021, verified): langevin (T = 0, omega yes, damp 1.0, scale s) applies F = -m/s v and
// T = -(10/3) I/s w; viscous (gamma 1.0, scale g) applies F = -g v.
struct LammpsDamping {
  std::vector<double> langevin_scale;  // s_t = (10/3) I / c_r  (empty: no rotational damping)
  std::vector<double> viscous_scale;   // g_t = c_t - m / s_t, clamped at 0
  bool clamped = false;                // some g_t < 0: langevin alone exceeds c_t
};

LammpsDamping lammps_damping(const Deck& deck);

// The paper's law (linear normal spring, linear tangential history, no rolling or twisting resistance): the
// scripts use gran/hooke/history (LAMMPS) and hooke/stiffness (LIGGGHTS), as they always did. Any other
// composition goes to LAMMPS's pair granular with the matching sub-models, and to LIGGGHTS's closest models.
bool plain_linear(const ContactDef& c);

std::string deck_name(const Deck& deck);

// ---- load programs: how each leg runs (translate_program.cpp) ----

// What a script translates: a test's program, or the preparation's.
struct ScriptProgram {
  std::string name;                               // the test's name, or "prepare"
  const std::vector<Leg>& legs;
  double friction = 0.0;
  std::int64_t output_interval = 1000;
  const EquilibriumDef* equilibrium = nullptr;    // the preparation only
  double rolling_friction = 0.0;                  // mu_roll (contact.rolling sds)
  // [s] the stage's own time step (Deck::stage_time_step): the script's `timestep`, and what the script makes per
  // step from it (fix deform rates of strain increments, the servo's pdamp, the steps of strain ends, the time).
  // One script runs one stage, so the time step never changes within a script.
  double time_step = 0.0;
  bool preparation() const { return equilibrium != nullptr; }
  // The one-leg form of a test: the script of a single leg, as before load programs (`-var steps N`).
  bool one_leg() const { return legs.size() == 1 && !preparation(); }
};

ScriptProgram test_program(const Deck& deck, const TestDef& test);
// Whether a leg of the program drives a shear axis by its strain: the script then makes the box triclinic
// (change_box) and writes the shear columns of its series (kTranslatedShearColumns).
bool program_shears(const ScriptProgram& p);

// How a leg's length is decided in the script.
enum class LegLength {
  Known,        // run N: a step end, or the strain end of a strain-driven axis whose start strain is known here
  FromStrain,   // the strain end of a strain-driven axis that starts where only the run knows: N at run time
  Halt,         // ratio, stress, the strain of an axis that is not strain-driven, solid fraction: checked running
  Equilibrium,  // the preparation's equilibrium: checked every check_interval steps of the leg
};

struct LegRun {
  LegLength length = LegLength::Known;
  std::int64_t steps = 0;  // Known: the leg's steps (core/plan's leg_steps)
  std::int64_t limit = 0;  // the others: the most steps (0: none)
};

// Each leg's length, following the strains of the strain-driven axes from the program's start (exactly as
// celldem's legs start: e = e(leg start) + n d) for as long as every leg's length is known.
std::vector<LegRun> plan_runs(const Deck& deck, const ScriptProgram& p);

std::string end_text(const Leg& leg, const LegRun& run);
std::string leg_text(const Leg& leg, const LegRun& run);

// Writes the control and the run of each leg.
class ProgramWriter {
 public:
  ProgramWriter(std::ostringstream& o, const Deck& deck, const ScriptProgram& p, TargetCode code);
  const std::vector<LegRun>& runs() const;
  // Before the series output is defined: the stresses of the state for the first leg's end.
  void state_stresses();
  // The one-leg form: the leg's controls (the end follows the series output, see end()).
  void controls_of_one_leg();
  // The load program: one block per leg.
  void program();
  // How the leg ends (the one-leg form of a leg of known length ends with `run ${steps}` in output()).
  void end(int j);

 private:
  std::string tag(int j) const;
  bool chunked(int j) const;
  void var(const std::string& name, const std::string& formula);
  void freeze(const std::string& name, const std::string& formula);
  void fail(const std::string& condition, const std::string& message);
  std::string leg_name(int j) const;
  void controls(int j);
  void tilt_deform(int j, bool by_erate, std::string& deform, bool& units_box);
  void control_comments(double modulus, bool coupled, bool volume);
  void from_strain(int j);
  void halt(int j);
  void chunks(int j);
  void equilibrium(int j);

  std::ostringstream& o_;
  const Deck& deck_;
  const ScriptProgram& p_;
  bool lmp_;
  std::vector<LegRun> runs_;
  std::vector<std::string> fixes_;  // the control fixes of the leg now defined
};

}  // namespace celldem::translation
