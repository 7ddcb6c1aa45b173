// Translation of a deck (and a state) into LAMMPS or LIGGGHTS input, for cross-code verification:
// a data file with the exact particles of the state and one input script per test of the deck.
//
// The scripts depend on the deck alone (atom type k = the k-th distinct diameter of sample.diameters), so
// they can be kept under version control; the data file carries the state. Everything the target code
// cannot express is returned as a difference: the caller prints it, and the scripts list it in a header.
// The generated inputs and the facts they rest on are documented in crosscheck/README.md.
#pragma once
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

// Columns of the series the scripts write (a subset of celldem's series.csv names, plus the lengths).
inline constexpr const char* kTranslatedSeriesHeader =
    "step,time,e1,e2,e3,ev,s11,s22,s33,Z,n_contacts,kinetic_energy,l1,l2,l3";

// What the target code does differently from the deck's physics (deck only: the same for every state).
std::vector<std::string> model_differences(const Deck& deck, TargetCode code);
// Smaller, discretisation-level differences (written in the script header only).
std::vector<std::string> model_notes(const Deck& deck, TargetCode code);
// What a data file cannot carry from this state (contact history).
std::vector<std::string> state_differences(const State& state, TargetCode code);

// The data file: the particles of the state, positions x = h s wrapped into [0, L), diameter, density,
// velocities and spins. Throws DeckError if the cell is not orthogonal or a diameter is not in the deck.
std::string translate_data(const Deck& deck, const State& state, TargetCode code, const std::string& state_label,
                           const std::vector<std::string>& differences);

// The input script of one test: depends on the deck (and the deck's file name, for the header) only.
std::string translate_test(const Deck& deck, const TestDef& test, TargetCode code);

// Servo constants of the translated stress control (press/berendsen law, also the LIGGGHTS variable servo):
// per step, dL/L ~= dt / (3 pdamp modulus) * (target - s). modulus is a nominal affine axis stiffness estimated
// from the deck, pdamp = dt / (3 gain), so the proportional gain equals celldem's at that stiffness.
struct TranslatedServo {
  double modulus = 0.0;  // [Pa]
  double pdamp = 0.0;    // [s]
};
TranslatedServo translated_servo(const Deck& deck);

}  // namespace celldem
