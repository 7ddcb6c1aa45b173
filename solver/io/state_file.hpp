// State files: the exact simulation state (cell, particles, contact history, control memory), binary,
// versioned and checksummed, written atomically (temporary file, then rename).
#pragma once
#include <stdexcept>
#include <string>

#include "core/state.hpp"

namespace celldem {

struct StateFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// 2: the control holds the current leg's start (strains, volume). 3: format 2 plus each contact's rotational
// springs (rolling displacement, twist angle), written only for laws that have them (a state of the linear law
// is still written as format 2). 4: after the label, the physics the state was made with (JSON text, possibly
// empty: run/preflight.hpp's state_physics); after the skin, a byte that says which of the optional contact
// fields follow each contact (bit 0: the rotational springs, bit 1: the contact radius of mindlin_rescale).
// 5: format 4 with the shear record: the contact shear stresses s12, s13, s23 in the off-diagonal of the
// stress tensor's slot, and after the axis stiffnesses the shear stiffnesses, the stage's reference tilts,
// the leg's start shear strains and the shear servo's integral (cell/control.hpp), so a leg with shear axes
// resumes bit for bit. Written for states with a physics record (every state a run writes) or contact radii;
// without either, format 2 or 3 as before. Formats 1 to 4 are still read (their tilts are the reference).
// 6: format 5 with the adaptive rate's record after the shear record (ControlState::rate_factor, leg_progress),
// written only for a state inside an adaptive leg; older files read as the deck's rate (factor 1, progress =
// the leg's steps).
// 7: the control as one record of the six components (ControlState's reference entries, servo integrals and
// leg start strains, its rate factor and leg progress; the state's stresses and stiffnesses), written for every
// state with a physics record or contact radii (formats 2 and 3 otherwise). Formats 1 to 6 are still read.
// 8: format 7 with a checkpoint record after the physics record: JSON text of what a stage carries over a resume
// besides its state (run/stage_output: the series' proof, the controls' errors, warnings, elapsed time), so that a
// checkpoint is one file written by one rename and no kill can leave its parts out of step. Written only for a
// state with such a record (checkpoints); every other state is written as before.
inline constexpr std::uint32_t kStateFormatVersion = 8;
inline constexpr std::uint8_t kStateRotationalFields = 1, kStateRadiusField = 2;

// label says what the state is (e.g. "prepared", "checkpoint:ttc"); physics, when not empty, the physics it
// was made with; checkpoint_record, when not empty, a checkpoint's record (format 8); all are stored and returned.
// Written atomically; a failed write throws IoError (io/files.hpp).
void write_state(const std::string& path, const State& state, const std::string& label,
                 const std::string& physics = "", const std::string& checkpoint_record = "");

// Reads and validates a state file; the pair list holds only the stored contacts until the next rebuild.
// Throws StateFileError with the reason (truncated, corrupted, wrong version, invalid values). `physics`
// receives the record (empty for files written without one, formats 1 to 3 included).
// `checkpoint_record` receives format 8's record (empty for every other file).
State read_state(const std::string& path, std::string* label = nullptr, std::string* physics = nullptr,
                 std::string* checkpoint_record = nullptr);
State parse_state(const std::string& bytes, std::string* label = nullptr, std::string* physics = nullptr,
                  std::string* checkpoint_record = nullptr);
std::string serialize_state(const State& state, const std::string& label, const std::string& physics = "",
                            const std::string& checkpoint_record = "");

}  // namespace celldem
