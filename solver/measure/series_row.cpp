#include "measure/series_row.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "cell/control.hpp"
#include "contact/contact_forces.hpp"
#include "measure/micro.hpp"

namespace celldem {

const std::vector<std::string>& series_columns() {
  static const std::vector<std::string> columns = {
      "step", "time", "e1", "e2", "e3", "ev", "s11", "s22", "s33", "s12", "s13", "s23", "p", "q", "ratio13",
      "b", "sin_phi", "DI", "void_ratio", "Z", "Zm", "sliding_fraction", "n_contacts", "n_strong", "H11",
      "H22", "H33", "H12", "H13", "H23", "Hs11", "Hs22", "Hs33", "Hw11", "Hw22", "Hw33", "H11_H33",
      "Hs11_Hs33", "Hw11_Hw33", "kinetic_energy", "unbalanced_force"};
  return columns;
}

double DilatancyWindow::add(double e1, double ev) {
  points_.emplace_back(e1, ev);
  // |.|: e1 may also decrease (extension along x1).
  while (!points_.empty() && std::abs(e1 - points_.front().first) > width_) points_.pop_front();
  const double span = std::abs(points_.back().first - points_.front().first);
  if (points_.size() < 2 || span < 0.5 * width_) return std::numeric_limits<double>::quiet_NaN();
  double mx = 0, my = 0;
  for (const auto& [x, y] : points_) mx += x, my += y;
  mx /= points_.size();
  my /= points_.size();
  double sxy = 0, sxx = 0;
  for (const auto& [x, y] : points_) sxy += (x - mx) * (y - my), sxx += (x - mx) * (x - mx);
  return -sxy / sxx;
}

namespace {
// The value as the series file prints it. The DI window is fed these, so a run resumed from the file
// (which refills the window from the printed rows) computes exactly the same DI.
double as_printed(double x) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", x);
  return std::strtod(buf, nullptr);
}
}  // namespace

std::vector<double> measure_series_row(const Model& model, const State& state, DilatancyWindow& di) {
  const Vec3 e = axis_strains(state);
  const double ev = 1.0 - state.cell.volume() / state.control.reference_volume;
  const Mat3 s = contact_stress(state);
  const StressInvariants inv = stress_invariants(s);
  const Coordination z = coordination(state);
  const Fabric f = contact_fabric(model, state);
  auto ratio = [](double a, double b) { return b != 0.0 ? a / b : std::numeric_limits<double>::quiet_NaN(); };
  return {static_cast<double>(state.control.stage_step),
          static_cast<double>(state.control.stage_step) * model.dt,
          e[0], e[1], e[2], ev,
          s(0, 0), s(1, 1), s(2, 2), s(0, 1), s(0, 2), s(1, 2),
          inv.p, inv.q, ratio(s(0, 0), s(2, 2)), b_value(s(0, 0), s(1, 1), s(2, 2)), inv.sin_phi,
          di.add(as_printed(e[0]), as_printed(ev)),
          void_ratio(model, state), z.z, z.z_mechanical, sliding_fraction(state),
          static_cast<double>(f.contacts), static_cast<double>(f.strong_contacts),
          f.all(0, 0), f.all(1, 1), f.all(2, 2), f.all(0, 1), f.all(0, 2), f.all(1, 2),
          f.strong(0, 0), f.strong(1, 1), f.strong(2, 2), f.weak(0, 0), f.weak(1, 1), f.weak(2, 2),
          ratio(f.all(0, 0), f.all(2, 2)), ratio(f.strong(0, 0), f.strong(2, 2)), ratio(f.weak(0, 0), f.weak(2, 2)),
          kinetic_energy(model, state), unbalanced_force_ratio(model, state)};
}

std::string series_header() {
  std::string line;
  for (const auto& c : series_columns()) line += (line.empty() ? "" : ",") + c;
  return line + "\n";
}

std::string format_series_row(const std::vector<double>& values) {
  std::string line;
  char buf[40];
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (std::isnan(values[k])) std::snprintf(buf, sizeof buf, "%s", "nan");
    else if (k == 0 || k == 22 || k == 23) std::snprintf(buf, sizeof buf, "%.0f", values[k]);  // counts
    else std::snprintf(buf, sizeof buf, "%.10g", values[k]);
    if (k) line += ',';
    line += buf;
  }
  return line + "\n";
}

}  // namespace celldem
