// Reads a LAMMPS data file of spheres (atom_style sphere) into a State: the files `celldem translate --to
// lammps` writes, and what LAMMPS `write_data` writes for atom_style sphere.
//
// What is read:
//   - header: `N atoms`, `K atom types`, `xlo xhi`, `ylo yhi`, `zlo zhi`, and `xy xz yz` only if all three
//     are 0. The first line is the title (LAMMPS skips it too); `#` starts a comment anywhere.
//     Counts of bonds, angles, ... must be 0; their `... types` lines are ignored.
//   - `Atoms # sphere` (also `Atoms # granular`, LIGGGHTS's name for the same columns, or `Atoms` with no
//     style): `id type diameter density x y z [ix iy iz]`, one line per atom.
//   - `Velocities` (optional): `id vx vy vz wx wy wz` for every atom.
//   - `Masses`, `Pair Coeffs`, `PairIJ Coeffs` and other `... Coeffs` sections are skipped.
//
// Assumptions (what the returned State is):
//   - Orthogonal box only: h = diag(xhi - xlo, yhi - ylo, zhi - zlo). A tilted (triclinic) box is an error.
//   - Particles are ordered by ascending atom id and renumbered 0..N-1 in that order (ids need not be
//     contiguous; `ids` keeps the originals). Types are returned, not interpreted.
//   - radius = diameter / 2; scaled position s = (x - lo) / L + image flag (never wrapped).
//   - velocity = the LAMMPS velocity, spin = the angular velocity. LAMMPS velocities are total ones; they
//     are taken as celldem's fluctuating velocities, which holds for a cell at rest (the start of a run).
//     Without a Velocities section both are zero.
//   - No contacts: the pair list is empty, with no tangential history (a data file cannot carry it), and its
//     skin is 0: the caller sets state.pairs.skin and rebuilds the list. Time and step counters are 0; the
//     control memory holds the cell's lengths and volume as the reference (as a new grid sample).
//   - Mass is not set here: the densities are returned (per atom, and the single value if all are equal) so
//     that the caller can check them against its deck.
// Errors are LammpsDataError, "<file>:<line>: <what>" (line 0 when the problem is the file as a whole).
#pragma once
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/state.hpp"

namespace celldem {

struct LammpsDataError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct LammpsData {
  State state;
  std::vector<std::int64_t> ids;        // (N) the LAMMPS atom id of each particle, ascending
  std::vector<int> types;               // (N) atom type, 1..atom types
  std::vector<double> density;          // (N) [kg/m^3]
  std::optional<double> common_density; // [kg/m^3] set when every atom has the same density
  Vec3 box_low = Vec3::Zero();          // [m] xlo ylo zlo (positions are stored relative to it)
  int atom_types = 0;                   // from the header
  bool has_velocities = false;          // a Velocities section was present
};

// Reads the file; LammpsDataError if it cannot be read or is not a valid atom_style sphere data file.
LammpsData read_lammps_data(const std::filesystem::path& path);

// The same for text in memory; `source` names it in error messages.
LammpsData parse_lammps_data(const std::string& text, const std::string& source);

}  // namespace celldem
