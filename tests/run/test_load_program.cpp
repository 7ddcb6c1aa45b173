// Load programs on a real packing (solver/run/program.hpp, cell/control.hpp): each control holds what it
// promises (b within 0.01, p within 0.5 %, volume within 1e-6, checked independently from the series), legs
// end where they should (strain in either direction, a stress ratio, a step count, a stress reached by a
// stress ramp, equilibrium), repeated blocks run in order, a stress ramp's axis follows its moving target, and
// a program resumed from a checkpoint ends byte-identical.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.hpp"
#include "helpers.hpp"
#include "measure/series.hpp"
#include "run/health.hpp"
#include "run/adaptive_rate.hpp"
#include "run/program.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using testing::celldem;
using testing::read_bytes;
using testing::Result;
using testing::run_args;
using testing::test_dir;
using testing::write_bytes;

using testing::read_series;

const std::string kTests = R"([
  {"name": "bp", "friction": 0.5, "output_interval": 200,
   "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"b": 0.5}, "x3": {"mean_stress": 1e5}},
   "end": {"axis": "x1", "strain": 0.006}},
  {"name": "bp_fast_b05", "friction": 0.5, "output_interval": 200,
   "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"b": 0.5}, "x3": {"mean_stress": 1e5}},
   "end": {"axis": "x1", "strain": 0.01}},
  {"name": "bp_fast_b1", "friction": 0.5, "output_interval": 200,
   "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"b": 1.0}, "x3": {"mean_stress": 1e5}},
   "end": {"axis": "x1", "strain": 0.01}},
  {"name": "bp_fast_b1_zero_shear", "friction": 0.5, "output_interval": 200, "zero_shear_stress": true,
   "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"b": 1.0}, "x3": {"mean_stress": 1e5}},
   "end": {"axis": "x1", "strain": 0.01}},
  {"name": "volume", "friction": 0.5, "output_interval": 200,
   "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"constant_volume": true}, "x3": {"constant_volume": true}},
   "end": {"axis": "x1", "strain": 0.004}},
  {"name": "cycles", "friction": 0.5, "output_interval": 170,
   "legs": [
     {"axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"axis": "x1", "strain": 0.003}},
     {"repeat": 2, "legs": [
       {"axes": {"x1": {"strain_increment": -1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
        "end": {"axis": "x1", "strain": 0.002}},
       {"axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
        "end": {"axis": "x1", "strain": 0.004}}]}]},
  {"name": "ratio", "friction": 0.5, "output_interval": 1,
   "legs": [
     {"axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"ratio": 1.8, "max_steps": 100000}},
     {"axes": {"x1": {"strain_increment": 0}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"steps": 300}}]},
  {"name": "ramp", "friction": 0.5, "output_interval": 200,
   "axes": {"x1": {"stress_ramp": {"from": 1e5, "rate": 5e6}}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
   "end": {"axis": "x1", "stress": 1.5e5, "max_steps": 20000}},
  {"name": "consolidate", "friction": 0.5, "output_interval": 250,
   "equilibrium": {"pressure_tolerance": 0.005, "stress_tolerance": 0.005, "unbalanced_force_ratio": 0.01,
                   "min_steps": 1000, "check_interval": 100, "max_steps": 100000},
   "legs": [
     {"axes": {"x1": {"stress_ramp": {"from": 1e5, "rate": 5e6}}, "x2": {"stress_ramp": {"from": 1e5, "rate": 5e6}},
               "x3": {"stress_ramp": {"from": 1e5, "rate": 5e6}}},
      "end": {"axis": "x1", "stress": 1.2e5, "max_steps": 20000}},
     {"axes": {"x1": {"stress": 1.2e5}, "x2": {"stress": 1.2e5}, "x3": {"stress": 1.2e5}},
      "end": {"equilibrium": true}},
     {"axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1.2e5}, "x3": {"stress": 1.2e5}},
      "end": {"axis": "x1", "strain": 0.002}}]},
  {"name": "shear_end", "friction": 0.5, "output_interval": 400,
   "legs": [
     {"simple_shear": {"gamma_increment": 1e-6, "normal_stress": 1e5}, "end": {"axis": "x12", "strain": 0.003}},
     {"simple_shear": {"gamma_rate": -1.0, "normal_stress": 1e5}, "end": {"axis": "x12", "strain": 0.001}}]},
  {"name": "rotation", "friction": 0.5, "output_interval": 200,
   "legs": [
     {"axes": {"x1": {"stress_ramp": {"from": 1e5, "rate": 5e6}}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"axis": "x1", "stress": 1.5e5, "max_steps": 20000}},
     {"axes": {"x2": {"stress": 1e5}},
      "rotate_principal_axes": {"plane": "x1x3", "sigma1": 1.5e5, "sigma3": 1e5, "from": 0,
                                "angle_increment": 0.0075},
      "end": {"steps": 12000}}]},
  {"name": "adaptive_fast", "friction": 0.5, "output_interval": 100,
   "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
   "adaptive_rate": {"max_factor": 4, "unbalanced_force_ratio": 1, "kinetic_to_elastic": 1, "inertial_number": 1,
                     "check_interval": 100},
   "end": {"axis": "x1", "strain": 0.008}},
  {"name": "adaptive_slow", "friction": 0.5, "output_interval": 100,
   "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
   "adaptive_rate": {"min_factor": 0.5, "unbalanced_force_ratio": 1e-9, "check_interval": 100},
   "end": {"axis": "x1", "strain": 0.004}},
  {"name": "adaptive_ceiling", "friction": 0.5, "output_interval": 100,
   "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
   "adaptive_rate": {"max_factor": 100, "unbalanced_force_ratio": 1, "kinetic_to_elastic": 1, "inertial_number": 1.2e-3,
                     "check_interval": 100},
   "end": {"axis": "x1", "strain": 0.008}},
  {"name": "ramp_path", "friction": 0.5, "output_interval": 200,
   "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress_ramp": {"from": 1e5, "rate": -5e6}},
            "x3": {"stress_ramp": {"from": 1e5, "rate": -5e6}}},
   "end": {"axis": "x1", "strain": 0.005}}])";

// The ramps' rate and time step (kTests): 5 Pa per step.
constexpr double kRampRate = 5e6, kTimeStep = 1e-6;

// A deck of these tests on the prepared packing prep/prepared.state, at kTimeStep, with the servo's default
// cap (each leg's follows its rate), not the small decks' fixed one.
std::string program_deck(const std::string& tests) {
  std::string deck = testing::small_deck_json(300, tests, 11);
  const std::string cap = "\"servo\": {\"max_strain_increment\": 4e-5},";
  EXPECT_NE(deck.find(cap), std::string::npos);
  deck.erase(deck.find(cap), cap.size());
  const auto at = deck.find("\"prepare\"");
  deck.replace(at, deck.find("}},", at) + 3 - at, "\"initial_state\": \"prep/prepared.state\",");
  deck.replace(deck.find("\"time_step\": 3.0e-6"), 19, "\"time_step\": 1.0e-6");
  return deck;
}

// One prepared packing and one run of the tests above, shared by the checks below.
struct ProgramRun {
  fs::path dir;
  Json summary;
  // ctest runs each test in its own process, side by side: a folder per process.
  ProgramRun() : dir(test_dir("load_program_" + std::to_string(getpid()))) {
    std::string prep = testing::small_deck_json(300, "[]", 11);
    write_bytes(dir / "prep.json", prep);
    Result r = celldem(dir, run_args(dir / "prep.json", dir / "prep"));
    EXPECT_EQ(r.code, 0) << r.err;
    const std::string deck = program_deck(kTests);
    write_bytes(dir / "deck.json", deck);
    r = celldem(dir, run_args(dir / "deck.json", dir / "run", "--quiet"));
    EXPECT_EQ(r.code, 0) << r.err;
    summary = Json::parse(read_bytes(dir / "run" / "summary.json"));
  }
};
const ProgramRun& program_run() {
  static const ProgramRun run;
  return run;
}

// zero_shear_stress beside b = 1 and p: the shear stresses held at 0 (their errors relative to p, in
// summary.json and independently from the series), so the principal stresses stay on the axes and
// b_principal is the axis b the control holds; without it the free shear stresses pull them apart.
TEST(LoadProgram, ZeroShearStressKeepsThePrincipalStressesOnTheAxes) {
  const ProgramRun& run = program_run();
  const Json errors = run.summary["tests"]["bp_fast_b1_zero_shear"]["legs"][0]["control_errors"];
  ASSERT_EQ(errors["axes"].size(), 6u) << errors.dump();
  const double shear_error = errors["shear_stress"].get<double>();
  EXPECT_LT(shear_error, kServoTolerance);
  double worst_axis = 0.0;
  for (int k = 3; k < 6; ++k) {  // x12, x13, x23: each measured as a shear stress control
    EXPECT_EQ(errors["axes"][k]["kind"], "shear_stress") << k;
    worst_axis = std::max(worst_axis, errors["axes"][k]["error"].get<double>());
  }
  EXPECT_EQ(worst_axis, shear_error);
  EXPECT_LT(errors["b"].get<double>(), 0.01);
  // Without zero_shear_stress the shear axes are held tilts, not controls: nothing measured.
  const Json& free = run.summary["tests"]["bp_fast_b1"]["legs"][0]["control_errors"];
  EXPECT_TRUE(free["shear_stress"].is_null()) << free.dump();
  EXPECT_EQ(free["axes"][3]["kind"], "held");
  int checked = 0;
  double free_gap = 0.0;
  for (const SeriesRow& r : read_series(run.dir / "run" / "bp_fast_b1_zero_shear" / "series.csv")) {
    if (r.e1 < 0.002) continue;
    for (const double shear : {r.s12, r.s13, r.s23}) EXPECT_LT(std::abs(shear) / r.p, kServoTolerance) << r.step;
    EXPECT_NEAR(r.b_principal, r.b, 0.02) << r.step;
    ++checked;
  }
  EXPECT_GT(checked, 10);
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "bp_fast_b1_zero_shear" / "series.csv");
  EXPECT_GT(std::abs(rows.back().g12) + std::abs(rows.back().g13) + std::abs(rows.back().g23), 1e-6);
  for (const SeriesRow& r : read_series(run.dir / "run" / "bp_fast_b1" / "series.csv"))
    if (r.e1 >= 0.002) free_gap = std::max(free_gap, std::abs(r.b_principal - r.b));
  RecordProperty("free_shear_largest_b_gap", std::to_string(free_gap));
}

TEST(LoadProgram, BAndMeanStressHeldTogether) {
  const ProgramRun& run = program_run();
  const Json errors = run.summary["tests"]["bp"]["legs"][0]["control_errors"];
  EXPECT_LT(errors["b"].get<double>(), 0.01);
  EXPECT_LT(errors["mean_stress"].get<double>(), 0.005);
  EXPECT_GT(errors["steps"].get<int>(), 10000);  // checked at every step after the first 0.2 % of e1
  // Independently, from the series' axis stresses.
  int checked = 0;
  for (const SeriesRow& r : read_series(run.dir / "run" / "bp" / "series.csv")) {
    if (r.e1 < 0.002) continue;
    EXPECT_NEAR((r.s22 - r.s33) / (r.s11 - r.s33), 0.5, 0.01) << r.step;
    EXPECT_NEAR((r.s11 + r.s22 + r.s33) / 3.0, 1e5, 500.0) << r.step;
    EXPECT_GT(r.s11, r.s22);
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

// At 1e-6 per step, the rate at which a servo capped at 1e-6 missed p by tens of percent (b = 0.5) and tenfold
// (b = 1): the default cap follows the driving rate, so both controls hold, checked again from the series.
TEST(LoadProgram, BAndMeanStressHeldAtAFastRate) {
  const ProgramRun& run = program_run();
  for (const auto& [name, b] : {std::pair{"bp_fast_b05", 0.5}, std::pair{"bp_fast_b1", 1.0}}) {
    const Json& test = run.summary["tests"][name];
    EXPECT_TRUE(test["controlled"].get<bool>()) << name << ": " << test["control_failures"].dump();
    EXPECT_LT(test["servo_max_error"].get<double>(), 0.005) << name;
    EXPECT_LT(test["b_max_error"].get<double>(), 0.01) << name;
    EXPECT_DOUBLE_EQ(test["legs"][0]["servo_cap"].get<double>(), 1e-5) << name;  // the default: 10 x 1e-6
    int checked = 0;
    for (const SeriesRow& r : read_series(run.dir / "run" / name / "series.csv")) {
      if (r.e1 < 0.002) continue;
      EXPECT_NEAR((r.s22 - r.s33) / (r.s11 - r.s33), b, 0.01) << name << " step " << r.step;
      EXPECT_NEAR((r.s11 + r.s22 + r.s33) / 3.0, 1e5, 500.0) << name << " step " << r.step;
      ++checked;
    }
    EXPECT_GT(checked, 30) << name;
  }
}

TEST(LoadProgram, ConstantVolumeHeld) {
  const ProgramRun& run = program_run();
  EXPECT_LT(run.summary["tests"]["volume"]["legs"][0]["control_errors"]["volume"].get<double>(), 1e-6);
  for (const SeriesRow& r : read_series(run.dir / "run" / "volume" / "series.csv")) {
    EXPECT_NEAR(r.ev, 0.0, 1e-9) << r.step;
    EXPECT_NEAR(r.e2, r.e3, 1e-12) << r.step;  // equal lateral strains
  }
}

TEST(LoadProgram, LegsEndOnStrainInEitherDirectionAndRepeat) {
  const ProgramRun& run = program_run();
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "cycles" / "series.csv");
  // Legs: up to 0.003, down to 0.002, up to 0.004, down to 0.002, up to 0.004; 1e-6 per step, a row every 170
  // steps and one at each leg's end (the turning points), with the leg's end state in summary.json.
  const double turns[] = {0.003, 0.002, 0.004, 0.002, 0.004};
  std::int64_t step = 0;
  double e = 0.0;
  for (int leg = 0; leg < 5; ++leg) {
    step += std::llround(std::abs(turns[leg] - e) / 1e-6);
    e = turns[leg];
    bool found = false;
    for (const SeriesRow& r : rows)
      if (r.step == static_cast<double>(step)) {
        EXPECT_NEAR(r.e1, turns[leg], 1e-12) << "leg " << leg;
        EXPECT_EQ(r.leg, static_cast<double>(leg));
        found = true;
      }
    EXPECT_TRUE(found) << "no row at the end of leg " << leg << " (step " << step << ")";
    const Json& end = run.summary["tests"]["cycles"]["legs"][leg]["end"];
    EXPECT_EQ(end["step"].get<double>(), static_cast<double>(step)) << "leg " << leg;
    EXPECT_NEAR(end["e1"].get<double>(), turns[leg], 1e-9) << "leg " << leg;
    for (const char* key : {"e2", "e3", "s11", "s22", "s33", "p", "q", "b", "ev"}) EXPECT_TRUE(end.contains(key)) << key;
  }
  EXPECT_EQ(rows.back().step, static_cast<double>(step));
  EXPECT_EQ(rows.back().leg, 4.0);
  EXPECT_EQ(run.summary["tests"]["cycles"]["legs"].size(), 5u);
  // Unloading lowers the axial stress well below its value at the turn.
  double at_turn = 0.0, unloaded = 0.0;
  for (const SeriesRow& r : rows) {
    if (r.step == 3000) at_turn = r.s11;
    if (r.step == 4000) unloaded = r.s11;
  }
  EXPECT_LT(unloaded, 0.9 * at_turn);
}

// Shear legs that end on their shear strain: simple shear to g12 = 0.3 %, then back to 0.1 % (1e-6 per step
// both ways: an increment, then a rate of -1 /s at dt = 1e-6), each leg's end row at the planned step with g12 at
// its end strain, e1 = e3 = 0 throughout.
TEST(LoadProgram, ShearLegsEndOnTheirShearStrain) {
  const ProgramRun& run = program_run();
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "shear_end" / "series.csv");
  const double turns[] = {0.003, 0.001};
  const std::int64_t ends[] = {3000, 5000};
  for (int leg = 0; leg < 2; ++leg) {
    bool found = false;
    for (const SeriesRow& r : rows)
      if (r.step == static_cast<double>(ends[leg])) {
        EXPECT_NEAR(r.g12, turns[leg], 1e-12) << "leg " << leg;
        EXPECT_EQ(r.leg, static_cast<double>(leg));
        found = true;
      }
    EXPECT_TRUE(found) << "no row at the end of leg " << leg << " (step " << ends[leg] << ")";
    EXPECT_EQ(run.summary["tests"]["shear_end"]["legs"][leg]["end"]["step"].get<double>(), static_cast<double>(ends[leg]));
  }
  EXPECT_EQ(rows.back().step, 5000.0);
  for (const SeriesRow& r : rows) {
    EXPECT_EQ(r.e1, 0.0) << r.step;
    EXPECT_EQ(r.e3, 0.0) << r.step;
  }
}

// A principal-axis rotation on the packing: s11 ramped to sigma1 = 150 kPa, then sigma1 and sigma3 = 100 kPa turned
// from x1 to x3 (90 degrees in 12000 steps, s22 held at 100 kPa). From the series (the measured stress tensor, not
// the control's own record): after a 2000-step start the principal values of the x1-x3 stress stay within 0.5 %
// of sigma1 and sigma3, the major principal direction within 2 degrees of the angle, and at the end sigma1 lies
// on x3.
TEST(LoadProgram, PrincipalAxesRotateAtFixedPrincipalValues) {
  const ProgramRun& run = program_run();
  const Json& test = run.summary["tests"]["rotation"];
  ASSERT_EQ(test["legs"].size(), 2u);
  const double start = test["legs"][0]["end"]["step"].get<double>();  // where the ramp reached 150 kPa
  const double sigma1 = 1.5e5, sigma3 = 1e5, per_step = 0.0075 * M_PI / 180.0;
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "rotation" / "series.csv");
  double worst_value = 0.0, worst_angle = 0.0;
  int checked = 0;
  for (const SeriesRow& r : rows) {
    if (r.step < start + 2000) continue;
    const double m = 0.5 * (r.s11 + r.s33), half = std::hypot(0.5 * (r.s11 - r.s33), r.s13);
    worst_value = std::max({worst_value, std::abs((m + half) / sigma1 - 1.0), std::abs((m - half) / sigma3 - 1.0)});
    const double angle = 0.5 * std::atan2(2.0 * r.s13, r.s11 - r.s33);  // of sigma1 from x1 towards x3
    const double off = angle - (r.step - start) * per_step;
    worst_angle = std::max(worst_angle, std::abs(off - M_PI * std::round(off / M_PI)));  // directions mod 180
    EXPECT_NEAR(r.s22, 1e5, 0.005 * 1e5) << r.step;
    ++checked;
  }
  EXPECT_GE(checked, 40);
  EXPECT_LT(worst_value, 0.005);
  EXPECT_LT(worst_angle * 180.0 / M_PI, 2.0);
  RecordProperty("worst_principal_value_error", std::to_string(worst_value));
  RecordProperty("worst_angle_error_deg", std::to_string(worst_angle * 180.0 / M_PI));
  EXPECT_EQ(rows.back().step, start + 12000);
  EXPECT_NEAR(rows.back().s33, sigma1, 0.005 * sigma1);  // at 90 degrees sigma1 is on x3
  EXPECT_NEAR(rows.back().s11, sigma3, 0.005 * sigma1);
  EXPECT_EQ(test["controlled"], true);
}

TEST(LoadProgram, RatioAndStepEnds) {
  const ProgramRun& run = program_run();
  // The hold leg (x1 fixed, x2 and x3 at their stress) has no driving strain: nothing was measured (null).
  const Json& hold = run.summary["tests"]["ratio"]["legs"][1]["control_errors"];
  EXPECT_TRUE(hold["stress"].is_null()) << hold.dump();
  EXPECT_EQ(hold["steps"].get<int>(), 0);
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "ratio" / "series.csv");
  std::int64_t first_leg1 = -1;
  for (const SeriesRow& r : rows) {
    if (r.leg == 0.0) {  // a row per step: the leg ends on the first crossing
      EXPECT_LT(r.ratio13, 1.8 * 1.001) << r.step;
    }
    if (r.leg == 1.0 && first_leg1 < 0) first_leg1 = static_cast<std::int64_t>(r.step);
  }
  ASSERT_GT(first_leg1, 0);
  // The leg ended at the first step whose force evaluation gave s11/s33 >= 1.8: the row before is below.
  const SeriesRow& before = rows[static_cast<std::size_t>(first_leg1) - 1];
  EXPECT_GE(before.ratio13, 1.8);
  EXPECT_LT(rows[static_cast<std::size_t>(first_leg1) - 2].ratio13, 1.8);
  EXPECT_EQ(rows.back().step - (before.step), 300.0);  // the second leg's 300 steps
}

// A stress ramp (x1 from 100 kPa at 5 Pa per step, x2 and x3 held at 100 kPa) to an end stress of 150 kPa:
// after the settle window every row's s11 is within the stress tolerance of the moving target 1e5 + R t (t the
// row's time: one leg from the test start), and the leg ends when s11 reaches 150 kPa, where the target does:
// (150 - 100) kPa / (R dt) steps, within one output interval.
TEST(LoadProgram, StressRampFollowsItsMovingTargetAndEndsOnItsStress) {
  const ProgramRun& run = program_run();
  const Json& test = run.summary["tests"]["ramp"];
  EXPECT_TRUE(test["controlled"].get<bool>()) << test["control_failures"].dump();
  const Json& errors = test["legs"][0]["control_errors"];
  EXPECT_LT(errors["stress"].get<double>(), kServoTolerance);
  EXPECT_GT(errors["steps"].get<int>(), 5000);  // a ramp alone drives the leg: checked after kRampSettleSteps
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "ramp" / "series.csv");
  double worst = 0.0;
  int checked = 0;
  for (const SeriesRow& r : rows) {
    if (r.step < static_cast<double>(kRampSettleSteps)) continue;
    const double target = 1e5 + kRampRate * r.time;
    EXPECT_NEAR(r.time, r.step * kTimeStep, 1e-12);
    worst = std::max(worst, std::abs(r.s11 / target - 1.0));
    EXPECT_NEAR(r.s11 / target, 1.0, kServoTolerance) << r.step;
    EXPECT_NEAR(r.s22 / 1e5, 1.0, kServoTolerance) << r.step;
    EXPECT_NEAR(r.s33 / 1e5, 1.0, kServoTolerance) << r.step;
    ++checked;
  }
  EXPECT_GT(checked, 40);
  std::printf("stress ramp: largest |s11 / target - 1| over %d rows %.3g (summary, every step: %.3g)\n", checked, worst,
              errors["stress"].get<double>());
  const double expected_steps = (1.5e5 - 1e5) / (kRampRate * kTimeStep);
  const Json& end = test["legs"][0]["end"];
  EXPECT_NEAR(end["step"].get<double>(), expected_steps, 200.0);  // the output interval
  EXPECT_GE(end["s11"].get<double>(), 1.5e5);
  EXPECT_EQ(rows.back().step, end["step"].get<double>());
  EXPECT_LT(rows[rows.size() - 2].s11, 1.5e5);  // the row before had not reached it
}

// A stress path: x1 compressed at 1e-6 per step while x2 and x3 unload at 5 Pa per step from 100 kPa (to 75
// kPa at e1 = 0.5 %): after the settle window (0.2 % of driving strain) both lateral stresses stay within the
// stress tolerance of 1e5 - R t, measured every step (summary) and at every row (series).
TEST(LoadProgram, StressRampBesideAStrainDrivenAxis) {
  const ProgramRun& run = program_run();
  const Json& test = run.summary["tests"]["ramp_path"];
  EXPECT_TRUE(test["controlled"].get<bool>()) << test["control_failures"].dump();
  EXPECT_LT(test["legs"][0]["control_errors"]["stress"].get<double>(), kServoTolerance);
  EXPECT_GT(test["legs"][0]["control_errors"]["steps"].get<int>(), 2500);
  int checked = 0;
  for (const SeriesRow& r : read_series(run.dir / "run" / "ramp_path" / "series.csv")) {
    if (r.e1 < 0.002) continue;
    const double target = 1e5 - kRampRate * r.time;
    EXPECT_NEAR(r.s22 / target, 1.0, kServoTolerance) << r.step;
    EXPECT_NEAR(r.s33 / target, 1.0, kServoTolerance) << r.step;
    ++checked;
  }
  EXPECT_GT(checked, 10);
  EXPECT_NEAR(test["legs"][0]["end"]["s22"].get<double>(), 1e5 - kRampRate * 0.005 / 1e-6 * kTimeStep,
              kServoTolerance * 1e5);
}

// A consolidation: an isotropic stress ramp to 120 kPa, a hold leg that ends in equilibrium by the test's
// criterion (min_steps 1000, checked every 100 steps, stresses within 0.5 %, unbalanced force ratio 0.01),
// then a strain-driven leg from there. The hold leg ends at a check, not before min_steps, in a state that
// meets the criterion; its end is a row and a legs[] entry like any other leg's.
TEST(LoadProgram, TestLegEndsInEquilibrium) {
  const ProgramRun& run = program_run();
  const Json& test = run.summary["tests"]["consolidate"];
  ASSERT_EQ(test["legs"].size(), 3u);
  const Json& ramp_end = test["legs"][0]["end"];
  const Json& hold_end = test["legs"][1]["end"];
  EXPECT_NEAR(ramp_end["step"].get<double>(), (1.2e5 - 1e5) / (kRampRate * kTimeStep), 250.0);
  EXPECT_LT(test["legs"][0]["control_errors"]["stress"].get<double>(), kServoTolerance);
  const auto hold_steps = static_cast<std::int64_t>(hold_end["step"].get<double>() - ramp_end["step"].get<double>());
  EXPECT_GE(hold_steps, 1000);
  EXPECT_EQ(hold_steps % 100, 0) << hold_steps;
  EXPECT_LT(hold_steps, 100000);
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "consolidate" / "series.csv");
  bool found = false;
  for (const SeriesRow& r : rows) {
    if (r.step != hold_end["step"].get<double>()) continue;
    found = true;
    EXPECT_EQ(r.leg, 1.0);
    EXPECT_NEAR(r.p / 1.2e5, 1.0, 0.005);
    for (const double s : {r.s11, r.s22, r.s33}) EXPECT_NEAR(s / 1.2e5, 1.0, 0.005) << r.step;
    EXPECT_LE(r.unbalanced_force, 0.01);
    EXPECT_DOUBLE_EQ(r.s11, hold_end["s11"].get<double>());
  }
  EXPECT_TRUE(found) << "no row at the end of the equilibrium leg";
  // The next leg runs from there to its end strain.
  EXPECT_EQ(rows.back().leg, 2.0);
  EXPECT_NEAR(rows.back().e1, 0.002, 0.5e-6);  // its steps round from where the hold left e1: half a step
  EXPECT_GT(rows.back().s11, 1.5 * 1.2e5);
}

// A falling ramp whose target reaches 0 Pa stops the run (a run-time failure, exit 1) naming the axis; a bad
// ramp is a deck error (exit 2) naming the key; `plan` gives the step where the ramp's target meets the end
// stress, and the equilibrium criterion of a test with an equilibrium leg.
TEST(LoadProgram, StressRampFailuresAndPlan) {
  const ProgramRun& run = program_run();
  const std::string falling = R"([{"name": "falling", "friction": 0.5, "output_interval": 100,
      "axes": {"x1": {"stress_ramp": {"from": 1e5, "rate": -2e8}}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"steps": 2000}}])";
  write_bytes(run.dir / "falling.json", program_deck(falling));
  Result r = celldem(run.dir, run_args(run.dir / "falling.json", run.dir / "falling", "--quiet"));
  EXPECT_EQ(r.code, 1) << r.err;
  // 1e5 Pa at 200 Pa per step: the target of step 500 is 0.
  EXPECT_NE(r.err.find("stress_ramp target of axis x1 falls to 0 Pa after 499 steps"), std::string::npos) << r.err;

  // A hold leg that cannot reach its criterion in max_steps stops the run naming the test's key.
  const std::string hold = R"([{"name": "hold", "friction": 0.5, "output_interval": 100,
      "equilibrium": {"unbalanced_force_ratio": 1e-12, "min_steps": 100, "check_interval": 100, "max_steps": 300},
      "axes": {"x1": {"stress": 1.1e5}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}}, "end": {"equilibrium": true}}])";
  write_bytes(run.dir / "hold.json", program_deck(hold));
  r = celldem(run.dir, run_args(run.dir / "hold.json", run.dir / "hold", "--quiet"));
  EXPECT_EQ(r.code, 1) << r.err;
  EXPECT_NE(r.err.find("test 'hold' leg 0 did not reach equilibrium in 300 servo steps"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("raise tests[].equilibrium.max_steps"), std::string::npos) << r.err;

  std::string bad = program_deck(falling);
  bad.replace(bad.find("\"rate\": -2e8"), 12, "\"rate\": 0");
  write_bytes(run.dir / "bad.json", bad);
  r = celldem(run.dir, "check '" + (run.dir / "bad.json").string() + "'");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("tests[0].axes.x1.stress_ramp.rate"), std::string::npos) << r.err;

  r = celldem(run.dir, "check '" + (run.dir / "deck.json").string() + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("the fastest 5 Pa per step (test 'ramp' leg 0 x1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("test 'ramp' leg 0: the ramp's target reaches end.stress 150000 Pa after 10000 steps"),
            std::string::npos) << r.out;
  EXPECT_NE(r.out.find("test 'consolidate' leg 1: ends in equilibrium after 1000 to 100000 steps"), std::string::npos)
      << r.out;

  r = celldem(run.dir, "plan --json '" + (run.dir / "deck.json").string() + "'");
  ASSERT_EQ(r.code, 0) << r.err;
  const Json plan = Json::parse(r.out);
  for (const Json& t : plan["tests"]) {
    if (t["name"] == "ramp") {
      EXPECT_EQ(t["legs"][0]["axes"]["x1"]["stress_ramp"]["rate"].get<double>(), kRampRate);
      EXPECT_EQ(t["legs"][0]["ramp_target_steps"].get<std::int64_t>(),
                std::llround((1.5e5 - 1e5) / (kRampRate * kTimeStep)));
      EXPECT_FALSE(t.contains("equilibrium"));
    }
    if (t["name"] == "consolidate") {
      EXPECT_EQ(t["equilibrium"]["min_steps"].get<std::int64_t>(), 1000);
      EXPECT_EQ(t["legs"][1]["equilibrium_max_steps"].get<std::int64_t>(), 100000);
    }
    if (t["name"] == "bp") {
      EXPECT_FALSE(t["legs"][0].contains("ramp_target_steps"));
    }
  }
}

// The adaptive rule (run/adaptive_rate.hpp adapted_rate_factor) on its own: raised by a quarter while both indicators
// sit under half their targets, held between, lowered by 1/u (at most halved) above, kept in its bounds and
// under the inertial-number ceiling; an indicator that is not a number (no contacts) lowers it.
TEST(AdaptiveRate, RuleRaisesHoldsLowersAndClamps) {
  AdaptiveRate rule;
  rule.min_factor = 0.25, rule.max_factor = 8.0, rule.unbalanced_force_ratio = 0.01, rule.kinetic_to_elastic = 1e-3;
  rule.inertial_number = 1e-3;
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 2.0, {.unbalanced_force = 0.004, .kinetic_to_elastic = 1e-4, .inertial_at_deck_rate = 0.0}), 2.5);       // u = 0.4: calm
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 2.0, {.unbalanced_force = 0.007, .kinetic_to_elastic = 1e-4, .inertial_at_deck_rate = 0.0}), 2.0);       // u = 0.7: held
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 2.0, {.unbalanced_force = 0.004, .kinetic_to_elastic = 8e-4, .inertial_at_deck_rate = 0.0}), 2.0);       // the energy's u = 0.8
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 2.0, {.unbalanced_force = 0.0125, .kinetic_to_elastic = 1e-4, .inertial_at_deck_rate = 0.0}), 1.6);      // u = 1.25: x 1/1.25
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 2.0, {.unbalanced_force = 0.05, .kinetic_to_elastic = 1e-4, .inertial_at_deck_rate = 0.0}), 1.0);        // u = 5: at most halved
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 2.0, {.unbalanced_force = NAN, .kinetic_to_elastic = 1e-4, .inertial_at_deck_rate = 0.0}), 1.0);         // no measure: halved
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 7.5, {.unbalanced_force = 0.001, .kinetic_to_elastic = 1e-5, .inertial_at_deck_rate = 0.0}), 8.0);       // max_factor
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 0.3, {.unbalanced_force = 0.05, .kinetic_to_elastic = 1e-4, .inertial_at_deck_rate = 0.0}), 0.25);       // min_factor
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 4.0, {.unbalanced_force = 0.001, .kinetic_to_elastic = 1e-5, .inertial_at_deck_rate = 4e-4}), 2.5);      // the ceiling 1e-3 / 4e-4
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 4.0, {.unbalanced_force = 0.001, .kinetic_to_elastic = 1e-5, .inertial_at_deck_rate = 1e-2}), 0.25);     // a ceiling below min_factor
  // The controls' indicator: held while the servo's error is past half its share, lowered beyond it; the servo's
  // ceiling (a fixed cap) bounds the factor.
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 2.0, {.unbalanced_force = 0.004, .kinetic_to_elastic = 1e-4, .control_over_tolerance = 0.7}), 2.0);
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 2.0, {.unbalanced_force = 0.004, .kinetic_to_elastic = 1e-4, .control_over_tolerance = 1.6}), 1.25);
  EXPECT_DOUBLE_EQ(adapted_rate_factor(rule, 4.0, {.unbalanced_force = 0.001, .kinetic_to_elastic = 1e-5, .servo_ceiling = 3.0}), 3.0);
}

// An adaptive leg on a real packing, with force and energy targets it always meets (calm): the factor stays 1
// over the settle window (0.2 % of driving strain), then rises by a quarter per check towards max_factor as far
// as the stress controls keep up; each row's strain increments are its factor times the deck's, the last step is
// cut to land on the end strain. The stress controls hold at every rate.
TEST(AdaptiveRate, CalmLegSpeedsUpToItsMaxAndLandsOnItsEndStrain) {
  const ProgramRun& run = program_run();
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "adaptive_fast" / "series.csv");
  ASSERT_GT(rows.size(), 10u);
  // The rule: 2000 steps at factor 1, then x 1.25 every 100 steps towards 4 while the packing and the servo keep
  // up (run/adaptive_rate.hpp: the controls' average error under a quarter of its tolerance), the last step cut.
  // Fewer steps than the deck's rate takes (8000), and never more than 4x.
  EXPECT_LT(rows.back().step, 8000.0 * 0.75);
  EXPECT_NEAR(rows.back().e1, 0.008, 1e-12);
  int at_max = 0;
  for (std::size_t k = 1; k < rows.size(); ++k) {
    const SeriesRow& r = rows[k];
    if (r.step <= 2000) {
      EXPECT_EQ(r.rate_factor, 1.0) << r.step;
    }
    EXPECT_NEAR(r.strain_rate, r.rate_factor * 1.0, 1e-9) << r.step;  // 1e-6 per step at dt 1e-6: 1 /s
    if (k + 1 < rows.size()) {  // each row's 100 steps ran at its factor (the last row's include the cut step)
      EXPECT_NEAR(r.e1 - rows[k - 1].e1, r.rate_factor * 1e-6 * (r.step - rows[k - 1].step), 1e-12) << r.step;
    }
    EXPECT_LE(r.rate_factor, 4.0) << r.step;
    at_max += r.rate_factor >= 1.25 * 1.25;
    if (r.e1 > 0.003) {  // past the first changes of rate: the servo holds its axes at every rate
      EXPECT_NEAR(r.s22, 1e5, 1000.0) << r.step;
      EXPECT_NEAR(r.s33, 1e5, 1000.0) << r.step;
    }
  }
  EXPECT_GT(at_max, 5);  // sped up for a good part of the leg
  const Json& test = run.summary["tests"]["adaptive_fast"];
  // (At factor 4, 4e-6 per step on 300 spheres, I = 2.4e-3, single steps pass 0.5 %: the control does not fail.)
  EXPECT_TRUE(test["controlled"].get<bool>()) << test["control_failures"].dump();
  EXPECT_LT(test["servo_max_error"].get<double>(), 0.01);
}

// Targets it never meets: after the settle window the factor falls to min_factor and stays there; 2000 steps at
// 1e-6, then 2000e-6 of strain at 0.5e-6 per step.
TEST(AdaptiveRate, UnmetTargetsSlowTheLegToItsMin) {
  const ProgramRun& run = program_run();
  const std::vector<SeriesRow> rows = read_series(run.dir / "run" / "adaptive_slow" / "series.csv");
  EXPECT_EQ(rows.back().step, 6000.0);
  EXPECT_NEAR(rows.back().e1, 0.004, 1e-12);
  for (const SeriesRow& r : rows)
    if (r.step > 2000) {
      EXPECT_EQ(r.rate_factor, 0.5) << r.step;
    }
}

// The inertial-number ceiling binds: after the settle window the rate sits at the ceiling, though the targets would
// let it climb to max_factor. The ceiling judges the cell's actual inertial number (its velocity gradient, the
// servo-held axes included), which moves between checks as the servo follows each change of the factor: each
// row's (its own step and mean stress) within 6 % above the ceiling, their mean within 3 % of it.
TEST(AdaptiveRate, InertialNumberCeilingBinds) {
  const ProgramRun& run = program_run();
  double highest = 0.0, sum = 0.0;
  int rows = 0;
  for (const SeriesRow& r : read_series(run.dir / "run" / "adaptive_ceiling" / "series.csv")) {
    if (r.step <= 3000) continue;  // the settle window and the climb
    EXPECT_LT(r.inertial_number, 1.2e-3 * 1.06) << r.step;
    EXPECT_LT(r.imposed_inertial_number, r.inertial_number) << r.step;  // the servo's axes move too
    highest = std::max(highest, r.inertial_number);
    sum += r.inertial_number, ++rows;
    EXPECT_LT(r.rate_factor, 100.0) << r.step;
  }
  EXPECT_GT(highest, 1.2e-3 * 0.97);
  ASSERT_GT(rows, 10);
  EXPECT_NEAR(sum / rows, 1.2e-3, 0.03 * 1.2e-3);
}

}  // namespace
}  // namespace celldem
