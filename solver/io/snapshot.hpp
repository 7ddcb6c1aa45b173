// Snapshots of a State for viewing (ParaView, OVITO): the particles, the contact network and a time
// collection. The VTK files store their arrays in one of three encodings (SnapshotFormat, the deck's
// `snapshots.format`), all read by ParaView and VTK's XML readers, with the same values bit for bit:
//   binary (default)  VTK XML "appended" format: the XML describes every array and names its offset; the
//                     arrays follow in <AppendedData encoding="raw"> after a '_', each as a UInt64 byte count
//                     and the host's bytes (header_type="UInt64"; byte_order the host's: LittleEndian on
//                     x86-64 and ARM, BigEndian on a big-endian host, which VTK readers swap).
//   zlib              the same, each array compressed in 32 KiB blocks in vtkZLibDataCompressor's layout:
//                     UInt64s [blocks, block size, size of a partial last block or 0, each block's compressed
//                     size], then the blocks (compressor="vtkZLibDataCompressor").
//   ascii             every number as text inside its DataArray, one tuple per line.
// Arrays are Float64, except contacts (Int32), id, i, j, connectivity and offsets (Int64), types and sliding
// (UInt8). The field data (TimeValue, step, cell_h) is stored like the other arrays. The LAMMPS dump and the .pvd
// collections are always text.
//
// Per snapshot at step S, in the writer's folder (the step in plain decimal, not padded):
//   <stem>_S.vtu            VTK XML UnstructuredGrid: one VTK_VERTEX per particle; point data radius,
//                           velocity (the fluctuation v' as stored, not the affine part), spin, contacts
//                           (touching pairs of the particle: its coordination), net_force (its contacts'
//                           forces summed), stress (its particle stress, 9 components row-major, compression
//                           positive: measure/micro.hpp's particle_stresses), id (the celldem particle
//                           index, from 0);
//                           field data TimeValue, step and the cell matrix h (row-major).
//   <stem>_contacts_S.vtp   VTK XML PolyData: one line per touching pair, from the centre of i to
//                           centre(i) + branch (a chain across the periodic boundary is drawn from i
//                           outwards, leaving the cell); cell data branch, normal_force, tangential_force,
//                           sliding (0/1), i, j.
//   <stem>_S.dump           LAMMPS text dump (one file per snapshot; OVITO loads the series with the
//                           wildcard <stem>_*.dump): id radius x y z vx vy vz wx wy wz contacts fx fy fz
//                           c_stress[1] ... c_stress[6], ids from 1 as in `celldem translate` data files;
//                           fx fy fz the net_force and c_stress[1-6] the particle stress of the .vtu, in the
//                           dump's frame (xx yy zz xy xz yz, LAMMPS's order; the names OVITO maps to Force
//                           and Stress Tensor). Unlike LAMMPS's compute stress/atom
//                           the stress is in Pa (not multiplied by the particle's volume) and positive in
//                           compression.
// and two collections listing every snapshot with its time, rewritten after each snapshot:
//   <stem>.pvd              the particle files      <stem>_contacts.pvd   the contact files
// (two collections rather than one with two parts, so ParaView opens each as a plain dataset that the
// Glyph and Tube filters take directly).
//
// The state is taken as the step left it: pair images from the last neighbour-list build, forces, flags
// and contact counts from the last force evaluation (a state just read from a file has no valid images
// until rebuild_pairs, so write its snapshot after the first force evaluation).
//
// Positions are wrapped into the primary cell for viewing: each scaled coordinate into [0, 1), x = h s.
// Text numbers are written with %.17g (they read back to the same double); binary ones are the doubles' bytes. Every file is written to a temporary
// name and renamed (io/files.hpp), the collections last, so a collection never lists a missing file and a
// run cut short still leaves a valid one; a failed write throws IoError "<file>: <what>: <system reason>".
#pragma once
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/choices.hpp"
#include "core/state.hpp"

namespace celldem {

// Scaled position wrapped into [0, 1) per component, and the position h s it gives [m].
Vec3 wrapped_scaled(const Vec3& s);
Vec3 wrapped_position(const Cell& cell, const Vec3& s);

// Touching pairs per particle (each pair counts for both of its particles), from the pair flags of the last
// force evaluation. (N)
std::vector<std::int32_t> contacts_per_particle(const State& state);

// One touching pair as drawn and reported in the contact file.
struct ContactSnapshot {
  Index i = 0, j = 0;
  Vec3 branch = Vec3::Zero();            // [m] h (s_j - s_i + n): from i's centre to the image of j's
  double normal_force = 0.0;             // [N] f . n, n = branch / |branch|; compression positive
  Vec3 tangential_force = Vec3::Zero();  // [N] f - (f . n) n
  bool sliding = false;
};
// The touching pairs of the last force evaluation, in pair-list order. f is pairs.force (on j by i).
std::vector<ContactSnapshot> touching_contacts(const State& state);

// The file contents (no files touched).
std::string particles_vtu(const State& state, std::int64_t step, double time,
                          SnapshotFormat format = SnapshotFormat::Binary);
std::string contacts_vtp(const State& state, std::int64_t step, double time,
                         SnapshotFormat format = SnapshotFormat::Binary);
std::string lammps_dump(const State& state, std::int64_t step);

struct CollectionEntry {
  double time = 0.0;      // [s]
  std::string file;       // relative to the collection's folder
};
std::string pvd_collection(const std::vector<CollectionEntry>& entries);

// Writes snapshots of one run into `dir` (created when the first snapshot is written).
//
// If `<stem>.pvd` already lists snapshots (a run resumed from a checkpoint), the writer continues that
// collection: write(step) first drops every entry at that step or later, so the snapshots of the
// interrupted run after the checkpoint are replaced, and a fresh run from step 0 starts a new collection.
class SnapshotWriter {
 public:
  // stem: letters, digits, '_', '-' or '.' (it goes into file names and XML attributes); else
  // std::invalid_argument.
  SnapshotWriter(std::filesystem::path dir, std::string stem, SnapshotFormat format = SnapshotFormat::Binary);

  void write(const State& state, std::int64_t step, double time);

  const std::filesystem::path& dir() const { return dir_; }
  std::filesystem::path particles_file(std::int64_t step) const;  // dir/<stem>_<step>.vtu
  std::filesystem::path contacts_file(std::int64_t step) const;   // dir/<stem>_contacts_<step>.vtp
  std::filesystem::path dump_file(std::int64_t step) const;       // dir/<stem>_<step>.dump
  std::filesystem::path particles_collection() const;             // dir/<stem>.pvd
  std::filesystem::path contacts_collection() const;              // dir/<stem>_contacts.pvd

 private:
  struct Entry {
    std::int64_t step;
    double time;
  };
  std::filesystem::path dir_;
  std::string stem_;
  SnapshotFormat format_;
  std::vector<Entry> entries_;  // ascending steps
};

}  // namespace celldem
