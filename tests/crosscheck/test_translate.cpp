// The LAMMPS / LIGGGHTS translator (solver/io/translate.hpp): the data file holds the state's particles
// exactly (wrapped positions, one type per deck diameter, velocities and spins), the scripts carry the deck's
// constants (body damping split exactly into langevin + viscous, fix deform rates, servo), and every model
// difference is reported for the deck settings that cause it. That the scripts reproduce celldem's results
// is checked against the real codes by crosscheck_reduced.
#include <gtest/gtest.h>

#include <cmath>
#include <regex>
#include <sstream>

#include "io/deck_reader.hpp"
#include "io/translate.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {

std::string deck_json(const std::string& extra) {
  return R"({"format": 1,
    "sample": {"count": 3, "diameters": {"list": [0.003, 0.004]}, "density": 2500, "grid_spacing": 0.005},
    "contact": {"kn": 1e6, "kt": 5e5)" + extra + R"(},
    "damping": {"translational": 0.05, "rotational": 0.04},
    "time_step": 1e-6,
    "initial_state": "x.state",
    "tests": [{"name": "ttc", "friction": 0.5,
               "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
               "end": {"axis": "x1", "strain": 0.001}, "output_interval": 100},
              {"name": "strain", "friction": 0.3,
               "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"strain_increment": 0.0},
                        "x3": {"strain_rate": -0.1}},
               "end": {"axis": "x1", "strain": 0.0004}}]})";
}

Deck deck_with(const std::string& contact_extra = "", const std::string& top_extra = "") {
  std::string text = deck_json(contact_extra);
  if (!top_extra.empty()) text.insert(text.find("\"time_step\""), top_extra + ", ");
  return parse_deck(text, "dir/the_deck.json");
}

// Three spheres: positions outside [0, 1) in scaled coordinates (they must be wrapped), one contact with
// tangential history when `history` is set.
State three_spheres(bool history) {
  State s;
  s.cell.h = Vec3(0.02, 0.021, 0.022).asDiagonal();
  s.particles.resize(3);
  s.particles.radius = {0.0015, 0.002, 0.0015};
  s.particles.scaled = {Vec3(-0.25, 0.5, 1.25), Vec3(0.1, 0.2, 0.3), Vec3(2.5, -1.0, 0.999)};
  s.particles.velocity = {Vec3(1e-3, -2e-3, 3e-3), Vec3::Zero(), Vec3(0.0, 0.0, -1.5e-4)};
  s.particles.spin = {Vec3(0.1, 0.0, -0.2), Vec3::Zero(), Vec3(0.0, 3.0, 0.0)};
  set_stored_contacts(s, {{0, 1, history ? Vec3(1e-7, 0.0, 0.0) : Vec3::Zero(), kTouching}});
  return s;
}

std::vector<std::string> lines_after(const std::string& text, const std::string& section, std::size_t count) {
  std::istringstream in(text.substr(text.find("\n" + section) + 1));
  std::vector<std::string> out;
  std::string line;
  std::getline(in, line);  // the section name
  while (out.size() < count && std::getline(in, line))
    if (!line.empty()) out.push_back(line);
  return out;
}

std::vector<double> numbers(const std::string& line) {
  std::istringstream in(line);
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  return v;
}

// "scale 1 a scale 2 b ..." on the line starting with `prefix`.
std::vector<double> scales(const std::string& script, const std::string& prefix) {
  const auto at = script.find("\n" + prefix);
  EXPECT_NE(at, std::string::npos) << prefix;
  const std::string line = script.substr(at + 1, script.find('\n', at + 1) - at - 1);
  std::vector<double> v;
  const std::regex re("scale (\\d+) (\\S+)");
  for (auto it = std::sregex_iterator(line.begin(), line.end(), re); it != std::sregex_iterator(); ++it) {
    EXPECT_EQ(std::stoi((*it)[1]), static_cast<int>(v.size()) + 1);
    v.push_back(std::stod((*it)[2]));
  }
  return v;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(Translate, DataFileHoldsTheStateExactly) {
  const Deck deck = deck_with();
  const State state = three_spheres(false);
  const std::string data = translate_data(deck, state, TargetCode::Lammps, "prepared", {});
  EXPECT_TRUE(contains(data, "\n3 atoms\n2 atom types\n"));
  EXPECT_TRUE(contains(data, "\n0 0.02 xlo xhi\n0 0.021 ylo yhi\n0 0.022 zlo zhi\n"));
  const auto atoms = lines_after(data, "Atoms # sphere", 3);
  ASSERT_EQ(atoms.size(), 3u);
  const std::vector<int> type = {1, 2, 1};
  for (int i = 0; i < 3; ++i) {
    const std::vector<double> a = numbers(atoms[i]);
    ASSERT_EQ(a.size(), 7u);
    EXPECT_EQ(a[0], i + 1);
    EXPECT_EQ(a[1], type[i]);
    EXPECT_EQ(a[2], 2.0 * state.particles.radius[i]);
    EXPECT_EQ(a[3], 2500.0);
    for (int k = 0; k < 3; ++k) {
      const double L = state.cell.h(k, k), s = state.particles.scaled[i][k];
      EXPECT_GE(a[4 + k], 0.0);
      EXPECT_LT(a[4 + k], L);
      EXPECT_NEAR(a[4 + k], L * (s - std::floor(s)), 1e-18) << "particle " << i << " axis " << k;
    }
  }
  const auto velocities = lines_after(data, "Velocities", 3);
  ASSERT_EQ(velocities.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const std::vector<double> v = numbers(velocities[i]);
    ASSERT_EQ(v.size(), 7u);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(v[1 + k], state.particles.velocity[i][k]);  // exact: shortest round-trip text
      EXPECT_EQ(v[4 + k], state.particles.spin[i][k]);
    }
  }
  EXPECT_TRUE(contains(translate_data(deck, state, TargetCode::Liggghts, "prepared", {}), "Atoms # granular"));
}

TEST(Translate, RefusesStatesItCannotWrite) {
  const Deck deck = deck_with();
  State sheared = three_spheres(false);
  sheared.cell.h(0, 1) = 1e-4;
  EXPECT_THROW(translate_data(deck, sheared, TargetCode::Lammps, "", {}), DeckError);
  State foreign = three_spheres(false);
  foreign.particles.radius[1] = 0.00175;  // diameter 3.5 mm is not in the deck
  EXPECT_THROW(translate_data(deck, foreign, TargetCode::Lammps, "", {}), DeckError);
}

TEST(Translate, ContactHistoryIsReportedOnlyWhenPresent) {
  EXPECT_TRUE(state_differences(three_spheres(false), TargetCode::Lammps).empty());
  const auto w = state_differences(three_spheres(true), TargetCode::Liggghts);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_TRUE(contains(w[0], "tangential contact history in 1 of 1 contacts"));
}

TEST(Translate, DifferencesFollowTheDeckSettings) {
  auto mentions = [](const std::vector<std::string>& list, const std::string& key) {
    for (const auto& s : list)
      if (s.rfind(key, 0) == 0) return true;
    return false;
  };
  // Deck defaults: affine kinematics, rotated history, contact-point arm, rotational damping, a servo.
  const Deck native = deck_with();
  const auto lmp = model_differences(native, TargetCode::Lammps);
  EXPECT_TRUE(mentions(lmp, "kinematics"));
  EXPECT_TRUE(mentions(lmp, "contact.tangential_rotation"));
  EXPECT_TRUE(mentions(lmp, "contact.moment_arm"));
  EXPECT_TRUE(mentions(lmp, "servo"));
  EXPECT_FALSE(mentions(lmp, "damping"));
  const auto lig = model_differences(native, TargetCode::Liggghts);
  EXPECT_FALSE(mentions(lig, "contact.moment_arm"));  // LIGGGHTS uses r - overlap/2 like the default
  EXPECT_TRUE(mentions(lig, "damping.rotational"));

  // Settings matched to LAMMPS: only the servo remains; to LIGGGHTS the radius arm is now a difference.
  const Deck matched = deck_with(R"(, "tangential_rotation": "project", "moment_arm": "radius")",
                                 R"("kinematics": "lammps")");
  const auto lmp2 = model_differences(matched, TargetCode::Lammps);
  ASSERT_EQ(lmp2.size(), 1u);
  EXPECT_TRUE(mentions(lmp2, "servo"));
  EXPECT_TRUE(mentions(model_differences(matched, TargetCode::Liggghts), "contact.moment_arm"));
}

TEST(Translate, LammpsScriptCarriesTheDeck) {
  const Deck deck = deck_with();
  const std::string s = translate_test(deck, deck.tests[0], TargetCode::Lammps);
  EXPECT_TRUE(contains(s, "\nread_data       ${data}\n"));
  EXPECT_TRUE(contains(s, "\npair_style      gran/hooke/history 1e+06 5e+05 0.0 0.0 0.5 0\n"));
  EXPECT_TRUE(contains(s, "\ntimestep        1e-06\n"));
  EXPECT_TRUE(contains(s, "\nfix             dfm all deform 1 x erate -0.2 remap x\n"));
  const TranslatedServo servo = translated_servo(deck);
  EXPECT_DOUBLE_EQ(servo.pdamp, 1e-6 / (3.0 * 0.05));
  {  // fix srv all press/berendsen y T T PDAMP z T T PDAMP couple none modulus M dilate all
    const auto at = s.find("\nfix             srv all press/berendsen");
    ASSERT_NE(at, std::string::npos);
    std::istringstream in(s.substr(at + 1, s.find('\n', at + 1) - at - 1));
    std::vector<std::string> w;
    for (std::string x; in >> x;) w.push_back(x);
    ASSERT_EQ(w.size(), 18u);
    EXPECT_EQ(w[4], "y");
    EXPECT_EQ(std::stod(w[5]), 1e5);
    EXPECT_EQ(std::stod(w[7]), servo.pdamp);
    EXPECT_EQ(w[8], "z");
    EXPECT_EQ(std::stod(w[11]), servo.pdamp);
    EXPECT_EQ(w[14], "modulus");
    EXPECT_EQ(std::stod(w[15]), servo.modulus);
  }
  EXPECT_TRUE(contains(s, "\nfix_modify      srv press P\n"));
  EXPECT_TRUE(contains(s, "\nvariable        steps index 5000\n") && contains(s, "\nrun             ${steps}\n"));
  // The observation fix comes before the box moves (fix order = end_of_step order).
  EXPECT_LT(s.find("fix             obs"), s.find("fix             dfm"));
  EXPECT_LT(s.find("fix             obs"), s.find("fix             srv"));

  // Body damping: langevin s and viscous g per type reproduce c_r and c_t exactly.
  const std::vector<AtomType> types = atom_types(deck);
  const std::vector<double> s_t = scales(s, "fix             bdr"), g_t = scales(s, "fix             bdt");
  ASSERT_EQ(s_t.size(), types.size());
  ASSERT_EQ(g_t.size(), types.size());
  for (std::size_t k = 0; k < types.size(); ++k) {
    const AtomType& t = types[k];
    EXPECT_NEAR(t.c_t, 0.05 * 2.0 * std::sqrt(t.mass * 1e6), 1e-15);
    EXPECT_NEAR(t.c_r, 0.04 * t.diameter * std::sqrt(t.inertia * 5e5), 1e-20);
    EXPECT_NEAR((10.0 / 3.0) * t.inertia / s_t[k], t.c_r, 1e-12 * t.c_r);
    EXPECT_NEAR(t.mass / s_t[k] + g_t[k], t.c_t, 1e-12 * t.c_t);
  }

  // The second test: a fixed axis is left out, a strain rate becomes erate, no servo.
  const std::string s2 = translate_test(deck, deck.tests[1], TargetCode::Lammps);
  EXPECT_TRUE(contains(s2, "\nfix             dfm all deform 1 x erate -0.2 z erate 0.1 remap x\n"));
  EXPECT_FALSE(contains(s2, "\nfix             srv"));
  EXPECT_TRUE(contains(s2, "\nvariable        steps index 2000\n"));
  EXPECT_TRUE(contains(s2, " 0.3 0\n"));
}

TEST(Translate, LiggghtsScriptCarriesTheDeck) {
  const Deck deck = deck_with();
  const std::string s = translate_test(deck, deck.tests[0], TargetCode::Liggghts);
  EXPECT_TRUE(contains(s, "\nfix             m1 all property/global kn peratomtypepair 2 1e+06 1e+06 1e+06 1e+06\n"));
  EXPECT_TRUE(contains(s, "\nfix             m5 all property/global coefficientFriction peratomtypepair 2 0.5 0.5 0.5 0.5\n"));
  EXPECT_TRUE(contains(s, "pair_style      gran model hooke/stiffness tangential history tangential_damping off"));
  EXPECT_FALSE(contains(s, "\nfix             bdr"));
  const std::vector<double> c = scales(s, "fix             bdt");
  const std::vector<AtomType> types = atom_types(deck);
  ASSERT_EQ(c.size(), types.size());
  for (std::size_t k = 0; k < types.size(); ++k) EXPECT_DOUBLE_EQ(c[k], types[k].c_t);
  EXPECT_TRUE(contains(s, "\nfix             dfm all deform 1 x erate -0.2 y variable v_dy v_ry z variable v_dz v_rz remap x\n"));
  EXPECT_TRUE(contains(s, "\nvariable        dy equal ly*(1.0-1e-06/"));
  EXPECT_TRUE(contains(s, "-c_P[2])/"));
  EXPECT_LT(s.find("fix             obs"), s.find("fix             dfm"));
}

TEST(Translate, ScriptsDependOnTheDeckOnly) {
  const Deck a = deck_with();
  const Deck b = deck_with();
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts})
    EXPECT_EQ(translate_test(a, a.tests[0], code), translate_test(b, b.tests[0], code));
  EXPECT_EQ(script_file_name(a.tests[0], TargetCode::Liggghts), "ttc.liggghts.in");
  EXPECT_EQ(series_file_name(a.tests[0], TargetCode::Lammps), "ttc.lammps.csv");
  EXPECT_THROW(parse_target_code("gromacs"), DeckError);
}

}  // namespace
}  // namespace celldem
