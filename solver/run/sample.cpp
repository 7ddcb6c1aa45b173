#include "run/sample.hpp"

#include <cmath>
#include <cstdio>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "core/plan.hpp"
#include "core/rng.hpp"
#include "neighbor/neighbor_list.hpp"
#include "run/preflight.hpp"

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
  s.control.reference.head<3>() = s.cell.h.diagonal();
  s.control.reference_volume = s.cell.volume();
  return s;
}

std::vector<double> graded_sample_diameters(const SampleDef& sample) {
  if (!sample.grading) return {};
  Rng rng(sample.seed);
  return draw_diameters(*sample.grading, sample.count, rng);
}

OverlapRelaxation relax_overlaps(const Deck& deck, State& state) {
  OverlapRelaxation r;
  const double deep = keys::prepare_relax_overlaps.max;  // what the run accepts without relaxing
  const Model model = make_model(deck, state.particles.radius);
  state.pairs.skin = skin_length(deck);
  rebuild_pairs(model, state);
  r.before = r.after = overlaps(state, deep);
  if (!deck.prepare || deck.prepare->relax_overlaps <= 0.0) return r;
  r.max_overlap = deck.prepare->relax_overlaps;
  r.factor = overlap_dilation(state, r.max_overlap);
  if (r.factor > 1.0) {
    state.cell.h *= r.factor;
    rebuild_pairs(model, state);
    r.after = overlaps(state, deep);
  }
  return r;
}

PreparationStart preparation_start(const Deck& deck) {
  InitialSample loaded = load_initial_sample(deck);
  PreparationStart start{std::move(loaded.state), std::move(loaded.atom_ids), {}, 0.0};
  start.relaxation = relax_overlaps(deck, start.state);
  begin_stage(start.state);
  start.solid_fraction = make_model(deck, start.state.particles.radius).solid_volume / start.state.cell.volume();
  return start;
}

std::string skipped_fast_leg_note(const Deck& deck, double start_solid_fraction) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "the fast compression is left out: the start fills %.4g of the cell, at or above "
                "prepare.fast_solid_fraction %.4g; the preparation starts with the servo", start_solid_fraction,
                deck.prepare->fast_solid_fraction);
  return buf;
}

namespace {

// `stage` starts each line ("prepare", "tests"); `starts` says it ("starts", "start").
std::string describe_start(const Deck& deck, const PreparationStart& start, int skipped, const std::string& stage,
                           const std::string& starts) {
  const auto who = [&](Index i) {
    return start.atom_ids.empty() ? "particle " + std::to_string(i) : "atom " + std::to_string(start.atom_ids[i]);
  };
  const auto overlap_text = [&](std::string& out, const Overlaps& o) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%lld touching pairs, the deepest overlap %.4g of the smaller radius",
                  static_cast<long long>(o.count), o.worst);
    out += buf;
    if (o.count > 0) out.append(" (").append(who(o.worst_i)).append(" and ").append(who(o.worst_j)).append(")");
  };
  const OverlapRelaxation& r = start.relaxation;
  char buf[160];
  std::string out = stage + ": " + starts + " from ";
  out += initial_state_path(deck);
  std::snprintf(buf, sizeof buf, ", solid fraction %.4g\n%s: as loaded ", start.solid_fraction, stage.c_str());
  out += buf;
  overlap_text(out, r.before);
  if (r.max_overlap > 0.0) {
    std::snprintf(buf, sizeof buf, "\nprepare: relax_overlaps %.4g: cell dilated by %.6g, then ", r.max_overlap,
                  r.factor);
    out += buf;
    overlap_text(out, r.after);
  }
  if (skipped > 0) out.append("\nprepare: ").append(skipped_fast_leg_note(deck, start.solid_fraction));
  return out;
}

}  // namespace

std::string describe_preparation_start(const Deck& deck, const PreparationStart& start, int skipped) {
  return describe_start(deck, start, skipped, "prepare", "starts");
}

std::string describe_test_start(const Deck& deck, const PreparationStart& loaded) {
  return describe_start(deck, loaded, 0, "tests", "start");
}

}  // namespace celldem
