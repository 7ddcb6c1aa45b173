// The LAMMPS / LIGGGHTS translator (solver/io/translate.hpp): the data file holds the state's particles
// exactly (wrapped positions, one type per deck diameter, velocities and spins), the scripts carry the deck's
// constants (body damping split exactly into langevin + viscous, fix deform rates, servo), and every model
// difference is reported for the deck settings that cause it. That the scripts reproduce celldem's results
// is checked against the real codes by crosscheck_reduced.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <regex>
#include <sstream>

#include "cell/control.hpp"
#include "core/plan.hpp"
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
  const TranslatedServo servo = translated_servo(deck, deck.time_step);
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

// ---- load programs ----

// A deck whose tests are the given JSON (comma-separated test objects).
Deck program_deck(const std::string& tests, const std::string& top_extra = R"("kinematics": "lammps")") {
  return parse_deck(R"({"format": 1,
    "sample": {"count": 3, "diameters": {"list": [0.003, 0.004]}, "density": 2500, "grid_spacing": 0.005},
    "contact": {"kn": 1e6, "kt": 1e6, "tangential_rotation": "project", "moment_arm": "radius"},
    "damping": {"translational": 0.05, "rotational": 0.05}, )" + top_extra + R"(,
    "time_step": 1e-6, "initial_state": "x.state", "tests": [)" + tests + "]}",
                    "dir/program.json");
}

// The script cut into its leg blocks ("# ---- leg k of n: ..." up to the next one); [0] is what comes before.
std::vector<std::string> leg_blocks(const std::string& script) {
  std::vector<std::string> blocks;
  std::size_t at = 0;
  for (;;) {
    const std::size_t next = script.find("\n# ---- leg ", at);
    blocks.push_back(script.substr(at, next == std::string::npos ? std::string::npos : next + 1 - at));
    if (next == std::string::npos) return blocks;
    at = next + 1;
  }
}

// The lines of `text` that start with `command` (padded as the scripts write it).
std::vector<std::string> command_lines(const std::string& text, const std::string& command) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind(command + " ", 0) == 0) out.push_back(line);
  return out;
}

// The formula of `variable NAME equal FORMULA` in `text` ("" when there is none).
std::string formula(const std::string& text, const std::string& name) {
  for (const std::string& line : command_lines(text, "variable")) {
    std::istringstream in(line);
    std::string cmd, n, style;
    in >> cmd >> n >> style;
    if (n == name && style == "equal") {
      std::string rest;
      std::getline(in, rest);
      return rest.substr(rest.find_first_not_of(' '));
    }
  }
  return "";
}

// Evaluates a LAMMPS equal-style formula of numbers, + - * / ^, parentheses, c_P[k] (from `stress`) and v_NAME
// (the formula of NAME in `script`, evaluated the same way): enough for the servo targets.
class Formula {
 public:
  Formula(const std::string& script, const Vec3& stress) : script_(script), stress_(stress) {}
  double eval(const std::string& f) {
    const std::string saved = text_;
    const std::size_t saved_at = at_;
    text_ = f, at_ = 0;
    const double x = sum();
    EXPECT_EQ(at_, text_.size()) << "unparsed rest of " << f;
    text_ = saved, at_ = saved_at;
    return x;
  }

 private:
  double sum() {
    double x = product();
    while (at_ < text_.size() && (text_[at_] == '+' || text_[at_] == '-')) {
      const char op = text_[at_++];
      const double y = product();
      x = op == '+' ? x + y : x - y;
    }
    return x;
  }
  double product() {
    double x = power();
    while (at_ < text_.size() && (text_[at_] == '*' || text_[at_] == '/')) {
      const char op = text_[at_++];
      const double y = power();
      x = op == '*' ? x * y : x / y;
    }
    return x;
  }
  double power() {
    const double x = unary();
    if (at_ < text_.size() && text_[at_] == '^') return ++at_, std::pow(x, unary());
    return x;
  }
  double unary() {
    if (text_[at_] == '-') return ++at_, -unary();
    if (text_[at_] == '(') {
      ++at_;
      const double x = sum();
      EXPECT_EQ(text_[at_], ')');
      ++at_;
      return x;
    }
    if (text_.compare(at_, 4, "c_P[") == 0) {
      const int k = text_[at_ + 4] - '1';
      at_ += 6;
      return stress_[k];
    }
    if (text_.compare(at_, 2, "v_") == 0) {
      std::size_t end = at_ + 2;
      while (end < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[end])) || text_[end] == '_')) ++end;
      const std::string name = text_.substr(at_ + 2, end - at_ - 2);
      at_ = end;
      const std::string f = formula(script_, name);
      EXPECT_FALSE(f.empty()) << "no variable " << name;
      return f.empty() ? std::nan("") : eval(f);
    }
    std::size_t used = 0;
    const double x = std::stod(text_.substr(at_), &used);
    at_ += used;
    return x;
  }

  const std::string& script_;
  Vec3 stress_;
  std::string text_;
  std::size_t at_ = 0;
};

const char* kTwoLegs = R"({"name": "load_unload", "friction": 0.5, "output_interval": 100, "legs": [
    {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
     "end": {"axis": "x1", "strain": 0.001}},
    {"axes": {"x1": {"strain_increment": -2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
     "end": {"axis": "x1", "strain": 0.0006}},
    {"axes": {"x1": {"strain_increment": -1e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
     "end": {"ratio": 1.1, "max_steps": 4000}},
    {"axes": {"x1": {"stress": 1.2e5}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
     "end": {"axis": "x1", "stress": 1.2e5, "max_steps": 3000}}]})";

TEST(TranslateProgram, LegsRunOneAfterTheOtherWithCelldemsLengths) {
  const Deck deck = program_deck(kTwoLegs);
  const TestDef& test = deck.tests[0];
  ASSERT_EQ(test.legs.size(), 4u);
  const std::string s = translate_test(deck, test, TargetCode::Lammps);
  const std::vector<std::string> blocks = leg_blocks(s);
  ASSERT_EQ(blocks.size(), 5u);  // what comes before, then one block per leg
  EXPECT_FALSE(contains(s, "variable        steps index"));  // the one-leg form's run length is not used
  EXPECT_TRUE(command_lines(blocks[0], "run").empty());
  EXPECT_TRUE(command_lines(blocks[0], "unfix").empty());

  // Leg 1: compression to e1 = 0.1 % from the test start, by erate; leg 2: unloading to e1 = 0.06 % from where
  // leg 1 ended: the lengths celldem's leg_steps gives from each leg's start strain.
  const std::int64_t n1 = leg_steps(test.legs[0], deck.time_step, 0.0);
  const std::int64_t n2 = leg_steps(test.legs[1], deck.time_step, n1 * 2e-7);
  EXPECT_EQ(n1, 5000);
  EXPECT_EQ(n2, 2000);
  EXPECT_EQ(command_lines(blocks[1], "run"), std::vector<std::string>{"run             " + std::to_string(n1)});
  EXPECT_EQ(command_lines(blocks[2], "run"), std::vector<std::string>{"run             " + std::to_string(n2)});
  EXPECT_TRUE(contains(blocks[1], "\nfix             dfm all deform 1 x erate -0.2 remap x\n"));
  EXPECT_TRUE(contains(blocks[1], "\nfix             srv all press/berendsen y 1e+05 1e+05 "));
  // Every later leg first removes the previous leg's fixes, then defines its own; strain axes by vel from the
  // box at the leg start (-L0 d per step, L0 the test start: celldem's exact engineering strain).
  for (int j = 2; j <= 4; ++j) {
    const std::vector<std::string> unfix = command_lines(blocks[j], "unfix");
    const std::vector<std::string> fix = command_lines(blocks[j], "fix");
    ASSERT_FALSE(unfix.empty()) << "leg " << j;
    ASSERT_FALSE(fix.empty()) << "leg " << j;
    EXPECT_LT(blocks[j].find(unfix.back()), blocks[j].find(fix.front())) << "leg " << j;
    EXPECT_LT(blocks[j].find(fix.back()), blocks[j].find("\nrun ")) << "leg " << j;
  }
  EXPECT_EQ(command_lines(blocks[2], "unfix"), (std::vector<std::string>{"unfix           dfm", "unfix           srv"}));
  EXPECT_TRUE(contains(blocks[2], "\nfix             dfm all deform 1 x vel $(0.2*v_L01:%.17g) remap x units box\n"));
  EXPECT_TRUE(contains(blocks[3], "\nfix             dfm all deform 1 x vel $(0.1*v_L01:%.17g) remap x units box\n"));

  // Leg 3 ends on s11/s33 = 1.1, leg 4 on s11 = 1.2e5: fix halt every step, from the side the leg starts on,
  // at most end.max_steps, then the script stops with an error if the end was not reached.
  EXPECT_EQ(formula(blocks[3], "now3"), "f_obs[4]/f_obs[6]");
  EXPECT_EQ(formula(blocks[3], "side3"), "$(2*(v_now3<1.1)-1:%.17g)");
  EXPECT_EQ(formula(blocks[3], "end3"), "v_side3*(v_now3-1.1)");
  EXPECT_TRUE(contains(blocks[3], "\nfix             hlt all halt 1 v_end3 >= 0.0 error continue message yes\n"));
  EXPECT_EQ(formula(blocks[3], "run3"), "(v_end3<0.0)*4000");
  EXPECT_EQ(command_lines(blocks[3], "run"), std::vector<std::string>{"run             ${run3}"});
  EXPECT_TRUE(contains(blocks[3], "\nif              \"$(v_end3) < 0.0\" then "));
  EXPECT_EQ(formula(blocks[4], "now4"), "f_obs[4]");
  EXPECT_EQ(formula(blocks[4], "run4"), "(v_end4<0.0)*3000");
  EXPECT_EQ(command_lines(blocks[4], "unfix"),
            (std::vector<std::string>{"unfix           dfm", "unfix           srv", "unfix           hlt"}));
  // Leg 4 has no strain axis: no fix deform, all three axes on press/berendsen.
  EXPECT_TRUE(command_lines(blocks[4], "fix             dfm").empty());
  EXPECT_TRUE(contains(blocks[4], "press/berendsen x 120000 120000 "));
}

TEST(TranslateProgram, LiggghtsChecksInChunksWhereLammpsHalts) {
  const Deck deck = program_deck(kTwoLegs);
  const std::string lmp = translate_test(deck, deck.tests[0], TargetCode::Lammps);
  const std::string lig = translate_test(deck, deck.tests[0], TargetCode::Liggghts);
  const std::vector<std::string> blocks = leg_blocks(lig);
  ASSERT_EQ(blocks.size(), 5u);
  EXPECT_EQ(command_lines(lmp, "fix             hlt").size(), 2u);
  EXPECT_TRUE(command_lines(lig, "fix             hlt").empty());
  // Legs of known length: one run each, as in LAMMPS.
  EXPECT_EQ(command_lines(blocks[1], "run"), std::vector<std::string>{"run             5000"});
  EXPECT_EQ(command_lines(blocks[2], "run"), std::vector<std::string>{"run             2000"});
  // Ratio and stress ends: a run of 0 steps, then chunks of kLiggghtsCheckSteps between checks of the end.
  for (int j : {3, 4}) {
    const std::string t = std::to_string(j);
    EXPECT_EQ(command_lines(blocks[j], "run"),
              (std::vector<std::string>{"run             0 post no",
                                        "run             " + std::to_string(kLiggghtsCheckSteps) + " pre no post no"}));
    EXPECT_TRUE(contains(blocks[j], "\nlabel           leg" + t + "\nif              \"${done" + t +
                                        "}\" then \"jump SELF leg" + t + "_end\"\n"));
    EXPECT_TRUE(contains(blocks[j], "\njump            SELF leg" + t + "\nlabel           leg" + t + "_end\n"));
    EXPECT_TRUE(contains(blocks[j], "\nvariable        S" + t + "_f equal step\n"));
  }
  EXPECT_EQ(formula(blocks[3], "over3"), "step-v_S3>=4000");
  // Strain axes of later legs: a fix deform variable counted from the leg's first step (chunks do not restart it).
  EXPECT_EQ(formula(blocks[3], "d3x"), "1e-07*v_L01*(step-v_S3)");
  EXPECT_TRUE(contains(blocks[3], "\nfix             dfm all deform 1 x variable v_d3x v_r3x "));
  // The difference is listed.
  bool listed = false;
  for (const std::string& d : model_differences(deck, TargetCode::Liggghts))
    listed = listed || contains(d, "no fix halt");
  EXPECT_TRUE(listed);
  for (const std::string& d : model_differences(deck, TargetCode::Lammps)) EXPECT_FALSE(contains(d, "no fix halt"));
}

TEST(TranslateProgram, StrainEndsWhoseStartOnlyTheRunKnowsAreCountedAtRunTime) {
  // Leg 2's start strain depends on where leg 1's ratio end stopped: its steps are celldem's leg_steps at run time.
  const Deck deck = program_deck(R"({"name": "t", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
       "end": {"ratio": 2.0, "max_steps": 10000}},
      {"axes": {"x1": {"strain_increment": -2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
       "end": {"axis": "x1", "strain": 0.0001, "max_steps": 7000}}]})");
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts}) {
    const std::vector<std::string> blocks = leg_blocks(translate_test(deck, deck.tests[0], code));
    ASSERT_EQ(blocks.size(), 3u);
    EXPECT_EQ(formula(blocks[2], "n2"), "round((1e-04-(1.0-lx/v_L01))/(-2e-07))");
    EXPECT_EQ(formula(blocks[2], "away2"), "(1e-04-(1.0-lx/v_L01))*(-2e-07)<0.0");
    EXPECT_EQ(formula(blocks[2], "m2"), "v_n2-(v_n2-7000)*(v_n2>7000)");  // capped at max_steps, as leg_steps
    EXPECT_EQ(command_lines(blocks[2], "run"), std::vector<std::string>{"run             ${m2}"});
    EXPECT_TRUE(contains(blocks[2], "\nif              \"${away2}\" then \"print 'celldem translate: leg 2: axis "
                                    "x1 moves away from its end strain 1e-04'\""));
  }
}

TEST(TranslateProgram, LegMovingAwayFromItsEndStrainIsAnError) {
  // Leg 1 ends at e1 = 0.1 %; leg 2 keeps compressing towards e1 = 0.05 %: celldem stops there (RunError). The
  // deck reader refuses such a program (check_leg_lengths), so the leg's end is moved after reading: the scripts'
  // own guard is what is tested here.
  Deck deck = program_deck(R"({"name": "away", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
       "end": {"axis": "x1", "strain": 0.001}},
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
       "end": {"axis": "x1", "strain": 0.002}}]})");
  deck.tests[0].legs[1].end.value = 0.0005;
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts}) {
    try {
      translate_test(deck, deck.tests[0], code);
      ADD_FAILURE() << "no DeckError";
    } catch (const DeckError& e) {
      EXPECT_TRUE(contains(e.what(), "leg 2: axis x1 moves away from its end strain 5e-04")) << e.what();
    }
  }
  // Moving towards it is fine, and an axis other than the end axis may move either way.
  const Deck back = program_deck(R"({"name": "back", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"strain_increment": -1e-7}, "x3": {"stress": 1e5}},
       "end": {"axis": "x1", "strain": 0.001}},
      {"axes": {"x1": {"strain_increment": -2e-7}, "x2": {"strain_increment": -1e-7}, "x3": {"stress": 1e5}},
       "end": {"axis": "x1", "strain": 0.0005}}]})");
  EXPECT_NO_THROW(translate_test(back, back.tests[0], TargetCode::Lammps));
}

// A stress ramp: the translated target, a formula of the steps since the leg start (v_S<leg>, frozen at the
// leg's start), evaluated some steps into the leg, is celldem's stress_targets() at that time; the axis is
// servoed by the press/berendsen law as a fix deform variable (never fix press/berendsen, whose target is fixed).
TEST(TranslateProgram, StressRampTargetsAreCelldems) {
  const Deck deck = program_deck(R"({"name": "ramps", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress_ramp": {"from": 1e5, "rate": -1e6}},
                "x3": {"stress": 1e5}}, "end": {"axis": "x1", "strain": 0.001}},
      {"axes": {"x1": {"stress_ramp": {"from": 1.2e5, "rate": 5e6}}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
       "end": {"axis": "x1", "stress": 1.5e5, "max_steps": 100000}}]},
    {"name": "one", "friction": 0.5,
     "axes": {"x1": {"stress_ramp": {"from": 1e5, "rate": 2e6}}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
     "end": {"axis": "x1", "stress": 1.1e5, "max_steps": 100000}})");
  const Vec3 s(1.6e5, 1.1e5, 4.0e4);  // the contact stresses of some step (a ramp's target does not use them)
  const double start = 1000.0, now = 1500.0;  // the leg's first step and this one
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts}) {
    struct Ramp {
      const TestDef& test;
      int leg, axis;
      std::string tag;  // "" in the one-leg form
    };
    for (const Ramp& ramp : {Ramp{deck.tests[0], 0, 1, "1"}, Ramp{deck.tests[0], 1, 0, "2"}, Ramp{deck.tests[1], 0, 0, ""}}) {
      const std::string script = translate_test(deck, ramp.test, code);
      const std::vector<std::string> blocks = leg_blocks(script);
      const std::string& block = ramp.test.legs.size() > 1 ? blocks[static_cast<std::size_t>(ramp.leg) + 1] : script;
      const std::string ax(1, "xyz"[ramp.axis]);
      const std::string where = ramp.test.name + " leg " + std::to_string(ramp.leg + 1) + " " + ax;
      // The leg start's step is frozen at the leg start.
      const std::string frozen = code == TargetCode::Lammps ? "$(step:%.17g)" : "${S" + ramp.tag + "_f}";
      EXPECT_EQ(formula(block, "S" + ramp.tag), frozen) << where;
      std::string target = formula(block, "t" + ramp.tag + ax);
      ASSERT_FALSE(target.empty()) << where;
      const std::string since = "step-v_S" + ramp.tag;
      ASSERT_NE(target.find(since), std::string::npos) << target;
      target.replace(target.find(since), since.size(), std::to_string(static_cast<int>(now)) + "-" + std::to_string(static_cast<int>(start)));
      Formula f(block, s);
      const double leg_time = (now - start) * deck.time_step;
      const double celldem = stress_targets(ramp.test.legs[ramp.leg].axes, s, leg_time)[ramp.axis];
      EXPECT_NEAR(f.eval(target), celldem, 1e-9 * celldem) << where << ": " << target;
      EXPECT_TRUE(contains(formula(block, "d" + ramp.tag + ax),
                           "*(v_t" + ramp.tag + ax + "-c_P[" + std::to_string(ramp.axis + 1) + "])/"))
          << where;
      for (const std::string& fix : command_lines(block, "fix"))
        if (contains(fix, "press/berendsen")) {
          EXPECT_FALSE(contains(fix, " " + ax + " ")) << where << ": " << fix;
        }
    }
  }
}

// A test leg that ends in equilibrium is named as not translated (its unbalanced force is the preparation's).
TEST(TranslateProgram, TestEquilibriumLegIsNamedUntranslatable) {
  const Deck deck = program_deck(R"({"name": "hold", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
       "end": {"axis": "x1", "strain": 0.001}},
      {"axes": {"x1": {"stress": 1.5e5}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"equilibrium": true}}]})");
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts}) {
    try {
      translate_test(deck, deck.tests[0], code);
      ADD_FAILURE() << "no DeckError";
    } catch (const DeckError& e) {
      EXPECT_TRUE(contains(e.what(), "test \"hold\", leg 2: end.equilibrium")) << e.what();
      EXPECT_TRUE(contains(e.what(), "not translated")) << e.what();
    }
  }
}

// A shear stress axis (zero_shear_stress too) is named as not translated; a strain-driven one is fix deform's
// tilt on a triclinic box: erate -dg/dt in a first leg of known length, else (LAMMPS) vel -L_j dg/dt; the
// series gain the shear stresses and strains. A held one (zero strain) leaves the script as it was.
TEST(TranslateProgram, ShearAxesAreFixDeformTiltsOrNamedUntranslatable) {
  const std::string axes = R"("x1": {"strain_increment": 0}, "x2": {"stress": 1e5}, "x3": {"strain_increment": 0})";
  const auto two_legs = [&](const std::string& first, const std::string& second) {
    return program_deck(R"({"name": "ss", "friction": 0.5, "legs": [
        {"axes": {)" + axes + first + R"(}, "end": {"steps": 100}},
        {"axes": {)" + axes + second + R"(}, "end": {"steps": 100}}]})");
  };
  const Deck stress = two_legs("", R"(, "x23": {"stress": 0})");
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts}) {
    try {
      translate_test(stress, stress.tests[0], code);
      ADD_FAILURE() << "no DeckError";
    } catch (const DeckError& e) {
      EXPECT_TRUE(contains(e.what(), "test \"ss\", leg 2: axes.x23 (a stress-controlled shear axis")) << e.what();
      EXPECT_TRUE(contains(e.what(), "not translated")) << e.what();
    }
  }
  const Deck strain = two_legs(R"(, "x12": {"strain_increment": 2e-6})", R"(, "x12": {"strain_rate": -1.0})");
  const std::string lmp = translate_test(strain, strain.tests[0], TargetCode::Lammps);
  EXPECT_TRUE(contains(lmp, "change_box      all triclinic")) << lmp;
  EXPECT_TRUE(contains(lmp, " xy erate -2 ")) << lmp;                 // -dg/dt = -2e-6 / 1e-6 s
  EXPECT_TRUE(contains(lmp, " xy vel $(1*v_L02:%.17g)")) << lmp;      // -L2 dg/dt
  EXPECT_TRUE(contains(lmp, "c_P[4] c_P[5] c_P[6]")) << lmp;
  EXPECT_TRUE(contains(lmp, "variable        g12 equal -(f_obs[10]-v_T0xy)/v_L02")) << lmp;
  EXPECT_TRUE(contains(lmp, std::string(kTranslatedSeriesHeader) + kTranslatedShearColumns)) << lmp;
  try {
    translate_test(strain, strain.tests[0], TargetCode::Liggghts);
    ADD_FAILURE() << "no DeckError";
  } catch (const DeckError& e) {
    EXPECT_TRUE(contains(e.what(), "test \"ss\", leg 2: axes.x12")) << e.what();
  }
  const Deck first_only = two_legs(R"(, "x13": {"strain_increment": 1e-6})", "");
  EXPECT_TRUE(contains(translate_test(first_only, first_only.tests[0], TargetCode::Liggghts), " xz erate -1 "));
  // A held shear axis: the same script as without it.
  const Deck held = two_legs(R"(, "x12": {"strain_rate": 0})", "");
  const Deck plain = two_legs("", "");
  EXPECT_EQ(translate_test(held, held.tests[0], TargetCode::Lammps), translate_test(plain, plain.tests[0], TargetCode::Lammps));
}

// Shear legs that end on their shear strain: run N with celldem's leg_steps from where the leg starts g12 (known
// here: the first leg's end), the same steps in both codes; after a leg that leaves g12 where only running tells
// (a ratio end), N is counted at run time from the tilt.
TEST(TranslateProgram, ShearStrainEndsRunCelldemsSteps) {
  const std::string axes = R"("x1": {"strain_increment": 0}, "x2": {"stress": 1e5}, "x3": {"strain_increment": 0})";
  const Deck deck = program_deck(R"({"name": "ss", "friction": 0.5, "legs": [
      {"axes": {)" + axes + R"(, "x12": {"strain_increment": 2e-6}}, "end": {"axis": "x12", "strain": 0.01}},
      {"axes": {)" + axes + R"(, "x12": {"strain_rate": -1.0}}, "end": {"axis": "x12", "strain": 0.004}}]})");
  const std::vector<std::int64_t> planned = program_leg_steps(deck.tests[0].legs, deck.time_step);
  ASSERT_EQ(planned, (std::vector<std::int64_t>{5000, 6000}));
  const std::string lmp = translate_test(deck, deck.tests[0], TargetCode::Lammps);
  const std::vector<std::string> blocks = leg_blocks(lmp);
  ASSERT_EQ(blocks.size(), 3u);
  EXPECT_EQ(command_lines(blocks[1], "run"), std::vector<std::string>{"run             5000"});
  EXPECT_EQ(command_lines(blocks[2], "run"), std::vector<std::string>{"run             6000"});
  EXPECT_TRUE(contains(blocks[1], "until g12 = 0.01 (5000 steps)")) << blocks[1];
  // A one-leg simple shear to g12 = 0.01: run ${steps} with the steps, in LIGGGHTS too.
  const Deck one = program_deck(R"({"name": "dss", "friction": 0.5,
      "simple_shear": {"gamma_increment": 2e-6, "normal_stress": 1e5}, "end": {"axis": "x12", "strain": 0.01}})");
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts})
    EXPECT_TRUE(contains(translate_test(one, one.tests[0], code), "\nvariable        steps index 5000\n"));
  // After a ratio end the leg's start is known at run time only: N from the tilt, celldem's leg_steps.
  const Deck late = program_deck(R"({"name": "late", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
       "end": {"ratio": 1.5, "max_steps": 10000}},
      {"axes": {)" + axes + R"(, "x12": {"strain_increment": 2e-6}}, "end": {"axis": "x12", "strain": 0.01}}]})");
  const std::string run_time = translate_test(late, late.tests[0], TargetCode::Lammps);
  const std::vector<std::string> late_blocks = leg_blocks(run_time);
  ASSERT_EQ(late_blocks.size(), 3u);
  EXPECT_EQ(formula(late_blocks[2], "n2"), "round((0.01-(-(xy-v_T0xy)/v_L02))/2e-06)");
  EXPECT_EQ(command_lines(late_blocks[2], "run"), std::vector<std::string>{"run             ${n2}"});
}

// b and mean_stress: the translated targets, evaluated for a known stress state, are celldem's stress_targets().
TEST(TranslateProgram, BAndMeanStressTargetsAreCelldems) {
  const Deck deck = program_deck(R"({"name": "bp", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"b": 0.25}, "x3": {"mean_stress": 1e5}},
       "end": {"axis": "x1", "strain": 0.001}},
      {"axes": {"x1": {"strain_increment": -2e-7}, "x2": {"b": 0.75}, "x3": {"stress": 8e4}},
       "end": {"axis": "x1", "strain": 0.0005}},
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"mean_stress": 1.5e5}, "x3": {"mean_stress": 1.5e5}},
       "end": {"axis": "x1", "strain": 0.001}},
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"b": 0.5}, "x3": {"stress": 2e4}},
       "end": {"axis": "x1", "strain": 0.0015}}]})");
  const TestDef& test = deck.tests[0];
  const Vec3 s(1.6e5, 1.1e5, 4.0e4);  // the contact stresses c_P[1..3] of some step
  // By hand: leg 1, b = 0.25, p = 1e5: s3 = (3p - 1.25 s1)/1.75 = (3e5 - 2e5)/1.75, s2 = s3 + 0.25 (s1 - s3).
  const double t3 = (3e5 - 1.25 * 1.6e5) / 1.75;
  const std::vector<Vec3> by_hand = {Vec3(NAN, t3 + 0.25 * (1.6e5 - t3), t3),
                                     Vec3(NAN, 8e4 + 0.75 * (1.6e5 - 8e4), 8e4),  // 140 kPa
                                     Vec3(NAN, (4.5e5 - 1.6e5) / 2, (4.5e5 - 1.6e5) / 2),  // 145 kPa
                                     Vec3(NAN, 2e4 + 0.5 * (1.6e5 - 2e4), 2e4)};
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts}) {
    const std::string script = translate_test(deck, test, code);
    const std::vector<std::string> blocks = leg_blocks(script);
    ASSERT_EQ(blocks.size(), 5u);
    for (int j = 0; j < 4; ++j) {
      const std::string& block = blocks[j + 1];
      Formula f(block, s);
      const Vec3 celldem = stress_targets(test.legs[j].axes, s, 0.0);
      for (int k = 1; k < 3; ++k) {
        std::string name = "t";  // built in steps: GCC 12 warns (-Wrestrict) about "t" + ... + "y"
        name += std::to_string(j + 1);
        name += k == 1 ? 'y' : 'z';
        const AxisMode mode = test.legs[j].axes[k].mode;
        std::string target = formula(block, name);
        if (mode == AxisMode::Stress) {  // a constant: press/berendsen (LAMMPS) or in the servo formula
          EXPECT_TRUE(target.empty()) << name;
          continue;
        }
        ASSERT_FALSE(target.empty()) << name << " in leg " << j + 1;
        const double value = f.eval(target);
        EXPECT_NEAR(value, by_hand[j][k], 1e-9 * std::abs(by_hand[j][k])) << name << " = " << target;
        EXPECT_NEAR(value, celldem[k], 1e-9 * std::abs(celldem[k])) << name;
        // The servo moves the axis by the press/berendsen law towards this target.
        std::string d_name = "d";  // (appended: GCC 12 warns -Wrestrict on "d" + string)
        d_name += name.substr(1);
        const std::string d = formula(block, d_name);
        EXPECT_TRUE(contains(d, "*(v_" + name + "-c_P[" + std::to_string(k + 1) + "])/")) << d;
      }
    }
    // The stress axis beside a b axis is a press/berendsen axis in LAMMPS, a variable servo in LIGGGHTS.
    if (code == TargetCode::Lammps)
      EXPECT_TRUE(contains(blocks[2], "press/berendsen z 80000 80000 "));
    else
      EXPECT_TRUE(contains(formula(blocks[2], "d2z"), "*(80000-c_P[3])/"));
  }
  // The targets are listed as a difference: no integral term, nominal stiffness.
  bool listed = false;
  for (const std::string& d : model_differences(deck, TargetCode::Lammps))
    listed = listed || d.rfind("b and mean_stress axes", 0) == 0;
  EXPECT_TRUE(listed);
}

TEST(TranslateProgram, ConstantVolumeIsFixDeformVolume) {
  const Deck deck = program_deck(R"({"name": "undrained", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"constant_volume": true}, "x3": {"stress": 1e5}},
       "end": {"steps": 1000}},
      {"axes": {"x1": {"strain_increment": -2e-7}, "x2": {"constant_volume": true}, "x3": {"constant_volume": true}},
       "end": {"axis": "x1", "strain": 0.0001}}]})");
  const std::string lmp = translate_test(deck, deck.tests[0], TargetCode::Lammps);
  const std::vector<std::string> blocks = leg_blocks(lmp);
  ASSERT_EQ(blocks.size(), 3u);
  // Leg 1: y by volume; the stress axis z in the same fix deform (a variable servo), not press/berendsen,
  // which fix deform volume would not see.
  EXPECT_TRUE(contains(blocks[1], "\nfix             dfm all deform 1 x erate -0.2 y volume z variable v_d1z v_r1z "
                                  "remap x\n"));
  EXPECT_FALSE(contains(blocks[1], "press/berendsen"));
  EXPECT_EQ(command_lines(blocks[1], "run"), std::vector<std::string>{"run             1000"});
  // Leg 2: two volume axes scale together; 500 steps from e1 = 0.02 % back to 0.01 % (known here).
  EXPECT_TRUE(contains(blocks[2], "\nfix             dfm all deform 1 x vel $(0.2*v_L01:%.17g) y volume z volume "
                                  "remap x units box\n"));
  EXPECT_EQ(command_lines(blocks[2], "run"),
            std::vector<std::string>{"run             " +
                                     std::to_string(leg_steps(deck.tests[0].legs[1], deck.time_step, 1000 * 2e-7))});
  EXPECT_EQ(leg_steps(deck.tests[0].legs[1], deck.time_step, 1000 * 2e-7), 500);
  const std::string lig = translate_test(deck, deck.tests[0], TargetCode::Liggghts);
  EXPECT_TRUE(contains(lig, "\nfix             dfm all deform 1 x erate -0.2 y volume z variable v_d1z v_r1z remap x\n"));
  EXPECT_TRUE(contains(lig, " y volume z volume remap x\n"));
}

TEST(TranslateProgram, OneLegTestsKeepTheirForm) {
  // A one-leg test written as "legs" is the one-leg script: run length overridable with -var steps.
  const Deck a = program_deck(R"({"name": "t", "friction": 0.5, "legs": [
      {"axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
       "end": {"axis": "x1", "strain": 0.001}}]})");
  const Deck b = program_deck(R"({"name": "t", "friction": 0.5,
      "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"axis": "x1", "strain": 0.001}})");
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts}) {
    const std::string s = translate_test(a, a.tests[0], code);
    EXPECT_EQ(s, translate_test(b, b.tests[0], code));
    EXPECT_TRUE(contains(s, "\nvariable        steps index 5000\n"));
    EXPECT_FALSE(contains(s, "# ---- leg "));
    EXPECT_FALSE(contains(s, "unfix"));
  }
}

TEST(TranslateProgram, SnapshotsAreListedAsNotTranslated) {
  auto listed = [](const Deck& d) {
    for (const std::string& w : model_differences(d, TargetCode::Lammps))
      if (w.rfind("snapshots", 0) == 0) return true;
    return false;
  };
  const char* test = R"({"name": "t", "friction": 0.5, %s
      "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"axis": "x1", "strain": 0.001}})";
  char with[512], without[512];
  std::snprintf(with, sizeof with, test, R"("snapshots": {"interval": 1000},)");
  std::snprintf(without, sizeof without, test, "");
  EXPECT_TRUE(listed(program_deck(with)));
  EXPECT_FALSE(listed(program_deck(without)));
}

TEST(TranslateProgram, PreparationScript) {
  const Deck deck = parse_deck(R"({"format": 1,
    "sample": {"count": 8, "diameters": {"list": [0.003, 0.004]}, "density": 2500, "grid_spacing": 0.005},
    "contact": {"kn": 1e6, "kt": 1e6}, "damping": {"translational": 0.05, "rotational": 0.05},
    "time_step": 1e-6,
    "prepare": {"target_pressure": 1e5, "fast_solid_fraction": 0.5,
                "equilibrium": {"unbalanced_force_ratio": 0.01, "min_steps": 2000, "check_interval": 500}},
    "tests": []})",
                               "dir/prep.json");
  EXPECT_THROW(translate_preparation(deck_with(), TargetCode::Lammps), DeckError);  // no prepare
  const std::string lmp = translate_preparation(deck, TargetCode::Lammps);
  const std::vector<std::string> blocks = leg_blocks(lmp);
  ASSERT_EQ(blocks.size(), 3u);  // the default program: fast compression, then the servo to equilibrium
  EXPECT_TRUE(contains(lmp, "\nvariable        data index sample.data\n"));
  EXPECT_TRUE(contains(lmp, "\nwrite_data      ${prepared} nocoeff\n"));
  EXPECT_EQ(formula(blocks[1], "now1"), "mass(all)/(2500*vol)");
  EXPECT_TRUE(contains(blocks[1], "halt 1 v_end1 >= 0.0"));
  EXPECT_TRUE(contains(blocks[2], "press/berendsen x 1e+05 1e+05 "));
  EXPECT_TRUE(contains(formula(blocks[2], "eq2"), "(v_ubf<=0.01)"));
  EXPECT_EQ(formula(blocks[2], "done2"), "(step-v_S2>=2000)&&v_eq2");
  EXPECT_EQ(command_lines(blocks[2], "run"),
            (std::vector<std::string>{"run             500 post no", "run             500 pre no post no"}));
  const std::string lig = translate_preparation(deck, TargetCode::Liggghts);
  EXPECT_TRUE(contains(lig, "\nwrite_data      ${prepared}\n"));
  EXPECT_TRUE(command_lines(lig, "fix             hlt").empty());
  EXPECT_EQ(command_lines(lig, "run").size(), 4u);  // leg 1 and leg 2 in chunks after a run of 0 steps
}

// A deck whose stages run at their own time steps (prepare.time_step, tests[].time_step, as --tolerance resolves
// them): each script sets its stage's timestep before its first run, and makes from it what celldem makes per step.
TEST(TranslateTimeSteps, EachScriptRunsItsStageAtItsOwnTimeStep) {
  const Deck deck = parse_deck(R"({"format": 1,
    "sample": {"count": 8, "diameters": {"list": [0.003, 0.004]}, "density": 2500, "grid_spacing": 0.005},
    "contact": {"kn": 1e6, "kt": 1e6}, "damping": {"translational": 0.05, "rotational": 0.05},
    "time_step": 1e-6,
    "prepare": {"target_pressure": 1e5, "fast_solid_fraction": 0.5, "time_step": 2e-6,
                "equilibrium": {"unbalanced_force_ratio": 0.01, "min_steps": 2000, "check_interval": 500}},
    "tests": [{"name": "own", "friction": 0.5, "time_step": 2.5e-6,
               "axes": {"x1": {"strain_increment": 5e-7}, "x2": {"stress": 1e5}, "x3": {"strain_rate": -0.1}},
               "end": {"axis": "x1", "strain": 0.002}, "output_interval": 100},
              {"name": "deck", "friction": 0.5,
               "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
               "end": {"axis": "x1", "strain": 0.002}, "output_interval": 100}]})",
                               "dir/stages.json");
  ASSERT_EQ(deck.stage_time_step(deck.tests[0]), 2.5e-6);
  // The timestep line of each script comes before its first run and is the stage's.
  const auto timestep_before_run = [](const std::string& script) {
    const std::vector<std::string> lines = command_lines(script, "timestep");
    EXPECT_EQ(lines.size(), 1u);
    EXPECT_LT(script.find("\ntimestep "), script.find("\nrun "));
    return lines.empty() ? std::nan("") : numbers(lines[0].substr(8)).at(0);
  };
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts}) {
    SCOPED_TRACE(target_code_name(code));
    const std::string prep = translate_preparation(deck, code);
    EXPECT_EQ(timestep_before_run(prep), 2e-6);
    EXPECT_TRUE(contains(prep, "\nvariable        time equal step*2e-06\n"));
    const std::string own = translate_test(deck, deck.tests[0], code);
    EXPECT_EQ(timestep_before_run(own), 2.5e-6);
    EXPECT_TRUE(contains(own, "\nvariable        time equal step*2.5e-06\n"));
    // x1's increment per step over the stage's step is fix deform's rate; the strain rate of x3 stays a rate; the
    // run's length is celldem's leg_steps at the stage's step (0.002 / 5e-7 = 4000).
    const std::int64_t n = leg_steps(deck.tests[0].legs[0], deck.stage_time_step(deck.tests[0]), 0.0);
    EXPECT_EQ(n, 4000);
    EXPECT_TRUE(contains(own, "\nvariable        steps index " + std::to_string(n) + "\n"));
    std::smatch rate;
    ASSERT_TRUE(std::regex_search(own, rate, std::regex(" x erate (\\S+) ")));
    EXPECT_DOUBLE_EQ(std::stod(rate[1]), -0.2);  // (at the deck's step it would be -0.5)
    EXPECT_TRUE(contains(own, " z erate 0.1 "));
    const std::string at_deck = translate_test(deck, deck.tests[1], code);
    EXPECT_EQ(timestep_before_run(at_deck), 1e-6);
    EXPECT_TRUE(contains(at_deck, "\nvariable        steps index 10000\n"));
  }
  // The servo: pdamp = dt / (3 gain) at the stage's step, so dt / pdamp, celldem's proportional gain, is the same.
  const std::string own = translate_test(deck, deck.tests[0], TargetCode::Lammps);
  const TranslatedServo servo = translated_servo(deck, 2.5e-6);
  EXPECT_DOUBLE_EQ(servo.pdamp, 2.5e-6 / (3.0 * deck.servo.gain));
  std::smatch m;
  const std::string srv = command_lines(own, "fix             srv").at(0);
  ASSERT_TRUE(std::regex_search(srv, m, std::regex(" y 1e\\+05 1e\\+05 (\\S+) ")));
  EXPECT_EQ(std::stod(m[1]), servo.pdamp);
  const std::string lig = translate_test(deck, deck.tests[0], TargetCode::Liggghts);
  const std::string dy = formula(lig, "dy");
  ASSERT_TRUE(std::regex_search(dy, m, std::regex("\\(1\\.0-(\\S+?)/(\\S+?)\\*")));
  EXPECT_EQ(std::stod(m[1]), 2.5e-6);
  EXPECT_EQ(std::stod(m[2]), servo.pdamp);
  // The notes name the per-stage steps; a deck whose stages share its step has no such note.
  const auto noted = [](const std::vector<std::string>& notes) {
    return std::any_of(notes.begin(), notes.end(), [](const std::string& n) { return n.rfind("per-stage time steps", 0) == 0; });
  };
  EXPECT_TRUE(noted(model_notes(deck, TargetCode::Lammps)));
  EXPECT_TRUE(noted(preparation_notes(deck, TargetCode::Liggghts)));
  EXPECT_TRUE(contains(own, "#   - per-stage time steps"));
  EXPECT_FALSE(noted(model_notes(deck_with(), TargetCode::Lammps)));
}

// ---- contact laws other than the plain linear one ----

Deck law_deck(const std::string& contact, const std::string& second_test_extra = "") {
  std::string text = R"({"format": 1,
    "sample": {"count": 3, "diameters": {"list": [0.003, 0.004]}, "density": 2500, "grid_spacing": 0.005},
    "contact": {)";
  text += contact;
  text += R"(},
    "damping": {"translational": 0.05, "rotational": 0.04},
    "time_step": 1e-7,
    "initial_state": "x.state",
    "tests": [{"name": "ttc", "friction": 0.5,
               "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
               "end": {"axis": "x1", "strain": 0.001}, "output_interval": 100},
              {"name": "strain", "friction": 0.3)";
  text += second_test_extra;
  text += R"(,
               "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"strain_increment": 0.0},
                        "x3": {"strain_increment": 0.0}},
               "end": {"axis": "x1", "strain": 0.0004}}]})";
  return parse_deck(text, "dir/law.json");
}

const char* kHertzMindlin = R"("normal": "hertz", "tangential": "mindlin", "youngs_modulus": 7e10, "poisson_ratio": 0.25)";
const char* kRolling = R"(, "rolling": "sds", "rolling_stiffness": 1e6, "rolling_damping": 2, "rolling_friction": 0.1)";

// Concatenation by appending (GCC 12 warns -Wrestrict on chains of string + literal).
std::string cat(std::initializer_list<const char*> parts) {
  std::string s;
  for (const char* p : parts) s += p;
  return s;
}

std::string line_of(const std::string& script, const std::string& prefix) {
  const auto at = script.find("\n" + prefix);
  if (at == std::string::npos) return "";
  return script.substr(at + 1, script.find('\n', at + 1) - at - 1);
}

TEST(TranslateLaws, LinearDeckKeepsGranHookeHistory) {
  // Naming the plain law's sub-models changes nothing: the script is byte-identical, gran/hooke/history.
  const Deck plain = deck_with();
  const Deck named = deck_with(R"(, "normal": "linear", "tangential": "linear_history", "rolling": "none", "twisting": "none")");
  for (TargetCode code : {TargetCode::Lammps, TargetCode::Liggghts})
    for (std::size_t t = 0; t < plain.tests.size(); ++t)
      EXPECT_EQ(translate_test(plain, plain.tests[t], code), translate_test(named, named.tests[t], code));
  const std::string s = translate_test(named, named.tests[0], TargetCode::Lammps);
  EXPECT_EQ(line_of(s, "pair_style"), "pair_style      gran/hooke/history 1e+06 5e+05 0.0 0.0 0.5 0");
  EXPECT_FALSE(contains(s, "granular"));
}

TEST(TranslateLaws, LammpsPairGranularPerLaw) {
  {  // hertz + mindlin: material parameters, NULL = LAMMPS's 8 G*, damping coefficients 0, per-test friction
    const Deck d = law_deck(kHertzMindlin);
    const std::string s = translate_test(d, d.tests[0], TargetCode::Lammps);
    EXPECT_EQ(line_of(s, "pair_style"), "pair_style      granular");
    EXPECT_EQ(line_of(s, "pair_coeff"),
              "pair_coeff      * * hertz/material 7e+10 0.0 0.25 damping viscoelastic tangential mindlin NULL 0.0 0.5");
    EXPECT_FALSE(contains(s, "\npair_style      gran/hooke/history"));
    EXPECT_EQ(line_of(translate_test(d, d.tests[1], TargetCode::Lammps), "pair_coeff"),
              "pair_coeff      * * hertz/material 7e+10 0.0 0.25 damping viscoelastic tangential mindlin NULL 0.0 0.3");
    // Rotational damping from mindlin's reference stiffness (contact.kt is not given), a finite servo.
    EXPECT_EQ(scales(s, "fix             bdr").size(), 2u);
    const TranslatedServo servo = translated_servo(d, d.time_step);
    EXPECT_GT(servo.modulus, 0.0);
    EXPECT_TRUE(std::isfinite(servo.modulus));
  }
  {  // + rolling sds: k_roll gamma_roll mu_roll, the test's rolling friction
    const Deck d = law_deck(cat({kHertzMindlin, kRolling}), R"(, "rolling_friction": 0.2)");
    EXPECT_EQ(line_of(translate_test(d, d.tests[0], TargetCode::Lammps), "pair_coeff"),
              "pair_coeff      * * hertz/material 7e+10 0.0 0.25 damping viscoelastic tangential mindlin NULL 0.0 0.5 "
              "rolling sds 1e+06 2 0.1");
    EXPECT_EQ(line_of(translate_test(d, d.tests[1], TargetCode::Lammps), "pair_coeff"),
              "pair_coeff      * * hertz/material 7e+10 0.0 0.25 damping viscoelastic tangential mindlin NULL 0.0 0.3 "
              "rolling sds 1e+06 2 0.2");
  }
  {  // + twisting marshall
    const Deck d = law_deck(cat({kHertzMindlin, kRolling, R"(, "twisting": "marshall")"}));
    EXPECT_EQ(line_of(translate_test(d, d.tests[0], TargetCode::Lammps), "pair_coeff"),
              "pair_coeff      * * hertz/material 7e+10 0.0 0.25 damping viscoelastic tangential mindlin NULL 0.0 0.5 "
              "rolling sds 1e+06 2 0.1 twisting marshall");
    const std::vector<std::string> diff = model_differences(d, TargetCode::Lammps);
    EXPECT_TRUE(std::any_of(diff.begin(), diff.end(), [](const std::string& w) { return contains(w, "twisting marshall: at the cap"); }));
    EXPECT_TRUE(std::any_of(diff.begin(), diff.end(), [](const std::string& w) { return contains(w, "rolling sds:"); }));
    EXPECT_TRUE(std::any_of(diff.begin(), diff.end(), [](const std::string& w) { return contains(w, "full radii"); }));
  }
  {  // linear normal with rolling: hooke; linear normal with mindlin: 8 G* as a number (NULL needs a material)
    const Deck d = law_deck(cat({R"("kn": 1e6, "kt": 5e5)", kRolling}));
    EXPECT_EQ(line_of(translate_test(d, d.tests[0], TargetCode::Lammps), "pair_coeff"),
              "pair_coeff      * * hooke 1e+06 0.0 damping viscoelastic tangential linear_history 5e+05 0.0 0.5 "
              "rolling sds 1e+06 2 0.1");
    const Deck m = law_deck(R"("kn": 1e6, "tangential": "mindlin", "youngs_modulus": 7e10, "poisson_ratio": 0.25)");
    const std::string line = line_of(translate_test(m, m.tests[0], TargetCode::Lammps), "pair_coeff");
    const std::vector<double> g = numbers(line.substr(line.find("mindlin ") + 8));
    ASSERT_GE(g.size(), 1u);
    EXPECT_DOUBLE_EQ(g[0], 8.0 * 7e10 / (4.0 * 1.75 * 1.25));
  }
  {  // mindlin_rescale: LAMMPS's tangential model of that name, the same coefficients as mindlin
    const Deck d = law_deck(R"("normal": "hertz", "tangential": "mindlin_rescale", "youngs_modulus": 7e10, )"
                            R"("poisson_ratio": 0.25)");
    const std::string s = translate_test(d, d.tests[0], TargetCode::Lammps);
    EXPECT_EQ(line_of(s, "pair_coeff"), "pair_coeff      * * hertz/material 7e+10 0.0 0.25 damping viscoelastic "
                                        "tangential mindlin_rescale NULL 0.0 0.5");
    EXPECT_TRUE(contains(s, "hertz + mindlin_rescale"));
    const Deck m = law_deck(R"("kn": 1e6, "tangential": "mindlin_rescale", "youngs_modulus": 7e10, )"
                            R"("poisson_ratio": 0.25)");
    const std::string line = line_of(translate_test(m, m.tests[0], TargetCode::Lammps), "pair_coeff");
    ASSERT_NE(line.find("mindlin_rescale "), std::string::npos) << line;
    const std::vector<double> g = numbers(line.substr(line.find("mindlin_rescale ") + 16));
    ASSERT_GE(g.size(), 1u);
    EXPECT_DOUBLE_EQ(g[0], 8.0 * 7e10 / (4.0 * 1.75 * 1.25));
  }
}

// LIGGGHTS 3.8 has no rescaling tangential model: the scripts run Mindlin's spring without it, and say so.
TEST(TranslateLaws, LiggghtsCannotExpressMindlinRescale) {
  const Deck d = law_deck(R"("normal": "hertz", "tangential": "mindlin_rescale", "youngs_modulus": 7e10, )"
                          R"("poisson_ratio": 0.25)");
  const std::string s = translate_test(d, d.tests[0], TargetCode::Liggghts);
  EXPECT_EQ(line_of(s, "pair_style"), "pair_style      gran model hertz tangential history tangential_damping off");
  const std::vector<std::string> diff = model_differences(d, TargetCode::Liggghts);
  EXPECT_TRUE(std::any_of(diff.begin(), diff.end(), [](const std::string& w) {
    return contains(w, "\"mindlin_rescale\"; LIGGGHTS 3.8 cannot express it");
  }));
  EXPECT_TRUE(contains(s, "LIGGGHTS 3.8 cannot express it"));
  // plain mindlin has no such line
  for (const std::string& w : model_differences(law_deck(kHertzMindlin), TargetCode::Liggghts))
    EXPECT_FALSE(contains(w, "mindlin_rescale")) << w;
}

TEST(TranslateLaws, LiggghtsClosestModelsAndWhatItCannotExpress) {
  const Deck d = law_deck(cat({kHertzMindlin, kRolling, R"(, "twisting": "marshall")"}));
  const std::string s = translate_test(d, d.tests[0], TargetCode::Liggghts);
  EXPECT_EQ(line_of(s, "pair_style"),
            "pair_style      gran model hertz tangential history rolling_friction epsd2 tangential_damping off");
  EXPECT_EQ(line_of(s, "fix             m1"), "fix             m1 all property/global youngsModulus peratomtype 7e+10 7e+10");
  EXPECT_EQ(line_of(s, "fix             m3"),
            "fix             m3 all property/global coefficientRestitution peratomtypepair 2 1 1 1 1");
  EXPECT_EQ(line_of(s, "fix             m5"),
            "fix             m5 all property/global coefficientRollingFriction peratomtypepair 2 0.1 0.1 0.1 0.1");
  EXPECT_TRUE(contains(s, "\nhard_particles  yes\n"));
  const std::vector<std::string> diff = model_differences(d, TargetCode::Liggghts);
  EXPECT_TRUE(std::any_of(diff.begin(), diff.end(), [](const std::string& w) { return contains(w, "cannot express twisting"); }));
  EXPECT_TRUE(std::any_of(diff.begin(), diff.end(), [](const std::string& w) { return contains(w, "no sds rolling model"); }));
  // ... and the header lists them.
  EXPECT_TRUE(contains(s, "cannot express twisting"));
  // hertz + mindlin alone: no rolling model, no difference about rolling or twisting.
  const Deck hm = law_deck(kHertzMindlin);
  EXPECT_EQ(line_of(translate_test(hm, hm.tests[0], TargetCode::Liggghts), "pair_style"),
            "pair_style      gran model hertz tangential history tangential_damping off");
  for (const std::string& w : model_differences(hm, TargetCode::Liggghts))
    EXPECT_FALSE(contains(w, "rolling") || contains(w, "twisting")) << w;
}

}  // namespace
}  // namespace celldem
