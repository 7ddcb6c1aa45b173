// Bring your own packing, see the packing: a state translated to a LAMMPS data file and imported as
// `initial_state` runs the same test as the state itself (to the series' printed precision: a data file
// holds positions wrapped into the box, so the arithmetic differs at round-off); a data file whose density
// contradicts the deck is refused naming both; snapshots and the peak contact network are written as asked.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.hpp"
#include "helpers.hpp"
#include "io/state_file.hpp"
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

  // A state of the older formats (2 and 3, which write_state still writes without a record) holds no physics
  // to check the deck against: check and run say that nothing was checked; a state with a record is not warned of.
  EXPECT_EQ(celldem(dir, "check '" + (dir / "same.json").string() + "'").err.find("records no physics"),
            std::string::npos);
  write_state((dir / "old.state").string(), read_state((dir / "prep" / "prepared.state").string()), "prepared");
  std::string record = "unread";
  read_state((dir / "old.state").string(), nullptr, &record);
  ASSERT_TRUE(record.empty());
  write_bytes(dir / "old.json", deck_from("old.state"));
  for (const std::string& cmd : {"check '" + (dir / "old.json").string() + "'", run_args(dir / "old.json", dir / "old")}) {
    r = celldem(dir, cmd);
    EXPECT_EQ(r.code, 0) << cmd << ": " << r.err;
    EXPECT_NE(r.err.find("old.state records no physics"), std::string::npos) << cmd << ": " << r.err;
    EXPECT_NE(r.err.find("nothing was checked"), std::string::npos) << r.err;
  }
  EXPECT_NE(read_bytes(dir / "old" / "summary.json").find("records no physics"), std::string::npos);
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

// An imported packing with deep overlaps is refused by check (count, deepest, the atoms), not blamed on the
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
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("touching pairs overlap by more than 0.05 of the smaller radius, the deepest"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("atom 1 and atom 2"), std::string::npos) << r.err;
  // Without a preparation the soft start needs one: the message says how.
  EXPECT_NE(r.err.find("\"prepare\" beside \"initial_state\") with \"prepare.relax_overlaps\""), std::string::npos) << r.err;

  write_bytes(dir / "lmp" / "same.data", move_atom_onto_another(data, 0.0));
  write_bytes(dir / "same.json", deck_from("lmp/same.data"));
  r = celldem(dir, "check '" + (dir / "same.json").string() + "'");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("atom 1 and atom 2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("same place"), std::string::npos) << r.err;
}

// A LAMMPS data file of `n` spheres of the small deck's diameters (3 to 4.5 mm, density 2650) at random places in
// a cube filled to `solid_fraction`; `apart`: each placed where it overlaps none before it (a loose packing),
// otherwise anywhere (a `create_atoms random` file, deep overlaps included).
struct Sphere {
  double d;
  Vec3 x;
};
void random_spheres(int n, double solid_fraction, bool apart, std::uint64_t seed, std::vector<Sphere>& s, double& box) {
  std::mt19937_64 rng(seed);
  const auto uniform = [](std::mt19937_64& g) { return static_cast<double>(g() >> 11) * 0x1.0p-53; };
  s.assign(n, {});
  double solid = 0.0;
  for (Sphere& p : s) {
    p.d = 3.0e-3 + 0.5e-3 * static_cast<double>(rng() % 4);
    solid += M_PI / 6.0 * p.d * p.d * p.d;
  }
  box = std::cbrt(solid / solid_fraction);
  for (std::size_t i = 0; i < s.size(); ++i)
    for (int tries = 0;; ++tries) {
      ASSERT_LT(tries, 100000);
      s[i].x = testing::draw_vec3(uniform, rng) * box;
      bool free = true;
      for (std::size_t j = 0; apart && free && j < i; ++j) {
        Vec3 b = s[i].x - s[j].x;
        for (int k = 0; k < 3; ++k) b[k] -= box * std::round(b[k] / box);
        free = b.norm() > 0.5 * (s[i].d + s[j].d);
      }
      if (free) break;
    }
}

void write_data_file(const fs::path& path, const std::vector<Sphere>& spheres, double box) {
  std::ostringstream o;
  o.precision(17);
  o << "random spheres\n\n" << spheres.size() << " atoms\n4 atom types\n\n0 " << box << " xlo xhi\n0 " << box
    << " ylo yhi\n0 " << box << " zlo zhi\n\nAtoms # sphere\n\n";
  for (std::size_t i = 0; i < spheres.size(); ++i)
    o << i + 1 << " " << std::lround((spheres[i].d - 3.0e-3) / 0.5e-3) + 1 << " " << spheres[i].d << " 2650 "
      << spheres[i].x.x() << " " << spheres[i].x.y() << " " << spheres[i].x.z() << "\n";
  write_bytes(path, o.str());
}

// The small deck preparing `count` spheres from `state` (with the extra prepare keys `prepare_extra`).
std::string deck_preparing(int count, const std::string& state, const std::string& tests,
                           const std::string& prepare_extra = "") {
  std::string d = testing::small_deck_json(count, tests);
  d.replace(d.find("\"prepare\": {"), 12, "\"initial_state\": \"" + state + "\",\n  \"prepare\": {" + prepare_extra);
  return d;
}

// The smallest isotropic dilation after which no pair overlaps by more than f of its smaller radius, by brute
// force over all pairs (nearest periodic image): the oracle of the soft start's factor.
double dilation_by_brute_force(const std::vector<Sphere>& s, double box, double f, double* worst = nullptr) {
  double factor = 1.0;
  for (std::size_t i = 0; i < s.size(); ++i)
    for (std::size_t j = i + 1; j < s.size(); ++j) {
      Vec3 b = s[i].x - s[j].x;
      for (int k = 0; k < 3; ++k) b[k] -= box * std::round(b[k] / box);
      const double ri = 0.5 * s[i].d, rj = 0.5 * s[j].d;
      factor = std::max(factor, (ri + rj - f * std::min(ri, rj)) / b.norm());
      if (worst) *worst = std::max(*worst, (ri + rj - b.norm()) / std::min(ri, rj));
    }
  return factor;
}

const std::string kShortTtc = R"([{"name": "ttc", "friction": 0.5, "output_interval": 100,
    "axes": {"x1": {"strain_increment": 4e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
    "end": {"axis": "x1", "strain": 0.001}}])";

// A user's loose packing (LAMMPS data file, solid fraction 0.2) becomes a sample: the preparation compresses
// it from there to the target pressure, the plan counts the fast leg from its solid fraction, and the test runs
// from the run's prepared.state. A prepared state denser than fast_solid_fraction prepares again with the servo
// alone (a fast leg there would end after no step).
TEST(Import, LoosePackingIsPreparedFromItsOwnSolidFraction) {
  const fs::path dir = testing::test_dir("loose_" + std::to_string(getpid()));
  double box = 0.0;
  std::vector<Sphere> spheres;
  ASSERT_NO_FATAL_FAILURE(random_spheres(300, 0.2, true, 7, spheres, box));
  write_data_file(dir / "loose.data", spheres, box);
  write_bytes(dir / "a.json", deck_preparing(300, "loose.data", kShortTtc));

  // plan: the fast leg from 0.2 to 0.55 at 1e-4 per step (each axis at strain n 1e-4 after n steps), then the
  // servo's min_steps..max_steps; each leg listed as a test's.
  Result r = celldem(dir, "plan '" + (dir / "a.json").string() + "' --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto plan = nlohmann::json::parse(r.out);
  EXPECT_NEAR(plan["prepare"]["start"]["solid_fraction"].get<double>(), 0.2, 1e-12);
  EXPECT_EQ(plan["prepare"]["start"]["fast_leg_skipped"], false);
  std::int64_t fast = 0;
  while (0.2 / std::pow(1.0 - static_cast<double>(fast) * 1e-4, 3) < 0.55) ++fast;
  EXPECT_EQ(plan["prepare"]["steps"]["low"].get<std::int64_t>(), fast + 1000);
  EXPECT_EQ(plan["prepare"]["steps"]["high"].get<std::int64_t>(), fast + 200000);
  const auto& legs = plan["prepare"]["legs"];
  ASSERT_EQ(legs.size(), 2u) << legs;
  EXPECT_EQ(legs[0]["steps"]["low"], fast);
  EXPECT_EQ(legs[0]["end"]["solid_fraction"], 0.55);
  EXPECT_EQ(legs[0]["driving_increment"], 1e-4);
  EXPECT_EQ(legs[1]["end"]["equilibrium"], true);
  EXPECT_EQ(legs[1]["servo"], true);
  EXPECT_TRUE(legs[1]["rows"].is_null());
  EXPECT_TRUE(plan["prepare"]["rows"].is_null());
  r = celldem(dir, "plan '" + (dir / "a.json").string() + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("leg 0: ends at solid fraction 0.55, " + std::to_string(fast) + " steps"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("leg 1: ends in equilibrium"), std::string::npos) << r.out;
  r = celldem(dir, "check '" + (dir / "a.json").string() + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("prepare: starts from"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("solid fraction 0.2"), std::string::npos) << r.out;

  r = celldem(dir, run_args(dir / "a.json", dir / "ra"));
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const auto summary = nlohmann::json::parse(read_bytes(dir / "ra" / "summary.json"));
  const auto& prepared = summary["prepared"];
  EXPECT_NEAR(prepared["started_from"]["solid_fraction"].get<double>(), 0.2, 1e-12);
  EXPECT_EQ(prepared["started_from"]["overlaps"]["touching_pairs"], 0);
  EXPECT_NE(prepared["started_from"]["initial_state"].get<std::string>().find("loose.data"), std::string::npos);
  EXPECT_FALSE(prepared["started_from"].contains("skipped"));
  EXPECT_NEAR(prepared["p"].get<double>(), 1e5, 0.01 * 1e5);
  EXPECT_GT(prepared["steps"].get<std::int64_t>(), fast);
  // The fast leg took the planned steps and wrote the planned rows: its end is the first row off the output
  // interval (500), and the rows up to it are the ones listed.
  const std::vector<SeriesRow> prep_rows = read_series(dir / "ra" / "prepare" / "series.csv");
  ASSERT_NE(fast % 500, 0);
  std::int64_t first_off = -1, rows_to_it = 0;
  for (const SeriesRow& row : prep_rows) {
    ++rows_to_it;
    if (std::llround(row.step) % 500 != 0) {
      first_off = std::llround(row.step);
      break;
    }
  }
  EXPECT_EQ(first_off, fast);
  EXPECT_EQ(rows_to_it, legs[0]["rows"].get<std::int64_t>());
  EXPECT_GT(prepared["void_ratio"].get<double>(), 0.45);  // frictionless, 300 spheres: about 0.55-0.6
  EXPECT_LT(prepared["void_ratio"].get<double>(), 0.75);
  EXPECT_GT(prepared["Zm"].get<double>(), 5.0);
  std::printf("loose packing: %lld preparation steps (fast %lld), e %.4f, Z %.3f, Zm %.3f\n",
              static_cast<long long>(prepared["steps"].get<std::int64_t>()), static_cast<long long>(fast),
              prepared["void_ratio"].get<double>(), prepared["Z"].get<double>(), prepared["Zm"].get<double>());
  // The test starts from the prepared state (at 1e5 Pa), not from the loose file (no contacts, p = 0).
  const std::vector<SeriesRow> rows = read_series(dir / "ra" / "ttc" / "series.csv");
  ASSERT_GT(rows.size(), 2u);
  EXPECT_NEAR(rows.front().p, prepared["p"].get<double>(), 1e-6 * 1e5);
  EXPECT_FALSE(summary.contains("initial_state"));

  // From the prepared state (denser than 0.55) to 2e5 Pa: the servo alone, noted in the log and summary.
  std::string again = deck_preparing(300, "ra/prepared.state", "[]");
  again.replace(again.find("\"target_pressure\": 1.0e5"), 24, "\"target_pressure\": 2.0e5");
  write_bytes(dir / "b.json", again);
  r = celldem(dir, "plan '" + (dir / "b.json").string() + "' --json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(r.out)["prepare"]["start"]["fast_leg_skipped"], true);
  EXPECT_EQ(nlohmann::json::parse(r.out)["prepare"]["steps"]["low"], 1000);
  r = celldem(dir, run_args(dir / "b.json", dir / "rb"));
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("the fast compression is left out"), std::string::npos) << r.out;
  const auto b = nlohmann::json::parse(read_bytes(dir / "rb" / "summary.json"))["prepared"];
  EXPECT_NE(b["started_from"]["skipped"].get<std::string>().find("prepare.fast_solid_fraction 0.55"), std::string::npos);
  EXPECT_NEAR(b["p"].get<double>(), 2e5, 0.01 * 2e5);
  EXPECT_LT(b["void_ratio"].get<double>(), prepared["void_ratio"].get<double>());

  // What does not follow a loaded start is refused naming the key: a seed ensemble (one sample for every seed)
  // and the translation (its preparation script starts from the grid sample).
  r = celldem(dir, run_args(dir / "b.json", dir / "rc", "--seeds 1,2"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(r.err.find("initial_state: --seeds"), r.err.find("initial_state")) << r.err;
  EXPECT_NE(r.err.find("initial_state: --seeds"), std::string::npos) << r.err;
  r = celldem(dir, "translate '" + (dir / "b.json").string() + "' --to lammps --out '" + (dir / "lmp").string() + "'");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("initial_state: translate writes the preparation"), std::string::npos) << r.err;
}

// A `create_atoms random` file (overlaps up to almost a diameter) is refused by check and run naming the overlaps
// and the soft start, not later as a time step too large; with prepare.relax_overlaps the cell is dilated by the
// smallest factor that brings every overlap within the limit (the brute-force oracle's), and it prepares.
TEST(Import, DeepOverlapsAreRefusedOrRelaxedBySoftStart) {
  const fs::path dir = testing::test_dir("soft_" + std::to_string(getpid()));
  double box = 0.0;
  std::vector<Sphere> spheres;
  ASSERT_NO_FATAL_FAILURE(random_spheres(250, 0.2, false, 11, spheres, box));
  write_data_file(dir / "random.data", spheres, box);
  double worst = 0.0;
  const double f = 0.01, expected = dilation_by_brute_force(spheres, box, f, &worst);
  ASSERT_GT(worst, 1.3) << "the file must overlap deeply";

  write_bytes(dir / "plain.json", deck_preparing(250, "random.data", "[]"));
  for (const std::string& cmd : {"check '" + (dir / "plain.json").string() + "'", run_args(dir / "plain.json", dir / "rp")}) {
    const Result r = celldem(dir, cmd);
    EXPECT_EQ(r.code, 2) << cmd;
    EXPECT_NE(r.err.find("touching pairs overlap by more than 0.05 of the smaller radius, the deepest"),
              std::string::npos) << r.err;
    EXPECT_NE(r.err.find("set \"prepare.relax_overlaps\""), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(atom "), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("time step too large"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir / "rp" / "summary.json"));

  write_bytes(dir / "soft.json", deck_preparing(250, "random.data", kShortTtc, "\"relax_overlaps\": 0.01, "));
  Result r = celldem(dir, "check '" + (dir / "soft.json").string() + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("cell dilated by"), std::string::npos) << r.out;
  r = celldem(dir, run_args(dir / "soft.json", dir / "rs"));
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("relax_overlaps 0.01: cell dilated by"), std::string::npos) << r.out;
  const auto summary = nlohmann::json::parse(read_bytes(dir / "rs" / "summary.json"));
  const auto& from = summary["prepared"]["started_from"];
  const auto& relax = from["relax_overlaps"];
  EXPECT_NEAR(relax["dilation"].get<double>(), expected, 1e-12 * expected);
  EXPECT_GT(from["overlaps"]["deep_pairs"].get<int>(), 10);
  EXPECT_NEAR(from["overlaps"]["worst"].get<double>(), worst, 1e-12 * worst);
  EXPECT_LE(relax["overlaps_after"]["worst"].get<double>(), f * (1.0 + 1e-9));
  EXPECT_EQ(relax["overlaps_after"]["deep_pairs"], 0);
  EXPECT_NEAR(from["solid_fraction"].get<double>(), 0.2 / std::pow(expected, 3), 1e-9);
  EXPECT_NEAR(summary["prepared"]["p"].get<double>(), 1e5, 0.01 * 1e5);
  EXPECT_TRUE(summary["tests"].contains("ttc"));
  std::printf("soft start: %lld touching pairs (%lld beyond 0.05 r), deepest %.3f r; dilation %.6f; then %lld steps\n",
              static_cast<long long>(from["overlaps"]["touching_pairs"].get<std::int64_t>()),
              static_cast<long long>(from["overlaps"]["deep_pairs"].get<std::int64_t>()),
              from["overlaps"]["worst"].get<double>(), relax["dilation"].get<double>(),
              static_cast<long long>(summary["prepared"]["steps"].get<std::int64_t>()));
}

// The solid fraction of a LAMMPS data file of the translator's or write_data_file's form, computed from its text
// alone (box bounds and diameters): the oracle of what check prints.
double data_file_solid_fraction(const std::string& data) {
  std::istringstream in(data);
  double volume = 1.0, solid = 0.0;
  bool atoms = false;
  for (std::string line; std::getline(in, line);) {
    std::istringstream ss(line);
    std::vector<std::string> f;
    for (std::string w; ss >> w;) f.push_back(w);
    if (f.size() == 4 && f[2].size() == 3 && f[2].substr(1) == "lo" && f[3].size() == 3 && f[3].substr(1) == "hi")
      volume *= std::stod(f[1]) - std::stod(f[0]);
    if (!f.empty() && f[0] == "Atoms") atoms = true;
    else if (atoms && f.size() >= 7) solid += M_PI / 6.0 * std::pow(std::stod(f[2]), 3);
    else if (atoms && !f.empty() && f[0] == "Velocities") break;
  }
  return solid / volume;
}

// The number check prints after `label` ("solid fraction ").
double printed_after(const std::string& out, const std::string& label) {
  const auto at = out.find(label);
  return at == std::string::npos ? std::nan("") : std::stod(out.substr(at + label.size()));
}

// check on a deck whose tests start from initial_state (no prepare) says what they start from: the solid
// fraction and the overlaps (count, deepest as a fraction of the smaller radius). A loose import (no contacts,
// solid fraction 0.2) is warned about, pointing to prepare; a prepared packing is not.
TEST(Import, CheckDescribesWhatTestsStartFromAndWarnsOfALooseOne) {
  const fs::path dir = testing::test_dir("test_start_" + std::to_string(getpid()));
  ASSERT_NO_FATAL_FAILURE(prepare_and_translate(dir));
  write_bytes(dir / "b.json", deck_from("lmp/state.data"));
  Result r = celldem(dir, "check '" + (dir / "b.json").string() + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("tests: start from "), std::string::npos) << r.out;
  const double dense = data_file_solid_fraction(read_bytes(dir / "lmp" / "state.data"));
  EXPECT_GT(dense, 0.5);
  EXPECT_NEAR(printed_after(r.out, "solid fraction "), dense, 1e-3 * dense) << r.out;  // printed to 4 digits
  EXPECT_GT(printed_after(r.out, "tests: as loaded "), 100) << r.out;  // a packing at 100 kPa: most spheres touch
  EXPECT_NE(r.out.find("the deepest overlap "), std::string::npos) << r.out;
  EXPECT_EQ(r.err.find("loose"), std::string::npos) << r.err;

  double box = 0.0;
  std::vector<Sphere> spheres;
  ASSERT_NO_FATAL_FAILURE(random_spheres(200, 0.2, true, 5, spheres, box));
  write_data_file(dir / "loose.data", spheres, box);
  write_bytes(dir / "loose.json", deck_from("loose.data"));
  for (const std::string& cmd : {"check '" + (dir / "loose.json").string() + "'",
                                 run_args(dir / "loose.json", dir / "rl", "--quiet")}) {
    r = celldem(dir, cmd);
    EXPECT_NE(r.err.find("loose gas of spheres"), std::string::npos) << cmd << ": " << r.err;
    EXPECT_NE(r.err.find("add \"prepare\" beside \"initial_state\""), std::string::npos) << r.err;
  }
  r = celldem(dir, "check '" + (dir / "loose.json").string() + "'");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(printed_after(r.out, "solid fraction "), 0.2, 1e-3) << r.out;
  EXPECT_EQ(printed_after(r.out, "tests: as loaded "), 0) << r.out;
}

}  // namespace
}  // namespace celldem
