// Bring your own packing, see the packing: a state translated to a LAMMPS data file and imported as
// `initial_state` runs the same test as the state itself (to the series' printed precision: a data file
// holds positions wrapped into the box, so the arithmetic differs at round-off); a data file whose density
// contradicts the deck is refused naming both; snapshots and the peak contact network are written as asked.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.hpp"
#include "helpers.hpp"
#include "measure/series.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;
using testing::celldem;
using testing::read_bytes;
using testing::Result;
using testing::run_args;
using testing::write_bytes;

using testing::read_series;

const std::string kTest = R"([{"name": "ttc", "friction": 0.5, "output_interval": 200,
    "axes": {"x1": {"strain_increment": 2e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
    "end": {"axis": "x1", "strain": 0.004}, "snapshots": {"interval": 1000, "e1": [0.003]}}])";

std::string deck_from(const std::string& state) {
  std::string d = testing::small_deck_json(200, kTest);
  const auto at = d.find("\"prepare\"");
  return d.replace(at, d.find("}},", at) + 3 - at, "\"initial_state\": \"" + state + "\",");
}

// In `dir`: a 200-sphere sample (prep/prepared.state), the deck a.json that tests it, and its LAMMPS data file
// (lmp/state.data) made by the translator.
void prepare_and_translate(const fs::path& dir) {
  write_bytes(dir / "prep.json", testing::small_deck_json(200, "[]"));
  ASSERT_EQ(celldem(dir, run_args(dir / "prep.json", dir / "prep")).code, 0);
  write_bytes(dir / "a.json", deck_from("prep/prepared.state"));
  const Result r = celldem(dir, "translate '" + (dir / "a.json").string() + "' --to lammps --state '" +
                                    (dir / "prep" / "prepared.state").string() + "' --out '" + (dir / "lmp").string() + "'");
  ASSERT_EQ(r.code, 0) << r.err;
}

TEST(Import, LammpsDataFileRunsLikeTheStateItCameFrom) {
  const fs::path dir = testing::test_dir("import_" + std::to_string(getpid()));
  ASSERT_NO_FATAL_FAILURE(prepare_and_translate(dir));
  write_bytes(dir / "b.json", deck_from("lmp/state.data"));
  ASSERT_EQ(celldem(dir, run_args(dir / "a.json", dir / "ra")).code, 0);
  Result r = celldem(dir, run_args(dir / "b.json", dir / "rb"));
  ASSERT_EQ(r.code, 0) << r.err;
  const std::vector<SeriesRow> a = read_series(dir / "ra" / "ttc" / "series.csv");
  const std::vector<SeriesRow> b = read_series(dir / "rb" / "ttc" / "series.csv");
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), 11u);
  for (std::size_t k = 0; k < a.size(); ++k)
    for (const SeriesColumn& c : series_columns()) {
      const double x = a[k].*c.field, y = b[k].*c.field;
      if (std::isnan(x)) {
        EXPECT_TRUE(std::isnan(y)) << c.name << " row " << k;
        continue;
      }
      // Printed to 10 digits: equal up to the last printed digit or two.
      EXPECT_NEAR(y, x, 1e-8 * std::max(1e-3 * std::abs(a[k].p), std::abs(x)) + 1e-300) << c.name << " row " << k;
    }

  // The deck's density must be the file's.
  std::string other = deck_from("lmp/state.data");
  other.replace(other.find("\"density\": 2650"), 15, "\"density\": 3000");  // heavier: the time step stays valid
  write_bytes(dir / "c.json", other);
  r = celldem(dir, "check '" + (dir / "c.json").string() + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("sample.density"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("2650"), std::string::npos) << r.err;

  // Snapshots at the start, every 1000 steps, at e1 = 0.3 % and at the end; the peak row's contacts.
  for (const char* f : {"ttc.pvd", "ttc_contacts.pvd", "ttc_0.vtu", "ttc_contacts_0.vtp", "ttc_0.dump",
                        "ttc_1000.vtu", "ttc_2000.vtu"})
    EXPECT_TRUE(fs::exists(dir / "ra" / "ttc" / "snapshots" / f)) << f;
  int e1_snapshots = 0;
  for (const auto& e : fs::directory_iterator(dir / "ra" / "ttc" / "snapshots"))
    e1_snapshots += e.path().extension() == ".vtu" ? 1 : 0;
  EXPECT_EQ(e1_snapshots, 4);  // steps 0, 1000, 1500-ish (e1 = 0.3 %) and 2000 (the end)
  const auto meta = nlohmann::json::parse(read_bytes(dir / "ra" / "ttc" / "peak_contacts.json"));
  const auto summary = nlohmann::json::parse(read_bytes(dir / "ra" / "summary.json"));
  EXPECT_EQ(meta["ratio13"], summary["tests"]["ttc"]["peak_ratio13"]);
  const std::string chains = read_bytes(dir / "ra" / "ttc" / "peak_contacts.csv");
  EXPECT_GT(std::count(chains.begin(), chains.end(), '\n'), 200);
}

// A state keeps the physics it was made with: a deck that disagrees (density, contact law or its stiffness)
// is refused naming both values, unless it overrides them on purpose, which the run's warnings record.
TEST(Import, StateAndDeckMustAgreeOnThePhysics) {
  const fs::path dir = testing::test_dir("physics_" + std::to_string(getpid()));
  write_bytes(dir / "prep.json", testing::small_deck_json(200, "[]"));
  ASSERT_EQ(celldem(dir, run_args(dir / "prep.json", dir / "prep")).code, 0);
  const std::string same = deck_from("prep/prepared.state");
  write_bytes(dir / "same.json", same);
  Result r = celldem(dir, "check '" + (dir / "same.json").string() + "'");
  EXPECT_EQ(r.code, 0) << r.err;

  std::string density = same;
  density.replace(density.find("\"density\": 2650"), 15, "\"density\": 3000");
  write_bytes(dir / "density.json", density);
  r = celldem(dir, "check '" + (dir / "density.json").string() + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("sample.density: the deck says 3000, the state was made with 2650"), std::string::npos) << r.err;

  std::string stiffer = same;
  stiffer.replace(stiffer.find("\"kn\": 1.0e6"), 11, "\"kn\": 2.0e6");
  write_bytes(dir / "stiffer.json", stiffer);
  r = celldem(dir, "check '" + (dir / "stiffer.json").string() + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("contact.kn: the deck says 2e+06, the state was made with 1e+06"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("override_state_physics"), std::string::npos) << r.err;

  std::string hertz = same;
  hertz.replace(hertz.find("\"time_step\": 3.0e-6"), 19, "\"time_step\": 1.0e-6");  // within Hertz's limit
  const std::string linear = "\"kn\": 1.0e6, \"kt\": 1.0e6";
  hertz.replace(hertz.find(linear), linear.size(),
                "\"normal\": \"hertz\", \"tangential\": \"mindlin\", \"youngs_modulus\": 7e7, \"poisson_ratio\": 0.3");
  write_bytes(dir / "hertz.json", hertz);
  r = celldem(dir, "check '" + (dir / "hertz.json").string() + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("contact.normal: the deck says hertz, the state was made with linear"), std::string::npos) << r.err;

  stiffer.replace(stiffer.find("\"initial_state\""), 0, "\"override_state_physics\": true, ");
  write_bytes(dir / "override.json", stiffer);
  r = celldem(dir, run_args(dir / "override.json", dir / "override"));
  EXPECT_EQ(r.code, 0) << r.err;
  const auto summary = nlohmann::json::parse(read_bytes(dir / "override" / "summary.json"));
  EXPECT_NE(summary.dump().find("override_state_physics: initial_state"), std::string::npos) << summary.dump();
}

// The data file with atom 1 moved to atom 2's position plus `offset` of the sum of their radii along x.
std::string move_atom_onto_another(const std::string& data, double offset) {
  std::istringstream in(data);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::size_t first = 0;
  while (lines[first].rfind("Atoms", 0) != 0) ++first;
  first += 2;  // the header line and a blank line
  auto fields = [&](std::size_t k) {
    std::istringstream ss(lines[k]);
    std::vector<std::string> f;
    for (std::string w; ss >> w;) f.push_back(w);
    return f;
  };
  std::size_t one = first, two = first;
  for (std::size_t k = first; k < lines.size() && !lines[k].empty(); ++k) {
    if (fields(k)[0] == "1") one = k;
    if (fields(k)[0] == "2") two = k;
  }
  std::vector<std::string> a = fields(one), b = fields(two);
  const double reach = 0.5 * (std::stod(a[2]) + std::stod(b[2]));
  std::ostringstream x;
  x.precision(17);
  x << std::stod(b[4]) + offset * reach;
  b[4] = x.str();
  std::string moved = a[0] + " " + a[1] + " " + a[2] + " " + a[3];
  for (std::size_t k = 4; k < b.size(); ++k) moved += " " + b[k];
  std::ostringstream out;
  for (std::size_t k = 0; k < lines.size(); ++k) out << (k == one ? moved : lines[k]) << "\n";
  return out.str();
}

// An imported packing with deep overlaps is reported by check (count, deepest, the atoms), not blamed on the
// time step later; two atoms at the same place are refused naming them.
TEST(Import, DeepOverlapsAreReportedAndCoincidentAtomsRefused) {
  const fs::path dir = testing::test_dir("overlaps_" + std::to_string(getpid()));
  ASSERT_NO_FATAL_FAILURE(prepare_and_translate(dir));
  Result r = celldem(dir, "check '" + (dir / "a.json").string() + "'");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("touching pairs overlap"), std::string::npos) << "a prepared packing overlaps slightly: " << r.err;

  const std::string data = read_bytes(dir / "lmp" / "state.data");
  write_bytes(dir / "lmp" / "deep.data", move_atom_onto_another(data, 0.5));
  write_bytes(dir / "deep.json", deck_from("lmp/deep.data"));
  r = celldem(dir, "check '" + (dir / "deep.json").string() + "'");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("touching pairs overlap by more than 0.05 of the smaller radius, the deepest"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("atom 1 and atom 2"), std::string::npos) << r.err;

  write_bytes(dir / "lmp" / "same.data", move_atom_onto_another(data, 0.0));
  write_bytes(dir / "same.json", deck_from("lmp/same.data"));
  r = celldem(dir, "check '" + (dir / "same.json").string() + "'");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("atom 1 and atom 2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("same place"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace celldem
