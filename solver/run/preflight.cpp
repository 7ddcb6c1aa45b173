#include "run/preflight.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "core/plan.hpp"
#include "io/files.hpp"
#include "io/lammps_data.hpp"
#include "io/state_file.hpp"
#include "measure/micro.hpp"
#include "neighbor/neighbor_list.hpp"
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

// An imported packing whose spheres overlap deeply starts with forces far above its stress's: the run then
// fails as if the time step were too large. Say so before: overlaps beyond this fraction of the smaller
// radius are reported (a packing at its stress overlaps by about 1e-3 of a radius), coincident centres refused.
inline constexpr double kDeepOverlap = 0.05;
inline constexpr double kCoincident = 1e-6;  // centre distance / (r_i + r_j)

void check_overlaps(const Deck& deck, State state, const std::vector<std::int64_t>& atom_ids, const std::string& path,
                    std::vector<std::string>& warnings) {
  const auto name = [&](Index i) {
    return atom_ids.empty() ? "particle " + std::to_string(i) : "atom " + std::to_string(atom_ids[i]);
  };
  state.pairs.skin = skin_length(deck);
  rebuild_pairs(make_model(deck, state.particles.radius), state);
  const Overlaps o = overlaps(state, kDeepOverlap);
  if (o.closest < kCoincident)
    throw DeckError("initial_state: " + name(o.closest_i) + " and " + name(o.closest_j) + " of " + path +
                    " lie at the same place (centre distance " + fmt(o.closest) + " of the sum of their radii): "
                    "remove one of them");
  if (o.worst > kDeepOverlap)
    warnings.push_back("initial_state: in " + path + " " + std::to_string(o.deep) + " of " + std::to_string(o.count) +
                       " touching pairs overlap by more than " + fmt(kDeepOverlap) + " of the smaller radius, the " +
                       "deepest " + fmt(o.worst) + " (" + name(o.worst_i) + " and " + name(o.worst_j) + "): the " +
                       "first steps push them apart violently and the run may stop with runaway motion that no time step cures: relax the "
                       "packing first (e.g. a LAMMPS run with fix nve/limit)");
}

void check_state(const Deck& deck, const std::string& path, std::vector<std::string>& warnings) {
  std::vector<std::int64_t> atom_ids;
  const State state = load_initial_state(deck, &atom_ids);
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
  check_overlaps(deck, state, atom_ids, path, warnings);
}

// The largest axis-1 strain a test reaches at the ends of its legs; NaN unless every leg drives axis 1 by
// strain and ends on its strain or on a step count (otherwise only running the test tells).
double largest_e1(const Deck& deck, const TestDef& test) {
  double e1 = 0.0, largest = 0.0;
  for (const Leg& leg : test.legs) {
    if (!leg.axes[0].strain_driven()) return std::nan("");
    if (leg.end.kind == LegEndKind::Strain && leg.end.axis == 0) e1 = leg.end.value;
    else if (leg.end.kind == LegEndKind::Steps) e1 += static_cast<double>(leg_steps(leg, deck.time_step)) *
                                                      leg.strain_per_step(0, deck.time_step);
    else return std::nan("");
    largest = std::max(largest, e1);
  }
  return largest;
}

// Snapshots at strains a test never reaches would be dropped silently: say so before the run.
void warn_unreached_snapshots(const Deck& deck, std::vector<std::string>& warnings) {
  for (std::size_t t = 0; t < deck.tests.size(); ++t) {
    const TestDef& test = deck.tests[t];
    const double reached = largest_e1(deck, test);
    if (!std::isfinite(reached)) continue;
    for (std::size_t k = 0; k < test.snapshots.e1.size(); ++k)
      if (test.snapshots.e1[k] > reached)
        warnings.push_back("tests[" + std::to_string(t) + "].snapshots.e1: " + fmt(test.snapshots.e1[k]) +
                           " lies beyond the largest e1 test '" + test.name + "' reaches (" + fmt(reached) +
                           "): no snapshot will be written there");
  }
}

}  // namespace

State load_initial_state(const Deck& deck, std::vector<std::int64_t>* atom_ids) {
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
  if (atom_ids) *atom_ids = data.ids;
  return data.state;
}

std::string initial_state_path(const Deck& deck) {
  return (std::filesystem::path(deck.source).parent_path() / deck.initial_state.value()).string();
}

std::vector<std::string> preflight(const Deck& deck) {
  if (deck.prepare) check_prepared_cell(deck);
  if (deck.initial_state) {
    const std::string path = initial_state_path(deck);
    if (!std::filesystem::exists(path)) throw DeckError("initial_state: no such file " + path);
  }
  std::vector<std::string> warnings = deck_warnings(deck);
  if (deck.initial_state) check_state(deck, initial_state_path(deck), warnings);
  warn_unreached_snapshots(deck, warnings);
  return warnings;
}

}  // namespace celldem
