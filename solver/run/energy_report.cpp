#include "run/energy_report.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

namespace celldem {
namespace {

// One span of rows' budget: the changes and totals between two rows.
nlohmann::json span_json(const SeriesRow& a, const SeriesRow& b) {
  const auto stored = [](const SeriesRow& r) {
    return r.energy_normal + r.energy_tangential + r.energy_rotational_springs;
  };
  const auto kinetic = [](const SeriesRow& r) { return r.energy_kinetic_translation + r.energy_kinetic_rotation; };
  const double work = b.energy_boundary_work - a.energy_boundary_work;
  const double friction = b.energy_friction - a.energy_friction;
  const double rotational = b.energy_rotational_friction - a.energy_rotational_friction;
  const double body = b.energy_body_damping - a.energy_body_damping;
  const double dashpot = b.energy_contact_damping - a.energy_contact_damping;
  const double closure = b.energy_closure - a.energy_closure;
  const double dissipated = friction + rotational + body + dashpot;
  const auto ratio = [](double x, double y) -> nlohmann::json { return y != 0.0 ? nlohmann::json(x / y) : nullptr; };
  return {{"boundary_work", work},
          {"stored_change", stored(b) - stored(a)},
          {"kinetic_change", kinetic(b) - kinetic(a)},
          {"friction", friction},
          {"rotational_friction", rotational},
          {"body_damping", body},
          {"contact_damping", dashpot},
          {"dissipated", dissipated},
          {"damping_share", ratio(body + dashpot, dissipated)},
          {"closure", closure},
          {"closure_relative", ratio(closure, work)}};
}

std::string percent(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g %%", 100.0 * x);
  return buf;
}

}  // namespace

EnergyReport energy_report(const std::string& test, const std::vector<SeriesRow>& rows, double dt) {
  EnergyReport out;
  if (rows.empty() || std::isnan(rows.back().energy_boundary_work)) return out;
  const SeriesRow& first = rows.front();
  const SeriesRow& last = rows.back();
  out.json = span_json(first, last);
  // Per leg: from the last row of the leg before (or the first row) to the leg's last row.
  nlohmann::json legs = nlohmann::json::array();
  std::size_t start = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (k + 1 < rows.size() && rows[k + 1].leg == rows[k].leg) continue;
    nlohmann::json leg = span_json(rows[start], rows[k]);
    leg["leg"] = static_cast<int>(rows[k].leg);
    legs.push_back(leg);
    start = k;
  }
  out.json["legs"] = legs;
  // The worst closure relative to the boundary work so far, over the rows where that work means something.
  const double total_work = std::abs(last.energy_boundary_work);
  double worst = 0.0;
  const SeriesRow* at = nullptr;
  for (const SeriesRow& r : rows)
    if (std::abs(r.energy_boundary_work) >= kClosureFloor * total_work && total_work > 0.0 &&
        std::abs(r.energy_closure_relative) >= worst)
      worst = std::abs(r.energy_closure_relative), at = &r;
  out.json["worst_closure_relative"] = at ? nlohmann::json(worst) : nlohmann::json(nullptr);
  out.json["worst_closure_step"] = at ? nlohmann::json(at->step) : nlohmann::json(nullptr);
  out.json["worst_closure_leg"] = at ? nlohmann::json(static_cast<int>(at->leg)) : nlohmann::json(nullptr);
  out.json["closure_bound"] = kClosureBound;
  out.json["damping_share_bound"] = kDampingShareBound;
  const bool closure_failed = at && worst > kClosureBound;
  const nlohmann::json& share = out.json["damping_share"];
  const bool damping_dominated = share.is_number() && share.get<double>() > kDampingShareBound;
  out.json["closure_within_bound"] = !closure_failed;
  out.json["damping_dominated"] = damping_dominated;
  char dt_text[32];
  std::snprintf(dt_text, sizeof dt_text, "%.4g s", dt);
  if (closure_failed)
    out.warnings.push_back(test + ": the energy budget does not close: closure error " + percent(worst) +
                           " of the boundary work at step " + std::to_string(static_cast<long long>(at->step)) +
                           " (leg " + std::to_string(static_cast<int>(at->leg)) + "), above the bound " +
                           percent(kClosureBound) + "; the time step " + dt_text +
                           " is likely too large for the contact stiffness (docs/energy.md)");
  if (damping_dominated)
    out.warnings.push_back(test + ": damping-dominated: the damping dissipated " + percent(share.get<double>()) +
                           " of the energy dissipated (bound " + percent(kDampingShareBound) +
                           "): the result depends on the damping, a numerical choice (docs/energy.md)");
  const double dissipated = out.json["dissipated"].get<double>();
  char line[256];
  std::snprintf(
      line, sizeof line,
      "energy: boundary work %.4g J, dissipated %.4g J (damping %s), stored %+.4g J, closure %s of the work "
      "(worst %s at step %.0f)",
      last.energy_boundary_work, dissipated, share.is_number() ? percent(share.get<double>()).c_str() : "-",
      out.json["stored_change"].get<double>(),
      out.json["closure_relative"].is_number() ? percent(out.json["closure_relative"].get<double>()).c_str() : "-",
      at ? percent(worst).c_str() : "-", at ? at->step : 0.0);
  out.console.push_back(line);
  return out;
}

}  // namespace celldem
