// State files (solver/io/state_file.hpp): an exact round trip, and every damaged file (truncated, any
// byte flipped, wrong magic or version, inconsistent contents under a valid checksum) is a StateFileError,
// never a crash or a silently wrong state.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <random>

#include "contact/contact_forces.hpp"
#include "helpers.hpp"
#include "io/state_file.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {

// A small state with everything set to something non-trivial: a sheared cell, velocities, spins,
// control memory and contacts with history (some sliding).
State sample_state() {
  std::mt19937_64 gen(17);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  State s = testing::lattice_state(3, 0.5, Vec3(0.97, 0.98, 0.99), 0.05);
  s.cell.h(0, 1) = 0.1;
  s.cell.h(1, 2) = -0.05;
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    s.particles.radius[i] = 0.5 + 0.01 * u(gen);
    s.particles.scaled[i] += testing::draw_vec3(u, gen) * 1e-3 + Vec3(i % 2, -(int)(i % 3), 0.0);
    s.particles.velocity[i] = testing::draw_vec3(u, gen);
    s.particles.spin[i] = testing::draw_vec3(u, gen) * 3.0;
  }
  s.cell.velocity_gradient = (Mat3() << 1e-3, 2e-4, 0, 0, -1e-3, 0, 0, 5e-5, 0).finished();
  const Model model = make_model(testing::model_deck(1e4, 1e4, 1e-4), s.particles.radius);
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.1, s);  // friction 0.1: some contacts slide
  s.time = 0.123;
  s.steps_since_creation = 1234567;
  s.control.leg_steps = 42;
  s.control.leg_progress = 42.0;  // at the deck's rate (factor 1)
  s.control.leg = 1;
  s.control.stage_steps = 4242;
  s.control.leg_start_strains.head<3>() = Vec3(0.01, -0.002, 0.003);
  s.control.leg_start_volume = 26.5;
  s.control.reference.head<3>() = Vec3(2.9, 2.95, 3.0);
  s.control.reference_volume = 25.6;
  s.control.servo_integral.head<3>() = Vec3(1e3, -2e3, 3.5);
  return s;
}

TEST(StateFile, RoundTripIsExact) {
  const State a = sample_state();
  ASSERT_GT(a.touching, 10);
  const std::string bytes = serialize_state(a, "checkpoint:ttc");
  std::string label;
  const State b = parse_state(bytes, &label);
  EXPECT_EQ(label, "checkpoint:ttc");
  EXPECT_EQ(b.cell.h, a.cell.h);
  EXPECT_EQ(b.cell.velocity_gradient, a.cell.velocity_gradient);
  EXPECT_EQ(b.particles.radius, a.particles.radius);
  EXPECT_EQ(b.particles.scaled, a.particles.scaled);
  EXPECT_EQ(b.particles.velocity, a.particles.velocity);
  EXPECT_EQ(b.particles.spin, a.particles.spin);
  EXPECT_EQ(b.time, a.time);
  EXPECT_EQ(b.steps_since_creation, a.steps_since_creation);
  EXPECT_EQ(b.control.leg_steps, a.control.leg_steps);
  EXPECT_EQ(b.control.leg, a.control.leg);
  EXPECT_EQ(b.control.stage_steps, a.control.stage_steps);
  EXPECT_EQ(b.control.reference.head<3>(), a.control.reference.head<3>());
  EXPECT_EQ(b.control.reference_volume, a.control.reference_volume);
  EXPECT_EQ(b.control.servo_integral, a.control.servo_integral);
  EXPECT_EQ(b.control.leg_start_strains, a.control.leg_start_strains);
  EXPECT_EQ(b.control.leg_start_volume, a.control.leg_start_volume);
  EXPECT_EQ(b.stress.head<3>(), a.stress.head<3>());
  EXPECT_EQ(b.stiffness.head<3>(), a.stiffness.head<3>());
  EXPECT_EQ(b.touching, a.touching);
  EXPECT_EQ(b.pairs.skin, a.pairs.skin);
  const auto ca = stored_contacts(a), cb = stored_contacts(b);
  ASSERT_EQ(ca.size(), cb.size());
  bool any_sliding = false;
  for (std::size_t c = 0; c < ca.size(); ++c) {
    EXPECT_EQ(ca[c].i, cb[c].i);
    EXPECT_EQ(ca[c].j, cb[c].j);
    EXPECT_EQ(ca[c].tangential, cb[c].tangential);
    EXPECT_EQ(ca[c].flags, cb[c].flags);
    any_sliding |= (ca[c].flags & kSliding) != 0;
  }
  EXPECT_TRUE(any_sliding);
  // Writing the parsed state again gives the same bytes.
  EXPECT_EQ(serialize_state(b, "checkpoint:ttc"), bytes);
}

TEST(StateFile, ResumedStateComputesSameForces) {
  const State a = sample_state();
  State b = parse_state(serialize_state(a, "x"));
  const Model model = make_model(testing::model_deck(1e4, 1e4, 1e-4), a.particles.radius);
  State a2 = a;
  rebuild_pairs(model, a2);
  rebuild_pairs(model, b);
  compute_contact_forces(model, 0.1, a2);
  compute_contact_forces(model, 0.1, b);
  EXPECT_EQ(a2.stress.head<3>(), b.stress.head<3>());
  EXPECT_EQ(a2.pairs.force, b.pairs.force);
  EXPECT_EQ(a2.pairs.tangential, b.pairs.tangential);
}

// A state keeps the physics it was made with (format 4 on; 7 with the six-component control record); without a record it is written as before (format 2
// for the linear law), so older readers' files and the record-less ones stay the same bytes.
TEST(StateFile, PhysicsRecordRoundTripsAndSetsFormatSeven) {
  const State a = sample_state();
  const std::string record = R"({"contact.kn":1000000.0,"contact.normal":"linear","sample.density":2650.0})";
  const std::string bytes = serialize_state(a, "prepared", record);
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, sizeof version);
  EXPECT_EQ(version, 7u);
  std::string label, physics;
  const State b = parse_state(bytes, &label, &physics);
  EXPECT_EQ(label, "prepared");
  EXPECT_EQ(physics, record);
  EXPECT_EQ(b.particles.scaled, a.particles.scaled);
  EXPECT_EQ(serialize_state(b, "prepared", record), bytes);
  // The shear components' record: what a leg with shear axes needs to resume bit for bit.
  ASSERT_GT(a.stiffness.tail<3>().minCoeff(), 0.0);
  ASSERT_NE(a.stress.tail<3>(), Vec3::Zero());
  EXPECT_EQ(b.stress.tail<3>(), a.stress.tail<3>());
  EXPECT_EQ(b.stiffness.tail<3>(), a.stiffness.tail<3>());
  EXPECT_EQ(b.stress.head<3>(), a.stress.head<3>());
  State c = a;
  c.control.reference.tail<3>() = Vec3(0.01, -0.02, 0.03);
  c.control.leg_start_strains.tail<3>() = Vec3(1e-3, 0.0, -2e-3);
  c.control.servo_integral.tail<3>() = Vec3(-5.0, 6.0, 7.0);
  const State d = parse_state(serialize_state(c, "prepared", record));
  EXPECT_EQ(d.control.reference.tail<3>(), c.control.reference.tail<3>());
  EXPECT_EQ(d.control.leg_start_strains.tail<3>(), c.control.leg_start_strains.tail<3>());
  EXPECT_EQ(d.control.servo_integral.tail<3>(), c.control.servo_integral.tail<3>());
  // Without a record (format 2): no shear record; the tilts as they stand are the stage's reference.
  const State e = parse_state(serialize_state(c, "prepared"));
  EXPECT_EQ(e.stress.tail<3>(), Vec3::Zero());
  EXPECT_EQ(e.control.reference.tail<3>(), Vec3(c.cell.h(0, 1), c.cell.h(0, 2), c.cell.h(1, 2)));
  std::memcpy(&version, serialize_state(a, "prepared").data() + 8, sizeof version);
  EXPECT_EQ(version, 2u);
  (void)parse_state(serialize_state(a, "prepared"), nullptr, &physics);
  EXPECT_EQ(physics, "");
}

// A checkpoint's record (format 8) travels with its state in one file: returned as written, the state as a format 7
// file holds it, and a state read back and written again with another record keeps its own bytes (a stage's finish
// rewrites its checkpoint's record so). Every other state stays format 7 or older.
TEST(StateFile, CheckpointRecordRoundTripsAndSetsFormatEight) {
  const State a = sample_state();
  const std::string physics = R"({"contact.kn":1000000.0})", record = R"({"elapsed_s":1.5,"warnings":[]})";
  const std::string bytes = serialize_state(a, "stage:ttc", physics, record);
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, sizeof version);
  EXPECT_EQ(version, 8u);
  std::string label, got_physics, got_record;
  const State b = parse_state(bytes, &label, &got_physics, &got_record);
  EXPECT_EQ(label, "stage:ttc");
  EXPECT_EQ(got_physics, physics);
  EXPECT_EQ(got_record, record);
  EXPECT_EQ(serialize_state(b, label, physics, record), bytes);
  const std::string seven = serialize_state(a, "stage:ttc", physics);
  EXPECT_EQ(serialize_state(b, label, physics), seven);  // the same state as a format 7 file holds it
  (void)parse_state(seven, nullptr, nullptr, &got_record);
  EXPECT_EQ(got_record, "");
  const std::string other = serialize_state(b, label, physics, R"({"elapsed_s":2.5})");
  EXPECT_EQ(parse_state(other).particles.velocity, a.particles.velocity);
}

// The adaptive rate's record (the factor and the leg's progress) is part of the control record: a leg resumes
// bit for bit; a factor that is not positive is refused.
TEST(StateFile, AdaptiveRateRecordRoundTrips) {
  const std::string record = R"({"contact.kn":1000000.0})";
  State a = sample_state();
  a.control.rate_factor = 1.953125;
  a.control.leg_progress = 57.3125;
  const std::string bytes = serialize_state(a, "checkpoint:ttc", record);
  const State b = parse_state(bytes);
  EXPECT_EQ(b.control.rate_factor, a.control.rate_factor);
  EXPECT_EQ(b.control.leg_progress, a.control.leg_progress);
  EXPECT_EQ(serialize_state(b, "checkpoint:ttc", record), bytes);
  // A factor that is not positive is refused (under a valid checksum: written by something else).
  State bad = sample_state();
  bad.control.rate_factor = -1.0;
  EXPECT_THROW(parse_state(serialize_state(bad, "x", record)), StateFileError);
}

TEST(StateFile, WriteAndReadThroughAFile) {
  testing::TempDir dir;
  const State a = sample_state();
  const auto path = dir.path() / "s.state";
  write_state(path.string(), a, "prepared");
  EXPECT_FALSE(std::filesystem::exists(path.string() + ".tmp"));
  std::string label;
  const State b = read_state(path.string(), &label);
  EXPECT_EQ(label, "prepared");
  EXPECT_EQ(b.particles.scaled, a.particles.scaled);
  EXPECT_EQ(testing::read_bytes(path), serialize_state(a, "prepared"));
  EXPECT_THROW(read_state((dir.path() / "missing.state").string()), StateFileError);
}

TEST(StateFile, EveryTruncationThrows) {
  const std::string bytes = serialize_state(sample_state(), "t");
  for (std::size_t n = 0; n < bytes.size(); ++n)
    EXPECT_THROW(parse_state(bytes.substr(0, n)), StateFileError) << "truncated to " << n << " bytes";
  EXPECT_THROW(parse_state(bytes + '\0'), StateFileError);  // trailing byte
}

TEST(StateFile, EveryFlippedByteThrows) {
  const std::string bytes = serialize_state(sample_state(), "flip");
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    std::string bad = bytes;
    bad[k] = static_cast<char>(bad[k] ^ 0x5A);
    EXPECT_THROW(parse_state(bad), StateFileError) << "byte " << k << " flipped";
  }
}

TEST(StateFile, WrongMagicAndVersionAreNamed) {
  const std::string bytes = serialize_state(sample_state(), "v");
  std::string bad = bytes;
  bad[0] = 'X';
  try {
    parse_state(bad);
    ADD_FAILURE() << "wrong magic accepted";
  } catch (const StateFileError& e) {
    EXPECT_NE(std::string(e.what()).find("not a celldem state file"), std::string::npos) << e.what();
  }
  bad = bytes;
  const std::uint32_t version = kStateFormatVersion + 1;
  std::memcpy(bad.data() + 8, &version, sizeof version);
  try {
    parse_state(bad);
    ADD_FAILURE() << "wrong version accepted";
  } catch (const StateFileError& e) {
    EXPECT_NE(std::string(e.what()).find("format"), std::string::npos) << e.what();
  }
}

// ---- contents that are wrong under a valid checksum (a file written by something else) ----

// The documented layout: magic (8), version (u32), payload size (u64), payload, FNV-1a 64 of the payload.
std::string wrap(const std::string& payload) {
  std::string out("CELLDEMS", 8);
  const std::uint32_t v = 2;  // the layout of these payloads (no rotational springs)
  out.append(reinterpret_cast<const char*>(&v), 4);
  const std::uint64_t n = payload.size();
  out.append(reinterpret_cast<const char*>(&n), 8);
  out += payload;
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : payload) h = (h ^ c) * 1099511628211ULL;
  out.append(reinterpret_cast<const char*>(&h), 8);
  return out;
}

std::string payload_of(const std::string& file) { return file.substr(20, file.size() - 28); }

template <class T>
void poke(std::string& payload, std::size_t offset, T value) {
  std::memcpy(payload.data() + offset, &value, sizeof value);
}

TEST(StateFile, LayoutIsAsDocumented) {
  const std::string bytes = serialize_state(sample_state(), "layout");
  EXPECT_EQ(wrap(payload_of(bytes)), bytes);  // the same checksum computed independently
}

// Format 1 (before load programs) had no leg start in the control: such files still read, as one leg that
// began at the stage start.
TEST(StateFile, FormatOneFilesStillRead) {
  State s = sample_state();
  s.control.leg_start_strains = Vec6::Zero();
  s.control.leg_start_volume = s.control.reference_volume;
  const std::string label = "v1";
  std::string payload = payload_of(serialize_state(s, label));
  const std::size_t at_leg = 4 + label.size() + 8 + 8 + 16 + 9 * 8 * 2 + 8 + 4 + 8 + 3 * 8 + 8 + 3 * 8;
  payload.erase(at_leg, 3 * 8 + 8);
  std::string v1 = wrap(payload);
  const std::uint32_t one = 1;
  std::memcpy(v1.data() + 8, &one, sizeof one);
  const State b = parse_state(v1);
  EXPECT_EQ(b.cell.h, s.cell.h);
  EXPECT_EQ(b.particles.scaled, s.particles.scaled);
  EXPECT_EQ(b.control.servo_integral, s.control.servo_integral);
  EXPECT_EQ(b.control.leg_start_strains, Vec6::Zero());
  EXPECT_EQ(b.control.leg_start_volume, s.control.reference_volume);
  EXPECT_EQ(b.stress.head<3>(), s.stress.head<3>());
  EXPECT_EQ(serialize_state(b, label), serialize_state(s, label));
}

TEST(StateFile, InvalidContentsUnderValidChecksumThrow) {
  const State s = sample_state();
  const std::string label = "lbl";  // payload: u32 length + 3 bytes, then n (u64) at 7, contacts (u64) at 15
  const std::string good = payload_of(serialize_state(s, label));
  const std::size_t at_n = 4 + label.size(), at_nc = at_n + 8, at_time = at_nc + 8;
  const std::size_t at_h = at_time + 16;             // after time and steps_since_creation
  const std::size_t header = at_h + 9 * 8 * 2 + 8 + 4 + 8 + 3 * 8 + 8 + 3 * 8 + (3 * 8 + 8) + 9 * 8 + 3 * 8 + 8 + 8;
  const std::size_t particle_bytes = 10 * 8;
  ASSERT_NO_THROW(parse_state(wrap(good)));

  auto expect_bad = [&](std::string p, const char* why) {
    EXPECT_THROW(parse_state(wrap(p)), StateFileError) << why;
  };
  {
    std::string p = good;
    poke<std::uint64_t>(p, at_n, 0);
    expect_bad(p, "zero particles");
  }
  {
    std::string p = good;
    poke<std::uint64_t>(p, at_n, ~0ULL);
    expect_bad(p, "absurd particle count");
  }
  {
    std::string p = good;
    poke<std::uint64_t>(p, at_nc, ~0ULL / 2);
    expect_bad(p, "absurd contact count");
  }
  {
    std::string p = good;
    poke<std::uint32_t>(p, 0, 0xFFFFFFFFu);
    expect_bad(p, "over-long label");
  }
  {
    std::string p = good;
    poke<double>(p, at_time, std::nan(""));
    expect_bad(p, "NaN time");
  }
  {
    std::string p = good;
    poke<double>(p, at_h, 0.0);  // h(0,0) = 0: a degenerate cell
    expect_bad(p, "cell without volume");
  }
  {
    std::string p = good;
    poke<double>(p, header, -0.5);  // first radius
    expect_bad(p, "negative radius");
  }
  const std::size_t at_contacts = header + s.particles.size() * particle_bytes;
  {
    std::string p = good;
    poke<Index>(p, at_contacts + 4, 100000);  // first contact's j beyond the particles
    expect_bad(p, "contact index out of range");
  }
  {
    std::string p = good;
    poke<Index>(p, at_contacts, 5);  // i = 5, j = its old value: unsorted or j <= i
    poke<Index>(p, at_contacts + 4, 5);
    expect_bad(p, "contact with j == i");
  }
}

// A header whose payload size is within 8 of 2^64: payload_size + 8 wraps around to the bytes left (here 0
// and 3), so the size check passes and the checksum would be taken over ~2^64 bytes. It must be a
// StateFileError like any other damaged file; run in a child process so that a crash fails only this test.
TEST(StateFile, PayloadSizeNearTwoToThe64ThrowsInsteadOfCrashing) {
  for (std::size_t extra : {0u, 3u}) {
    std::string bytes("CELLDEMS", 8);
    const std::uint32_t v = kStateFormatVersion;
    bytes.append(reinterpret_cast<const char*>(&v), 4);
    const std::uint64_t size = ~std::uint64_t{0} - 7 - extra;  // size + 8 == extra (mod 2^64)
    bytes.append(reinterpret_cast<const char*>(&size), 8);
    bytes.append(extra, 'x');
    EXPECT_EXIT(
        {
          try {
            (void)parse_state(bytes);
          } catch (const StateFileError&) {
            std::exit(0);
          }
          std::exit(1);
        },
        ::testing::ExitedWithCode(0), "")
        << "a " << bytes.size() << "-byte file claiming a payload of 2^64 - " << (8 + extra) << " bytes";
  }
}


// Formats 5 and 6 (the normal axes' record, then the shear axes', then the adaptive rate's) still read: a file
// written in that layout by hand, from the same state, reads back to it, and writes again as format 7.
std::string append_doubles(std::initializer_list<double> xs) {
  std::string out;
  for (const double x : xs) out.append(reinterpret_cast<const char*>(&x), sizeof x);
  return out;
}
std::string with_version(const std::string& payload, std::uint32_t v) {
  std::string out = wrap(payload);
  std::memcpy(out.data() + 8, &v, sizeof v);
  return out;
}

TEST(StateFile, FormatFiveAndSixFilesStillRead) {
  const std::string record = R"({"contact.kn":1000000.0})", label = "old";
  State a = sample_state();
  a.control.reference.tail<3>() = Vec3(0.01, -0.02, 0.03);
  a.control.leg_start_strains.tail<3>() = Vec3(1e-3, 0.0, -2e-3);
  a.control.servo_integral.tail<3>() = Vec3(-5.0, 6.0, 7.0);
  a.control.rate_factor = 1.5, a.control.leg_progress = 61.5;
  const std::string seven = serialize_state(a, label, record);
  const std::string payload = payload_of(seven);
  // The control record starts after the counters (label, record, counts, time, steps, h, L, leg steps, leg,
  // stage steps) and is 34 doubles long in format 7.
  const std::size_t at = 4 + label.size() + 4 + record.size() + 8 + 8 + 8 + 8 + 9 * 8 * 2 + 8 + 4 + 8;
  const std::size_t length = 34 * 8;
  const ControlState& c = a.control;
  const Vec6& s = a.stress;
  const Vec6& k = a.stiffness;
  const std::string five =
      append_doubles({c.reference[0], c.reference[1], c.reference[2], c.reference_volume, c.servo_integral[0],
                      c.servo_integral[1], c.servo_integral[2], c.leg_start_strains[0], c.leg_start_strains[1],
                      c.leg_start_strains[2], c.leg_start_volume,
                      // the stress tensor, column-major, the shear stresses off the diagonal
                      s[0], s[3], s[4], s[3], s[1], s[5], s[4], s[5], s[2], k[0], k[1], k[2], k[3], k[4], k[5],
                      c.reference[3], c.reference[4], c.reference[5], c.leg_start_strains[3], c.leg_start_strains[4],
                      c.leg_start_strains[5], c.servo_integral[3], c.servo_integral[4], c.servo_integral[5]});
  const std::string six = five + append_doubles({c.rate_factor, c.leg_progress});
  std::string p6 = payload;
  p6.replace(at, length, six);
  const State b = parse_state(with_version(p6, 6));
  EXPECT_EQ(serialize_state(b, label, record), seven);  // every field as it was
  std::string p5 = payload;
  p5.replace(at, length, five);
  const State d = parse_state(with_version(p5, 5));
  EXPECT_EQ(d.control.rate_factor, 1.0);  // format 5: the deck's rate
  EXPECT_EQ(d.control.leg_progress, static_cast<double>(a.control.leg_steps));
  EXPECT_EQ(d.control.servo_integral, a.control.servo_integral);
  EXPECT_EQ(d.stress, a.stress);
}

}  // namespace
}  // namespace celldem
