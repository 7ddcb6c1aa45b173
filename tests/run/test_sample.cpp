// A new sample (solver/run/sample.hpp): the grid, the sizes, no overlaps, and the seed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "core/rng.hpp"
#include "helpers.hpp"
#include "run/sample.hpp"

namespace celldem {
namespace {

SampleDef sample_def(int count, std::uint64_t seed) {
  SampleDef d;
  d.count = count;
  d.diameters = {3e-3, 3.5e-3, 4e-3, 4.5e-3};
  d.density = 2650;
  d.seed = seed;
  d.grid_spacing = 5e-3;
  return d;
}

TEST(Sample, GridOfRequestedSpheresWithoutOverlap) {
  const SampleDef def = sample_def(100, 7);  // 5 per side (125 sites), the first 100 used
  const State s = make_grid_sample(def, 4.5e-4);
  ASSERT_EQ(s.particles.size(), 100u);
  EXPECT_EQ(s.cell.h, Mat3::Identity() * 5 * 5e-3);
  EXPECT_EQ(s.pairs.skin, 4.5e-4);
  EXPECT_EQ(s.control.reference.head<3>(), s.cell.h.diagonal());
  EXPECT_NEAR(s.control.reference_volume, std::pow(25e-3, 3), 1e-18);
  std::set<double> sizes;
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    const double d = 2 * s.particles.radius[i];
    EXPECT_TRUE(std::find(def.diameters.begin(), def.diameters.end(), d) != def.diameters.end()) << d;
    sizes.insert(d);
    for (int k = 0; k < 3; ++k) {
      EXPECT_GE(s.particles.scaled[i][k], 0.0);
      EXPECT_LT(s.particles.scaled[i][k], 1.0);
    }
    EXPECT_EQ(s.particles.velocity[i], Vec3::Zero());
  }
  EXPECT_EQ(sizes.size(), 4u);  // every size drawn
  // No two spheres overlap, through any periodic image.
  double closest = 1e9;
  for (std::size_t i = 0; i < s.particles.size(); ++i)
    for (std::size_t j = i + 1; j < s.particles.size(); ++j) {
      Vec3 ds = s.particles.scaled[j] - s.particles.scaled[i];
      ds -= ds.array().round().matrix();
      const double gap = (s.cell.h * ds).norm() - s.particles.radius[i] - s.particles.radius[j];
      closest = std::min(closest, gap);
    }
  EXPECT_GT(closest, 0.0);
}

TEST(Sample, SameSeedSameSampleOtherSeedOther) {
  const State a = make_grid_sample(sample_def(64, 1), 1e-4);
  const State b = make_grid_sample(sample_def(64, 1), 1e-4);
  const State c = make_grid_sample(sample_def(64, 2), 1e-4);
  EXPECT_EQ(a.particles.radius, b.particles.radius);
  EXPECT_EQ(a.particles.scaled, b.particles.scaled);
  EXPECT_NE(a.particles.scaled, c.particles.scaled);
}

// The listed forms draw as they always did: each particle one size by Rng::below, then its three jitters,
// from one stream seeded by the seed (written out here as the algorithm was), bit for bit.
TEST(Sample, ListedSizesDrawExactlyAsBefore) {
  for (std::uint64_t seed : {1u, 7u, 12345u}) {
    const SampleDef def = sample_def(125, seed);
    const State s = make_grid_sample(def, 1e-4);
    Rng rng(seed);
    const double length = 5 * def.grid_spacing;
    for (int i = 0; i < def.count; ++i) {
      const double d = def.diameters[rng.below(def.diameters.size())];
      ASSERT_EQ(s.particles.radius[i], 0.5 * d) << i;
      const int g[3] = {i % 5, (i / 5) % 5, i / 25};
      const double gap = 0.25 * (def.grid_spacing - d);
      for (int k = 0; k < 3; ++k)
        ASSERT_EQ(s.particles.scaled[i][k], ((g[k] + 0.5) * def.grid_spacing + gap * (2.0 * rng.uniform() - 1.0)) / length);
    }
    EXPECT_TRUE(graded_sample_diameters(def).empty());
  }
}

SampleDef graded_def(int count, std::uint64_t seed) {
  SampleDef d = sample_def(count, seed);
  d.diameters.clear();
  d.grading = GradingDef{GradingBasis::Mass, {2e-3, 3e-3, 4.5e-3}, {0.0, 30.0, 100.0}};
  return d;
}

// A graded sample: the sizes graded_sample_diameters replays, inside the grading's bounds, no overlaps, and
// the seed decides them.
TEST(Sample, GradedSizesAreTheReplayedDrawsWithoutOverlap) {
  const SampleDef def = graded_def(125, 3);
  const State s = make_grid_sample(def, 1e-4);
  const std::vector<double> d = graded_sample_diameters(def);
  ASSERT_EQ(d.size(), 125u);
  std::set<double> sizes;
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_EQ(s.particles.radius[i], 0.5 * d[i]) << i;
    EXPECT_GE(d[i], 2e-3);
    EXPECT_LE(d[i], 4.5e-3);
    sizes.insert(d[i]);
  }
  EXPECT_EQ(sizes.size(), d.size());  // a continuous distribution: no two alike
  double closest = 1e9;
  for (std::size_t i = 0; i < s.particles.size(); ++i)
    for (std::size_t j = i + 1; j < s.particles.size(); ++j) {
      Vec3 ds = s.particles.scaled[j] - s.particles.scaled[i];
      ds -= ds.array().round().matrix();
      closest = std::min(closest, (s.cell.h * ds).norm() - s.particles.radius[i] - s.particles.radius[j]);
    }
  EXPECT_GT(closest, 0.0);
  EXPECT_EQ(make_grid_sample(def, 1e-4).particles.scaled, s.particles.scaled);
  EXPECT_NE(graded_sample_diameters(graded_def(125, 4)), d);
}

}  // namespace
}  // namespace celldem
