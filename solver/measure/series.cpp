#include "measure/series.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cell/control.hpp"
#include "measure/energy.hpp"
#include "measure/micro.hpp"
#include "measure/quasi_static.hpp"

namespace celldem {
namespace {

using R = SeriesRow;
constexpr ColumnFormat kCount = ColumnFormat::Count;
constexpr ColumnFormat kReal = ColumnFormat::Real;

// clang-format off
const std::array kColumns = std::to_array<SeriesColumn>({
    {"step", &R::step, kCount, "-", "steps since the stage started", false},
    {"time", &R::time, kReal, "s", "time since the stage started", false},
    {"e1", &R::e1, kReal, "-", "engineering strain of axis 1, 1 - h11/h11(start), compression +", false},
    {"e2", &R::e2, kReal, "-", "engineering strain of axis 2", false},
    {"e3", &R::e3, kReal, "-", "engineering strain of axis 3", false},
    {"ev", &R::ev, kReal, "-", "volumetric strain 1 - V/V(start), compression +", false},
    {"s11", &R::s11, kReal, "Pa", "contact stress (1/V) sum f (x) l, compression +", true},
    {"s22", &R::s22, kReal, "Pa", "contact stress, axis 2", true},
    {"s33", &R::s33, kReal, "Pa", "contact stress, axis 3", true},
    {"s12", &R::s12, kReal, "Pa", "contact shear stress (symmetric part)", false},
    {"s13", &R::s13, kReal, "Pa", "contact shear stress", false},
    {"s23", &R::s23, kReal, "Pa", "contact shear stress", false},
    {"p", &R::p, kReal, "Pa", "mean stress trace/3", false},
    {"q", &R::q, kReal, "Pa", "deviator stress sqrt(3/2 s':s')", false},
    {"ratio13", &R::ratio13, kReal, "-", "s11/s33 (axis stresses)", false},
    {"b", &R::b, kReal, "-", "(s22 - s33)/(s11 - s33) (axis stresses); nan while s11 - s33 < 1 % of p (noise)",
     false},
    {"sin_phi", &R::sin_phi, kReal, "-", "(s1 - s3)/(s1 + s3) of the principal stresses", false},
    {"DI", &R::DI, kReal, "-",
     "dilatancy index -d(ev)/d(e1), least squares over a centred window of 0.25 % in e1 (written when the stage ends)",
     false},
    {"void_ratio", &R::void_ratio, kReal, "-", "V/V(solid) - 1", false},
    {"Z", &R::Z, kReal, "-", "coordination number 2 contacts / particles", false},
    {"Zm", &R::Zm, kReal, "-", "mechanical coordination number, rattlers (< 2 contacts: the frictional rule) removed",
     true},
    {"sliding_fraction", &R::sliding_fraction, kReal, "-", "contacts at the Coulomb limit / contacts", false},
    {"n_contacts", &R::n_contacts, kCount, "-", "contacts", false},
    {"n_strong", &R::n_strong, kCount, "-", "contacts with normal force above the mean", false},
    {"H11", &R::H11, kReal, "-", "fabric tensor (1/Nc) sum n (x) n, all contacts", false},
    {"H22", &R::H22, kReal, "-", "fabric tensor, all contacts", false},
    {"H33", &R::H33, kReal, "-", "fabric tensor, all contacts", false},
    {"H12", &R::H12, kReal, "-", "fabric tensor, all contacts", false},
    {"H13", &R::H13, kReal, "-", "fabric tensor, all contacts", false},
    {"H23", &R::H23, kReal, "-", "fabric tensor, all contacts", false},
    {"Hs11", &R::Hs11, kReal, "-", "fabric tensor of the strong contacts", false},
    {"Hs22", &R::Hs22, kReal, "-", "fabric tensor of the strong contacts", false},
    {"Hs33", &R::Hs33, kReal, "-", "fabric tensor of the strong contacts", false},
    {"Hw11", &R::Hw11, kReal, "-", "fabric tensor of the weak contacts (normal force <= mean)", false},
    {"Hw22", &R::Hw22, kReal, "-", "fabric tensor of the weak contacts", false},
    {"Hw33", &R::Hw33, kReal, "-", "fabric tensor of the weak contacts", false},
    {"H11_H33", &R::H11_H33, kReal, "-", "H11/H33", false},
    {"Hs11_Hs33", &R::Hs11_Hs33, kReal, "-", "Hs11/Hs33", false},
    {"Hw11_Hw33", &R::Hw11_Hw33, kReal, "-", "Hw11/Hw33", false},
    {"kinetic_energy", &R::kinetic_energy, kReal, "J", "fluctuating translation and rotation", false},
    {"unbalanced_force", &R::unbalanced_force, kReal, "-",
     "mean |net contact force| over particles / mean contact normal force", false},
    {"leg", &R::leg, kCount, "-", "leg of the load program (0-based)", false},
    {"sigma1", &R::sigma1, kReal, "Pa", "major principal stress of the contact stress tensor", false},
    {"sigma2", &R::sigma2, kReal, "Pa", "intermediate principal stress", false},
    {"sigma3", &R::sigma3, kReal, "Pa", "minor principal stress", false},
    {"b_principal", &R::b_principal, kReal, "-",
     "(sigma2 - sigma3)/(sigma1 - sigma3) (the paper's b); nan while sigma1 - sigma3 < 1 % of p", false},
    {"ratio_principal", &R::ratio_principal, kReal, "-", "sigma1/sigma3", false},
    {"lode_angle", &R::lode_angle, kReal, "deg",
     "atan((2 sigma2 - sigma1 - sigma3)/(sqrt(3) (sigma1 - sigma3))): -30 compression (b = 0), +30 extension", false},
    {"Zm_frictionless", &R::Zm_frictionless, kReal, "-",
     "mechanical coordination number with the frictionless rule: rattlers have < 4 contacts (d + 1)", false},
    {"g12", &R::g12, kReal, "-",
     "engineering shear strain -(h12 - h12(start))/h22(start): the tilt xy over axis 2's length, sign as s12", false},
    {"g13", &R::g13, kReal, "-", "engineering shear strain -(h13 - h13(start))/h33(start)", false},
    {"g23", &R::g23, kReal, "-", "engineering shear strain -(h23 - h23(start))/h33(start)", false},
    {"rate_factor", &R::rate_factor, kReal, "-",
     "the loading rate over the deck's in the steps up to the row: an adaptive leg's factor (tests[].adaptive_rate), "
     "else 1", false},
    {"strain_rate", &R::strain_rate, kReal, "1/s",
     "the fastest strain-driven axis's strain rate in the steps up to the row (0 before the first step)", false},
    {"inertial_number", &R::inertial_number, kReal, "-",
     "gamma_dot d_mean sqrt(rho / p) of the cell's actual deformation in the row's step: gamma_dot = sqrt(2 D':D'), "
     "D the symmetric part of the cell's velocity gradient, all six components, servo-held axes included "
     "(docs/physics.md), d_mean the particles' mean diameter (quasi-static below about 1e-3; 0 at step 0)", false},
    {"kinetic_to_elastic", &R::kinetic_to_elastic, kReal, "-",
     "kinetic_energy over the elastic energy stored in the contact springs (nan without contacts)", false},
    {"imposed_inertial_number", &R::imposed_inertial_number, kReal, "-",
     "rate d_mean sqrt(rho / p) of the imposed rates alone: rate the deviatoric scale sqrt(3/2 e':e') of the driven "
     "components, servo-held ones counted 0 (strain_rate for an axial test; the planned figure of the adaptive "
     "rate's ceiling and the time-to-answer rules)", false},
    {"energy_boundary_work", &R::energy_boundary_work, kReal, "J",
     "work of the cell on the contacts since the stage started, sum of -dt L : V sigma over the steps (trapezoid of "
     "the stress at each step's ends; nan unless the deck sets energy_budget, as every energy_ column)", false},
    {"energy_normal", &R::energy_normal, kReal, "J", "energy stored in the normal springs", false},
    {"energy_tangential", &R::energy_tangential, kReal, "J", "energy stored in the tangential springs", false},
    {"energy_rotational_springs", &R::energy_rotational_springs, kReal, "J",
     "energy stored in the rolling and twisting springs", false},
    {"energy_kinetic_translation", &R::energy_kinetic_translation, kReal, "J",
     "the leapfrog's kinetic energy of the fluctuating translation, 1/2 m v(t - dt/2).v(t + dt/2)", false},
    {"energy_kinetic_rotation", &R::energy_kinetic_rotation, kReal, "J",
     "the leapfrog's kinetic energy of rotation, 1/2 I w(t - dt/2).w(t + dt/2)", false},
    {"energy_friction", &R::energy_friction, kReal, "J",
     "dissipated at the Coulomb caps since the stage started (capped force times slip)", false},
    {"energy_rotational_friction", &R::energy_rotational_friction, kReal, "J",
     "dissipated at the rolling and twisting caps since the stage started", false},
    {"energy_body_damping", &R::energy_body_damping, kReal, "J",
     "dissipated by the body damping (translation and rotation) since the stage started", false},
    {"energy_contact_damping", &R::energy_contact_damping, kReal, "J",
     "dissipated by the rolling dashpot since the stage started", false},
    {"energy_closure", &R::energy_closure, kReal, "J",
     "closure error: boundary work - (change of stored + kinetic energy since the stage started) - dissipated",
     false},
    {"energy_closure_relative", &R::energy_closure_relative, kReal, "-",
     "energy_closure / energy_boundary_work (nan while the boundary work is 0)", false},
});
// clang-format on

// The value as the series file prints it.
void print_value(char* buf, std::size_t size, double x, ColumnFormat format) {
  if (std::isnan(x)) std::snprintf(buf, size, "%s", "nan");
  else if (format == ColumnFormat::Count) std::snprintf(buf, size, "%.0f", x);
  else std::snprintf(buf, size, "%.10g", x);
}

double printed(double x, ColumnFormat format) {
  char buf[40];
  print_value(buf, sizeof buf, x, format);
  return std::strtod(buf, nullptr);
}

// The energy budget's columns: NaN unless the model keeps the budget (its walk of the pairs costs a row as
// much again).
void set_energy_columns(const Model& model, const State& state, SeriesRow& r) {
  if (!model.energy_budget) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    for (double R::*f : {&R::energy_boundary_work, &R::energy_normal, &R::energy_tangential,
                         &R::energy_rotational_springs, &R::energy_kinetic_translation, &R::energy_kinetic_rotation,
                         &R::energy_friction, &R::energy_rotational_friction, &R::energy_body_damping,
                         &R::energy_contact_damping, &R::energy_closure, &R::energy_closure_relative})
      r.*f = nan;
    return;
  }
  const EnergyBudget b = energy_budget(model, state);
  r.energy_boundary_work = b.totals.boundary_work;
  r.energy_normal = b.partition.normal, r.energy_tangential = b.partition.tangential;
  r.energy_rotational_springs = b.partition.rotational_springs;
  r.energy_kinetic_translation = b.partition.kinetic_translation;
  r.energy_kinetic_rotation = b.partition.kinetic_rotation;
  r.energy_friction = b.totals.friction, r.energy_rotational_friction = b.totals.rotational_friction;
  r.energy_body_damping = b.totals.damping_translation + b.totals.damping_rotation;
  r.energy_contact_damping = b.totals.contact_damping;
  r.energy_closure = b.closure, r.energy_closure_relative = b.closure_relative;
}

}  // namespace

std::span<const SeriesColumn> series_columns() { return kColumns; }

const SeriesColumn* find_series_column(std::string_view name) {
  for (const SeriesColumn& c : kColumns)
    if (c.name == name) return &c;
  return nullptr;
}

void fill_dilatancy(std::vector<SeriesRow>& rows, double width) {
  const std::size_t n = rows.size();
  // Rows that are half a window away count, whatever the rounding of their strains (symmetric windows).
  const double half = 0.5 * width * (1.0 + 1e-9);
  for (std::size_t k = 0; k < n; ++k) {
    const double centre = rows[k].e1;
    std::size_t lo = k, hi = k;
    while (lo > 0 && std::abs(rows[lo - 1].e1 - centre) <= half) --lo;
    while (hi + 1 < n && std::abs(rows[hi + 1].e1 - centre) <= half) ++hi;
    double e_min = centre, e_max = centre, mx = 0.0, my = 0.0;
    for (std::size_t j = lo; j <= hi; ++j) {
      e_min = std::min(e_min, rows[j].e1), e_max = std::max(e_max, rows[j].e1);
      mx += rows[j].e1, my += rows[j].ev;
    }
    const double count = static_cast<double>(hi - lo + 1);
    mx /= count, my /= count;
    double sxy = 0.0, sxx = 0.0;
    for (std::size_t j = lo; j <= hi; ++j)
      sxy += (rows[j].e1 - mx) * (rows[j].ev - my), sxx += (rows[j].e1 - mx) * (rows[j].e1 - mx);
    const bool enough = hi > lo && e_max - e_min >= 0.5 * width * (1.0 - 1e-9);
    rows[k].DI = enough ? -sxy / sxx : std::numeric_limits<double>::quiet_NaN();
  }
}

SeriesRow measure_series_row(const Model& model, const State& state) {
  return series_row(model, state, measure_contacts(model, state));
}

SeriesRow series_row(const Model& model, const State& state, const ContactMeasures& m) {
  const Vec3 e = axis_strains(state);
  const Mat3& s = m.stress;
  const StressInvariants inv = stress_invariants(s);
  const Coordination& z = m.coordination;
  const Fabric& f = m.fabric;
  auto ratio = [](double a, double b) { return b != 0.0 ? a / b : std::numeric_limits<double>::quiet_NaN(); };
  SeriesRow r;
  r.step = static_cast<double>(state.control.stage_steps);
  r.time = static_cast<double>(state.control.stage_steps) * model.dt;
  r.e1 = e[0], r.e2 = e[1], r.e3 = e[2];
  r.ev = 1.0 - state.cell.volume() / state.control.reference_volume;
  r.s11 = s(0, 0), r.s22 = s(1, 1), r.s33 = s(2, 2), r.s12 = s(0, 1), r.s13 = s(0, 2), r.s23 = s(1, 2);
  // b is a ratio of differences: while the deviator is at the level of the noise it means nothing.
  const double noise = kBNoise * std::abs(inv.p);
  auto b_above_noise = [&](double s1, double s2, double s3) {
    return std::abs(s1 - s3) >= noise ? b_value(s1, s2, s3) : std::numeric_limits<double>::quiet_NaN();
  };
  r.p = inv.p, r.q = inv.q, r.ratio13 = ratio(s(0, 0), s(2, 2)), r.b = b_above_noise(s(0, 0), s(1, 1), s(2, 2));
  r.sin_phi = inv.sin_phi;
  r.DI = std::numeric_limits<double>::quiet_NaN();  // filled when the stage ends (fill_dilatancy)
  r.void_ratio = void_ratio(model, state);
  r.Z = z.z, r.Zm = z.z_mechanical, r.sliding_fraction = m.sliding_fraction;
  r.n_contacts = static_cast<double>(f.contacts), r.n_strong = static_cast<double>(f.strong_contacts);
  r.H11 = f.all(0, 0), r.H22 = f.all(1, 1), r.H33 = f.all(2, 2);
  r.H12 = f.all(0, 1), r.H13 = f.all(0, 2), r.H23 = f.all(1, 2);
  r.Hs11 = f.strong(0, 0), r.Hs22 = f.strong(1, 1), r.Hs33 = f.strong(2, 2);
  r.Hw11 = f.weak(0, 0), r.Hw22 = f.weak(1, 1), r.Hw33 = f.weak(2, 2);
  r.H11_H33 = ratio(f.all(0, 0), f.all(2, 2));
  r.Hs11_Hs33 = ratio(f.strong(0, 0), f.strong(2, 2));
  r.Hw11_Hw33 = ratio(f.weak(0, 0), f.weak(2, 2));
  r.kinetic_energy = m.kinetic_energy;
  r.unbalanced_force = m.unbalanced_force;
  r.leg = static_cast<double>(state.control.leg);
  const Vec3 principal = principal_stresses(s);
  r.sigma1 = principal[0], r.sigma2 = principal[1], r.sigma3 = principal[2];
  r.b_principal = b_above_noise(r.sigma1, r.sigma2, r.sigma3);
  r.Zm_frictionless = m.coordination_frictionless.z_mechanical;
  const Vec3 g = shear_strains(state);
  r.g12 = g[0], r.g13 = g[1], r.g23 = g[2];
  r.ratio_principal = ratio(r.sigma1, r.sigma3);
  r.rate_factor = state.driving_factor;
  r.strain_rate = state.driving_rate;
  r.inertial_number = cell_inertial_number(state, model.density, inv.p);
  r.imposed_inertial_number = state.inertial_rate == 0.0 ? 0.0
                              : inv.p > 0.0 ? inertial_number(state.inertial_rate, mean_particle_diameter(state.particles),
                                                              model.density, inv.p)
                                            : std::numeric_limits<double>::quiet_NaN();
  r.kinetic_to_elastic = ratio(m.kinetic_energy, m.elastic_energy);
  set_energy_columns(model, state, r);
  r.lode_angle = r.sigma1 != r.sigma3 ? std::atan((2.0 * r.sigma2 - r.sigma1 - r.sigma3) /
                                                  (std::sqrt(3.0) * (r.sigma1 - r.sigma3))) * 180.0 / M_PI
                                      : std::numeric_limits<double>::quiet_NaN();
  return r;
}

SeriesRow as_printed(const SeriesRow& row) {
  SeriesRow out;
  for (const SeriesColumn& c : kColumns) out.*c.field = printed(row.*c.field, c.format);
  return out;
}

std::string series_header() {
  std::string line;
  for (const SeriesColumn& c : kColumns) {
    if (!line.empty()) line += ',';
    line += c.name;
  }
  return line + "\n";
}

std::string format_series_row(const SeriesRow& row) {
  std::string line;
  char buf[40];
  for (const SeriesColumn& c : kColumns) {
    print_value(buf, sizeof buf, row.*c.field, c.format);
    if (!line.empty()) line += ',';
    line += buf;
  }
  return line + "\n";
}

std::optional<SeriesRow> parse_series_row(const std::vector<std::string>& header, const std::string& line) {
  SeriesRow row;
  std::stringstream ss(line);
  std::size_t k = 0;
  for (std::string field; std::getline(ss, field, ','); ++k) {
    if (k >= header.size()) return std::nullopt;
    if (const SeriesColumn* c = find_series_column(header[k])) row.*c->field = std::strtod(field.c_str(), nullptr);
  }
  if (k != header.size()) return std::nullopt;
  return row;
}

std::string series_columns_markdown() {
  std::string out = "| column | unit | meaning |\n|---|---|---|\n";
  for (const SeriesColumn& c : kColumns)
    out += "| `" + std::string(c.name) + "` | " + std::string(c.unit) + " | " + std::string(c.meaning) + " |\n";
  return out;
}

std::string series_columns_json() {
  nlohmann::json columns = nlohmann::json::array();
  for (const SeriesColumn& c : kColumns)
    columns.push_back({{"name", c.name}, {"unit", c.unit}, {"meaning", c.meaning}});
  return nlohmann::json{{"columns", columns}}.dump(1) + "\n";
}

}  // namespace celldem
