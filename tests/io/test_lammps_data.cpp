// LAMMPS data files (solver/io/lammps_data.hpp): a state written by `celldem translate` reads back with
// the same radii, positions (to the printed precision, modulo whole cells), velocities, spins and cell; a
// file as LAMMPS write_data writes it (image flags, ids out of order, sections to skip) gives the documented
// state; and every malformed file is an error naming the file and the line.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "helpers.hpp"
#include "io/lammps_data.hpp"
#include "io/translate.hpp"
#include "run/sample.hpp"

namespace celldem {
namespace {

constexpr double kDensity = 2650.0;

// A deck whose sample the translator can type (its diameters), and a grid sample of it in a rectangular
// cell, with velocities, spins and some particles displaced by whole cells.
Deck sample_deck() {
  Deck d = testing::model_deck(1e6, 5e5, 1e-6, kDensity, 0.1, 0.1);
  d.sample.count = 30;
  d.sample.diameters = {3.0e-3, 3.5e-3, 4.0e-3};
  d.sample.grid_spacing = 5.0e-3;
  d.sample.seed = 11;
  return d;
}

State sample_state(const Deck& deck) {
  State s = make_grid_sample(deck.sample, 0.0);
  s.cell.h(1, 1) *= 1.1;
  s.cell.h(2, 2) *= 0.95;
  std::mt19937_64 gen(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    s.particles.scaled[i] += Vec3(double(i % 3) - 1.0, i % 4 == 0 ? 2.0 : 0.0, 0.0);
    s.particles.velocity[i] = testing::draw_vec3(u, gen) * 1e-3;
    s.particles.spin[i] = testing::draw_vec3(u, gen) * 0.7;
  }
  return s;
}

void expect_round_trip(TargetCode code) {
  const Deck deck = sample_deck();
  const State a = sample_state(deck);
  testing::TempDir dir;
  const auto path = dir.path() / "state.data";
  testing::write_bytes(path, translate_data(deck, a, code, "round trip", {}));
  const LammpsData data = read_lammps_data(path);
  const State& b = data.state;

  ASSERT_EQ(b.particles.size(), a.particles.size());
  EXPECT_EQ(b.cell.h, a.cell.h);  // diag(L), lo = 0: the lengths print exactly
  EXPECT_EQ(data.box_low, Vec3::Zero());
  EXPECT_EQ(data.atom_types, 3);
  ASSERT_TRUE(data.common_density.has_value());
  EXPECT_EQ(*data.common_density, kDensity);
  EXPECT_TRUE(data.has_velocities);
  bool any_shifted = false;
  for (std::size_t i = 0; i < a.particles.size(); ++i) {
    EXPECT_EQ(data.ids[i], static_cast<std::int64_t>(i + 1));
    EXPECT_EQ(deck.sample.diameters[data.types[i] - 1], 2.0 * a.particles.radius[i]);
    EXPECT_EQ(data.density[i], kDensity);
    EXPECT_EQ(b.particles.radius[i], a.particles.radius[i]);
    EXPECT_EQ(b.particles.velocity[i], a.particles.velocity[i]);
    EXPECT_EQ(b.particles.spin[i], a.particles.spin[i]);
    // The file holds x = h s wrapped into the cell: the same place up to whole cells and the last digit.
    const Vec3 shift = a.particles.scaled[i] - b.particles.scaled[i];
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(shift[k], std::round(shift[k]), 1e-15) << i;
      EXPECT_GE(b.particles.scaled[i][k], 0.0);
      EXPECT_LT(b.particles.scaled[i][k], 1.0);
    }
    any_shifted |= shift.norm() > 0.5;
    const Vec3 xa = a.cell.h * (a.particles.scaled[i] - shift.array().round().matrix());
    EXPECT_NEAR((b.cell.h * b.particles.scaled[i] - xa).norm(), 0.0, 1e-17);
  }
  EXPECT_TRUE(any_shifted);
  // A new sample: no contacts, nothing in the control memory but the cell.
  EXPECT_EQ(b.pairs.size(), 0u);
  EXPECT_EQ(b.time, 0.0);
  EXPECT_EQ(b.control.reference.head<3>(), a.cell.h.diagonal());
  EXPECT_DOUBLE_EQ(b.control.reference_volume, a.cell.volume());
}

TEST(LammpsData, TranslatedStateReadsBack) { expect_round_trip(TargetCode::Lammps); }
TEST(LammpsData, TranslatedLiggghtsStateReadsBack) { expect_round_trip(TargetCode::Liggghts); }

// As LAMMPS write_data writes it: a title, image flags, ids not in order (and not contiguous), a box that
// does not start at 0, zero tilts, sections to skip.
const char* kWriteDataFile = R"(LAMMPS data file via write_data, version 29 Sep 2021, timestep = 1000, units = si

3 atoms
2 atom types

-0.01 0.01 xlo xhi
0 0.02 ylo yhi
0.005 0.025 zlo zhi
0 0 0 xy xz yz

Pair Coeffs # gran/hooke/history

1
2

Atoms # sphere

7 2 0.004 2500 0.001 0.002 0.003 0 -1 2
2 1 0.003 2500 -0.005 0.019 0.024 1 0 0
4 1 0.003 2600 0.0 0.0 0.005 0 0 0

Velocities

4 0.1 0.2 0.3 1 2 3
7 -0.1 0 0 0 0 -4
2 0 0 0 0 0 0
)";

TEST(LammpsData, WriteDataFileGivesParticlesInIdOrder) {
  const LammpsData d = parse_lammps_data(kWriteDataFile, "w.data");
  const State& s = d.state;
  ASSERT_EQ(s.particles.size(), 3u);
  EXPECT_EQ(d.ids, (std::vector<std::int64_t>{2, 4, 7}));
  EXPECT_EQ(d.types, (std::vector<int>{1, 1, 2}));
  EXPECT_EQ(d.density, (std::vector<double>{2500, 2600, 2500}));
  EXPECT_FALSE(d.common_density.has_value());
  EXPECT_EQ(d.box_low, Vec3(-0.01, 0.0, 0.005));
  EXPECT_EQ(s.cell.h, Mat3(Vec3(0.01 - -0.01, 0.02 - 0.0, 0.025 - 0.005).asDiagonal()));
  EXPECT_EQ(s.particles.radius, (std::vector<double>{0.0015, 0.0015, 0.002}));
  // s = (x - lo) / L + image flags.
  const Vec3 expected[3] = {Vec3(0.25 + 1, 0.95, 0.95), Vec3(0.5, 0.0, 0.0), Vec3(0.55, 0.1 - 1, -0.1 + 2)};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(s.particles.scaled[i][k], expected[i][k], 1e-14) << i << " " << k;
  EXPECT_EQ(s.particles.velocity[1], Vec3(0.1, 0.2, 0.3));
  EXPECT_EQ(s.particles.spin[1], Vec3(1, 2, 3));
  EXPECT_EQ(s.particles.velocity[2], Vec3(-0.1, 0, 0));
  EXPECT_EQ(s.particles.spin[2], Vec3(0, 0, -4));
  EXPECT_EQ(s.particles.velocity[0], Vec3::Zero());
}

TEST(LammpsData, VelocitiesAreOptional) {
  std::string text = kWriteDataFile;
  text.erase(text.find("Velocities"));
  const LammpsData d = parse_lammps_data(text, "w.data");
  EXPECT_FALSE(d.has_velocities);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(d.state.particles.velocity[i], Vec3::Zero());
    EXPECT_EQ(d.state.particles.spin[i], Vec3::Zero());
  }
}

// The text with `from` replaced by `to` (which must be there).
std::string edited(const std::string& from, const std::string& to) {
  std::string text = kWriteDataFile;
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

// The error message: "w.data:<line>: ..." with the given line and words.
void expect_error(const std::string& text, int line, const std::string& words) {
  try {
    parse_lammps_data(text, "w.data");
    ADD_FAILURE() << "no error; expected: " << words;
  } catch (const LammpsDataError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("w.data:" + std::to_string(line) + ": ", 0), 0u) << message;
    EXPECT_NE(message.find(words), std::string::npos) << message;
  }
}

TEST(LammpsData, MalformedFilesAreErrorsNamingTheLine) {
  expect_error(edited("0 0 0 xy xz yz", "0.001 0 0 xy xz yz"), 9, "triclinic boxes are not supported");
  expect_error(edited("Atoms # sphere", "Atoms # atomic"), 16, "unsupported atom style \"atomic\"");
  expect_error(edited("Atoms # sphere", "Bonds"), 16, "unsupported section \"Bonds\"");
  expect_error(edited("3 atoms", "4 atoms"), 16, "the Atoms section has 3 lines, but the header says 4 atoms");
  expect_error(edited("4 1 0.003", "7 1 0.003"), 20, "duplicate atom id 7 (also on line 18)");
  expect_error(edited("2 1 0.003 2500 -0.005", "2 1 -0.003 2500 -0.005"), 19, "diameter -0.003: must be positive");
  expect_error(edited("2 1 0.003 2500 -0.005", "2 1 0 2500 -0.005"), 19, "diameter 0: must be positive");
  expect_error(edited("0.019 0.024", "nan 0.024"), 19, "\"nan\" is not finite");
  expect_error(edited("0.019 0.024", "0.0x9 0.024"), 19, "\"0.0x9\" is not a number");
  expect_error(edited("0.003 0 -1 2", "0.003 0 -1"), 18, "expected 7 or 10 columns");
  expect_error(edited("7 2 0.004", "7 3 0.004"), 18, "atom type 3 is outside 1..2");
  expect_error(edited("-0.01 0.01 xlo xhi", "0.01 -0.01 xlo xhi"), 6, "xlo xhi: the low bound must be below");
  expect_error(edited("2 0 0 0 0 0 0", "2 0 0 0 0 0"), 26, "Velocities: expected 7 columns");
  expect_error(edited("2 0 0 0 0 0 0", "5 0 0 0 0 0 0"), 26, "atom id 5 is not in the Atoms section");
  expect_error(edited("2 0 0 0 0 0 0", "7 0 0 0 0 0 0"), 26, "Velocities: duplicate atom id 7 (also on line 25)");
  expect_error(edited("2 0 0 0 0 0 0\n", ""), 22, "Velocities: no line for atom id 2");
  expect_error(edited("0 0.02 ylo yhi", "0 0.02 ylo yhigh"), 7, "unrecognised header line");
  expect_error(edited("2 atom types", "2 atom types\n5 bonds"), 5, "atom_style sphere has no bonds");
  // Whole-file problems are reported at line 0.
  std::string no_atoms = kWriteDataFile;
  no_atoms.erase(no_atoms.find("Atoms # sphere"));
  expect_error(no_atoms, 0, "no Atoms section");
  expect_error(edited("3 atoms\n", ""), 0, "no \"N atoms\" header line");
  expect_error(edited("0.005 0.025 zlo zhi\n", ""), 0, "no \"zlo zhi\" header line");
  // Accepted: zero tilts (above), an untyped Atoms section, LIGGGHTS's name for the same columns,
  // topology counts of 0 and comments anywhere.
  EXPECT_NO_THROW(parse_lammps_data(edited("Atoms # sphere", "Atoms"), "w.data"));
  EXPECT_NO_THROW(parse_lammps_data(edited("Atoms # sphere", "Atoms # granular"), "w.data"));
  EXPECT_NO_THROW(parse_lammps_data(edited("2 atom types", "2 atom types # two sizes\n0 bonds\n0 bond types"), "w.data"));
}

TEST(LammpsData, UnreadableFileIsAnErrorNamingIt) {
  testing::TempDir dir;
  const auto path = dir.path() / "missing.data";
  try {
    read_lammps_data(path);
    ADD_FAILURE() << "no error";
  } catch (const LammpsDataError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path.string() + ": ", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("No such file"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace celldem
