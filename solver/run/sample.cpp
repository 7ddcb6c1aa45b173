#include "run/sample.hpp"

#include <cmath>

#include "core/rng.hpp"

namespace celldem {

State make_grid_sample(const SampleDef& sample, double skin) {
  State s;
  const int n = sample.count;
  int side = 1;
  while (static_cast<long long>(side) * side * side < n) ++side;
  const double length = side * sample.grid_spacing;
  s.cell.h = Mat3::Identity() * length;
  s.particles.resize(n);
  s.pairs.skin = skin;
  Rng rng(sample.seed);
  // A grading's sizes are the rng's first draws, one uniform each (graded_sample_diameters replays them); the
  // listed sizes are drawn one per particle between the jitters, as they always were.
  const std::vector<double> graded = sample.grading ? draw_diameters(*sample.grading, n, rng) : std::vector<double>{};
  for (int i = 0; i < n; ++i) {
    const double d = sample.grading ? graded[i] : sample.diameters[rng.below(sample.diameters.size())];
    s.particles.radius[i] = 0.5 * d;
    const int g[3] = {i % side, (i / side) % side, i / (side * side)};
    // Up to a quarter of the free gap each way: still no overlaps, but no perfect lattice either.
    const double gap = 0.25 * (sample.grid_spacing - d);
    for (int k = 0; k < 3; ++k) {
      const double x = (g[k] + 0.5) * sample.grid_spacing + gap * (2.0 * rng.uniform() - 1.0);
      s.particles.scaled[i][k] = x / length;
    }
  }
  s.control.reference_lengths = s.cell.h.diagonal();
  s.control.reference_volume = s.cell.volume();
  return s;
}

std::vector<double> graded_sample_diameters(const SampleDef& sample) {
  if (!sample.grading) return {};
  Rng rng(sample.seed);
  return draw_diameters(*sample.grading, sample.count, rng);
}

}  // namespace celldem
