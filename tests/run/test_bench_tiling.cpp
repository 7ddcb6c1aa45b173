// The bench's periodic copies (run/bench.hpp tile_state): each copy's particles and contacts, and the first list
// built with the skin the original's list had adapted to, so that a large sample's few timed steps run on a list
// like the original's after its warm-up.
#include <gtest/gtest.h>

#include "helpers.hpp"
#include "neighbor/neighbor_list.hpp"
#include "run/bench.hpp"

namespace celldem {
namespace {

TEST(TileState, CopiesKeepTheListsAdaptedSkinAndListAsManyPairsPerParticle) {
  State s = testing::jostled_lattice(6, 3, 0.02, 0.0, 0.0);
  s.pairs.skin = 0.5;  // wide enough to list the diagonal neighbours (1.39 apart, contact at 1)
  const Deck deck = testing::model_deck(1e4, 1e4, 1e-3, testing::kUnitMassDensity, 0.1, 0.1);
  const Model model = make_model(deck, s.particles.radius);
  rebuild_pairs(model, s);
  const double wide = static_cast<double>(s.pairs.size()) / static_cast<double>(s.particles.size());
  s.pairs.build_skin = 0.25 * s.pairs.skin;  // as adapt_skin leaves it after long-lived lists
  rebuild_pairs(model, s);
  const double adapted = static_cast<double>(s.pairs.size()) / static_cast<double>(s.particles.size());
  ASSERT_LT(adapted, wide);  // the premise: the narrower skin lists fewer pairs apart

  State t = tile_state(s, 8);
  ASSERT_EQ(t.particles.size(), 8 * s.particles.size());
  EXPECT_EQ(t.pairs.current_skin(), s.pairs.current_skin());
  const Model tiled_model = make_model(deck, t.particles.radius);
  rebuild_pairs(tiled_model, t);
  EXPECT_DOUBLE_EQ(static_cast<double>(t.pairs.size()) / static_cast<double>(t.particles.size()), adapted);
}

}  // namespace
}  // namespace celldem
