#include "run/preflight.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "core/plan.hpp"
#include "io/files.hpp"
#include "io/lammps_data.hpp"
#include "io/state_file.hpp"
#include "run/health.hpp"

namespace celldem {
namespace {

std::string fmt(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

// The neighbour list needs every face width of the cell above 2 (largest diameter + skin).
double smallest_cell_width(const Deck& deck) {
  const double d_max = *std::max_element(deck.sample.diameters.begin(), deck.sample.diameters.end());
  return 2.0 * (d_max + skin_length(deck));
}

void check_prepared_cell(const Deck& deck) {
  const SampleDef& s = deck.sample;
  int side = 1;
  while (static_cast<long long>(side) * side * side < s.count) ++side;
  double solid = 0.0;
  for (double d : s.diameters) solid += M_PI / 6.0 * d * d * d / static_cast<double>(s.diameters.size());
  // A prepared random packing of spheres fills about 64 % of the cell.
  const double prepared = std::cbrt(s.count * solid / 0.64);
  const double needed = smallest_cell_width(deck);
  if (std::min(side * s.grid_spacing, prepared) <= needed)
    throw DeckError("sample.count: " + std::to_string(s.count) + " spheres make a cell about " + fmt(prepared) +
                    " m wide once compressed, too small for the largest diameter and the skin (the cell must "
                    "exceed " + fmt(needed) + " m): use more spheres");
}

void check_state(const Deck& deck, const std::string& path) {
  const State state = load_initial_state(deck);
  const std::size_t n = state.particles.size();
  if (n != static_cast<std::size_t>(deck.sample.count))
    throw DeckError("sample.count: the deck says " + std::to_string(deck.sample.count) + " spheres, initial_state " +
                    path + " holds " + std::to_string(n));
  for (std::size_t i = 0; i < n; ++i) {
    const double d = 2.0 * state.particles.radius[i];
    const bool listed = std::any_of(deck.sample.diameters.begin(), deck.sample.diameters.end(),
                                    [d](double x) { return std::abs(x - d) <= 1e-12 * x; });
    if (!listed)
      throw DeckError("sample.diameters: initial_state " + path + " holds a sphere of diameter " + fmt(d) +
                      " m (particle " + std::to_string(i) + "), which is not one of the deck's diameters");
  }
  const double needed = smallest_cell_width(deck);
  const double width = state.cell.face_widths().minCoeff();
  if (width <= needed)
    throw DeckError("initial_state: the cell of " + path + " is " + fmt(width) + " m wide, too small for its "
                    "largest diameter and the skin (it must exceed " + fmt(needed) + " m)");
}

// A servo axis beside an axis driven at d per step moves about d to 2d per step (its dilation): a cap below
// kMinServoCapRatio x d saturates the servo, and the control fails.
void check_servo_caps(const Deck& deck) {
  const auto check = [&](const std::vector<Leg>& legs, const std::string& stage) {
    for (std::size_t j = 0; j < legs.size(); ++j) {
      const Leg& leg = legs[j];
      const double d = leg_driving_increment(leg, deck.time_step);
      const double cap = servo_cap(deck.servo, leg, deck.time_step);
      if (leg_has_servo(leg) && d > 0.0 && cap < kMinServoCapRatio * d)
        throw DeckError("servo.max_strain_increment: " + fmt(cap) + " is below " + fmt(kMinServoCapRatio) +
                        " x the driving strain per step " + fmt(d) + " of " + stage + " leg " + std::to_string(j) +
                        " (the servo's axes need about 1 to 2 x it): raise it to at least " +
                        fmt(kMinServoCapRatio * d) + ", leave it out (the default follows each leg's rate) or "
                        "lower the strain rate");
    }
  };
  if (deck.prepare) check(deck.prepare->legs, "the preparation");
  for (const TestDef& t : deck.tests) check(t.legs, "test '" + t.name + "'");
}

}  // namespace

State load_initial_state(const Deck& deck) {
  const std::string path = initial_state_path(deck);
  if (read_file(path).rfind("CELLDEMS", 0) == 0) return read_state(path);
  LammpsData data;
  try {
    data = read_lammps_data(path);
  } catch (const LammpsDataError& e) {
    throw DeckError(std::string("initial_state: neither a celldem state file nor a readable LAMMPS data file: ") +
                    e.what());
  }
  if (!data.common_density)
    throw DeckError("initial_state: " + path + " gives its atoms different densities; celldem has one (sample.density)");
  if (std::abs(*data.common_density - deck.sample.density) > 1e-12 * deck.sample.density)
    throw DeckError("sample.density: the deck says " + fmt(deck.sample.density) + " kg/m^3, initial_state " + path +
                    " says " + fmt(*data.common_density));
  return data.state;
}

std::string initial_state_path(const Deck& deck) {
  return (std::filesystem::path(deck.source).parent_path() / deck.initial_state.value()).string();
}

std::vector<std::string> preflight(const Deck& deck) {
  const double dt_fraction = deck.time_step / critical_time_step(deck.sample, deck.contact);
  if (dt_fraction < kMinTimeStepFraction)
    throw DeckError("time_step: " + fmt(deck.time_step) + " s is " + fmt(dt_fraction) + " of sqrt(m_min/kn), below " +
                    fmt(kMinTimeStepFraction) + " of it: the run would take more than a thousand times the steps "
                    "it needs");
  check_servo_caps(deck);
  if (deck.prepare) check_prepared_cell(deck);
  if (deck.initial_state) {
    const std::string path = initial_state_path(deck);
    if (!std::filesystem::exists(path)) throw DeckError("initial_state: no such file " + path);
    check_state(deck, path);
  }
  std::vector<std::string> warnings = deck_warnings(deck);
  if (dt_fraction < kSlowTimeStepFraction)
    warnings.push_back("time_step is only " + fmt(dt_fraction) + " of sqrt(m_min/kn): the run takes " +
                       fmt(kSlowTimeStepFraction / dt_fraction) + " times the steps of a time step at " +
                       fmt(kSlowTimeStepFraction) + " of it");
  return warnings;
}

}  // namespace celldem
