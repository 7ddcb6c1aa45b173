// The reference deck against reference values taken from a seed ensemble (tests/run/reference.json,
// made by tests/run/make_reference.sh): the deck's own seed, which is not in the ensemble, must give each
// quantity within its tolerance (the 99.9 % prediction interval of one more seed), as LAMMPS's force-style
// tests keep a reference value with its tolerance beside it.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "helpers.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// "ttc.end_window.ev" in a summary: tests.ttc.end_window.ev; "prepared.Z": prepared.Z.
const Json* find(const Json& summary, const std::string& path) {
  const std::string group = path.substr(0, path.find('.'));
  const Json* node = group == "prepared" ? &summary["prepared"] : &summary["tests"][group];
  std::string rest = path.substr(path.find('.') + 1);
  while (node && !rest.empty()) {
    const auto dot = rest.find('.');
    const std::string key = rest.substr(0, dot);
    node = node->contains(key) ? &(*node)[key] : nullptr;
    rest = dot == std::string::npos ? "" : rest.substr(dot + 1);
  }
  return node;
}

TEST(Reference, SmallDeckWithinTheEnsembleTolerances) {
  const fs::path here = fs::path(__FILE__).parent_path();
  const Json reference = Json::parse(testing::read_bytes(here / "reference.json"));
  const fs::path dir = testing::test_dir("reference");
  const testing::Result r = testing::celldem(dir, testing::run_args(here / "reference_deck.json", dir / "run", "--quiet"));
  ASSERT_EQ(r.code, 0) << r.err;
  const Json summary = Json::parse(testing::read_bytes(dir / "run" / "summary.json"));
  ASSERT_GE(reference["values"].size(), 10u);
  for (const auto& [path, ref] : reference["values"].items()) {
    const Json* value = find(summary, path);
    ASSERT_TRUE(value && value->is_number()) << path << " missing from summary.json";
    EXPECT_NEAR(value->get<double>(), ref["mean"].get<double>(), ref["tolerance"].get<double>()) << path;
  }
}

}  // namespace
}  // namespace celldem
