// The key table (solver/core/deck_schema.hpp): which contact sub-model choices use which key.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "core/deck.hpp"
#include "core/deck_schema.hpp"

namespace celldem {
namespace {

bool has_sub_models(const KeySpec& k) { return !k.sub_models[0].sub_model.empty(); }

// Every contact key names the sub-model choices that use it; the sub-model keys belong to themselves, with
// every choice.
TEST(DeckSchema, EveryContactKeyBelongsToSubModels) {
  int contact_keys = 0;
  for (const KeySpec* k : keys::kAll) {
    if (!k->path.starts_with("contact.")) continue;
    ++contact_keys;
    EXPECT_TRUE(has_sub_models(*k)) << k->path;
  }
  EXPECT_EQ(contact_keys, 14);
  for (const KeySpec* k : keys::kSubModels) {
    EXPECT_EQ(k->sub_models[0].sub_model, k->name());
    EXPECT_TRUE(k->sub_models[0].choice.empty()) << k->path;
    EXPECT_TRUE(k->sub_models[1].sub_model.empty()) << k->path;
  }
  // Outside contact: only the stages' rolling friction, of rolling: sds.
  std::set<std::string> others;
  for (const KeySpec* k : keys::kAll)
    if (has_sub_models(*k) && !k->path.starts_with("contact.")) others.insert(std::string(k->path));
  EXPECT_EQ(others, (std::set<std::string>{"prepare.rolling_friction", "tests[].rolling_friction"}));
  EXPECT_TRUE(sub_model_uses_valid());
}

// Exactly the parameters without a default are required when their choice is made.
TEST(DeckSchema, RequiredWhenUsed) {
  std::set<std::string> required;
  for (const KeySpec* k : keys::kAll)
    if (k->required_when_used) required.insert(std::string(k->path));
  EXPECT_EQ(required, (std::set<std::string>{"contact.kn", "contact.kt", "contact.youngs_modulus",
                                              "contact.poisson_ratio", "contact.rolling_stiffness",
                                              "contact.rolling_friction"}));
}

// A key used by several choices (E by Hertz's normal law and by both Mindlin laws) is used when any of them is
// made; a key of no sub-model always.
TEST(DeckSchema, KeyUsedByTheChosenSubModels) {
  const SubModelSelection linear{"linear", "linear_history", "none", "none"};
  const SubModelSelection hertz{"hertz", "linear_history", "none", "none"};
  const SubModelSelection rescale{"linear", "mindlin_rescale", "none", "none"};
  const SubModelSelection all{"hertz", "mindlin", "sds", "marshall"};
  EXPECT_FALSE(key_used(keys::contact_youngs_modulus, linear));
  EXPECT_TRUE(key_used(keys::contact_youngs_modulus, hertz));
  EXPECT_TRUE(key_used(keys::contact_youngs_modulus, rescale));
  EXPECT_EQ(chosen_use(keys::contact_youngs_modulus, rescale)->choice, "mindlin_rescale");
  EXPECT_EQ(chosen_use(keys::contact_youngs_modulus, all)->sub_model, "normal");  // the first in table order
  EXPECT_TRUE(key_used(keys::contact_kn, linear));
  EXPECT_FALSE(key_used(keys::contact_kn, hertz));
  EXPECT_TRUE(key_used(keys::contact_kt, hertz));
  EXPECT_FALSE(key_used(keys::contact_kt, rescale));
  EXPECT_FALSE(key_used(keys::contact_rolling_damping, hertz));
  EXPECT_TRUE(key_used(keys::contact_rolling_damping, all));
  EXPECT_FALSE(key_used(keys::test_rolling_friction, linear));
  EXPECT_TRUE(key_used(keys::contact_moment_arm, linear));  // every tangential choice
  EXPECT_TRUE(key_used(keys::contact_normal, hertz));
  EXPECT_TRUE(key_used(keys::time_step, linear));  // no sub-model
  EXPECT_EQ(chosen_use(keys::time_step, linear), nullptr);
}

// A ContactDef names its choices as the deck does, in keys::kSubModels order.
TEST(DeckSchema, SelectionOfAContactLaw) {
  ContactDef c;
  EXPECT_EQ(c.selection(), (SubModelSelection{"linear", "linear_history", "none", "none"}));
  c.normal = NormalModel::Hertz;
  c.tangential = TangentialModel::MindlinRescale;
  c.rolling = RollingModel::Sds;
  c.twisting = TwistingModel::Marshall;
  EXPECT_EQ(c.selection(), (SubModelSelection{"hertz", "mindlin_rescale", "sds", "marshall"}));
  for (std::size_t k = 0; k < keys::kSubModels.size(); ++k) EXPECT_EQ(sub_model_index(keys::kSubModels[k]->name()), k);
  EXPECT_EQ(sub_model_index("damping"), keys::kSubModels.size());
}

}  // namespace
}  // namespace celldem
