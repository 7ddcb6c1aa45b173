// Translation of a deck (and a state) into LAMMPS or LIGGGHTS input, for cross-code verification:
// a data file with the exact particles of the state, one input script per test of the deck and, for a deck
// that prepares its sample, a preparation script that starts from celldem's initial grid sample.
//
// A test's load program becomes successive blocks of one script: per leg the previous leg's control fixes
// are removed, the leg's own are defined, and the leg runs for its known length or until a halt condition.
//
// The scripts depend on the deck alone (atom type k = the k-th distinct diameter of sample.diameters), so
// they can be kept under version control; the data file carries the state. Everything the target code
// cannot express is returned as a difference: the caller prints it, and the scripts list it in a header.
// The generated inputs and the facts they rest on are documented in crosscheck/README.md.
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/state.hpp"
#include "core/deck.hpp"

namespace celldem {

enum class TargetCode { Lammps, Liggghts };

// "lammps" or "liggghts"; throws DeckError naming the bad value otherwise.
TargetCode parse_target_code(const std::string& name);
const char* target_code_name(TargetCode code);

// One atom type per distinct diameter of the deck (in deck order), with its body-damping coefficients.
struct AtomType {
  double diameter = 0.0;  // [m]
  double mass = 0.0;      // [kg]   rho pi d^3 / 6
  double inertia = 0.0;   // [kg m^2] 0.4 m r^2
  double c_t = 0.0;       // [kg/s] translational drag, damping.translational * 2 sqrt(m kn)
  double c_r = 0.0;       // [kg m^2/s] rotational drag, damping.rotational * 2 r sqrt(I kt)
};
std::vector<AtomType> atom_types(const Deck& deck);

// File names inside the output folder, and the series file each script writes (in its working folder).
inline constexpr const char* kTranslatedDataName = "state.data";
std::string script_file_name(const TestDef& test, TargetCode code);  // "<test>.lammps.in" / ".liggghts.in"
std::string series_file_name(const TestDef& test, TargetCode code);  // "<test>.lammps.csv" / ".liggghts.csv"
// The preparation: its script reads celldem's initial grid sample (run/sample.hpp's make_grid_sample, written
// with translate_data as kTranslatedSampleName) and writes the prepared sample with write_data
// (kTranslatedPreparedName), which the test scripts read with -var data prepared.data.
inline constexpr const char* kTranslatedSampleName = "sample.data";
inline constexpr const char* kTranslatedPreparedName = "prepared.data";
std::string preparation_script_name(TargetCode code);  // "prepare.lammps.in" / "prepare.liggghts.in"
std::string preparation_series_name(TargetCode code);  // "prepare.lammps.csv" / "prepare.liggghts.csv"

// LIGGGHTS 3.8 has no fix halt: a leg whose end only running can tell runs in chunks of this many steps, its
// end checked between them.
inline constexpr std::int64_t kLiggghtsCheckSteps = 100;

// Columns of the series the scripts write (a subset of celldem's series.csv names, plus the lengths).
inline constexpr const char* kTranslatedSeriesHeader =
    "step,time,e1,e2,e3,ev,s11,s22,s33,Z,n_contacts,kinetic_energy,l1,l2,l3";
// Appended to them by a test whose program drives a shear axis by its strain (program_shears).
inline constexpr const char* kTranslatedShearColumns = ",s12,s13,s23,g12,g13,g23";

// What the target code does differently from the deck's physics in its tests (deck only: the same for every
// state).
std::vector<std::string> model_differences(const Deck& deck, TargetCode code);
// Smaller, discretisation-level differences of the tests (written in the script header only).
std::vector<std::string> model_notes(const Deck& deck, TargetCode code);
// The same for the preparation script (deck.prepare required).
std::vector<std::string> preparation_differences(const Deck& deck, TargetCode code);
std::vector<std::string> preparation_notes(const Deck& deck, TargetCode code);
// What a data file cannot carry from this state (contact history).
std::vector<std::string> state_differences(const State& state, TargetCode code);

// The data file: the particles of the state, positions x = h s wrapped into [0, L), diameter, density,
// velocities and spins. Throws DeckError if the cell is not orthogonal or a diameter is not in the deck.
std::string translate_data(const Deck& deck, const State& state, TargetCode code, const std::string& state_label,
                           const std::vector<std::string>& differences);

// The input script of one test: depends on the deck (and the deck's file name, for the header) only.
// Throws DeckError when a leg's strain-driven end axis moves away from its end strain (celldem stops there).
std::string translate_test(const Deck& deck, const TestDef& test, TargetCode code);

// The preparation script (deck.prepare required): the preparation program from the grid sample's data file,
// ending with write_data. Depends on the deck only.
std::string translate_preparation(const Deck& deck, TargetCode code);

// Servo constants of the translated stress control (press/berendsen law, also the LIGGGHTS variable servo):
// per step, dL/L ~= dt / (3 pdamp modulus) * (target - s). modulus is a nominal affine axis stiffness estimated
// from the deck, pdamp = dt / (3 gain) at the stage's time step dt, so the proportional gain equals celldem's at
// that stiffness.
struct TranslatedServo {
  double modulus = 0.0;  // [Pa]
  double pdamp = 0.0;    // [s]
};
TranslatedServo translated_servo(const Deck& deck, double time_step);

}  // namespace celldem
