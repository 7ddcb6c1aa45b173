// A stage's series: one row of named measurements per output interval, and the table of columns that
// drives everything about them (CSV header and formats, units and meanings, which values must be finite).
// Code reads a quantity by its field (row.ratio13), never by its position in the file.
#pragma once
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/model.hpp"
#include "core/state.hpp"
#include "measure/micro.hpp"

namespace celldem {

struct SeriesRow {
  double step = 0, time = 0;
  double e1 = 0, e2 = 0, e3 = 0, ev = 0;
  double s11 = 0, s22 = 0, s33 = 0, s12 = 0, s13 = 0, s23 = 0;
  double p = 0, q = 0, ratio13 = 0, b = 0, sin_phi = 0, DI = 0;
  double void_ratio = 0, Z = 0, Zm = 0, sliding_fraction = 0, n_contacts = 0, n_strong = 0;
  double H11 = 0, H22 = 0, H33 = 0, H12 = 0, H13 = 0, H23 = 0;
  double Hs11 = 0, Hs22 = 0, Hs33 = 0, Hw11 = 0, Hw22 = 0, Hw33 = 0;
  double H11_H33 = 0, Hs11_Hs33 = 0, Hw11_Hw33 = 0;
  double kinetic_energy = 0, unbalanced_force = 0;
  double leg = 0;                                   // the leg of the load program (0-based)
  double sigma1 = 0, sigma2 = 0, sigma3 = 0;        // principal stresses, descending
  double b_principal = 0, ratio_principal = 0, lode_angle = 0;
  double Zm_frictionless = 0;                       // Zm with the frictionless rattler rule (< 4 contacts)
  double g12 = 0, g13 = 0, g23 = 0;                 // engineering shear strains (cell/control.hpp's convention)
  double rate_factor = 0, strain_rate = 0;          // the loading rate (an adaptive leg's factor) in the last steps
  double inertial_number = 0, kinetic_to_elastic = 0;  // quasi-static indicators (I of the cell's own rate)
  double imposed_inertial_number = 0;               // I of the imposed (driven) rates alone, as planned
  // The energy budget since the stage started (measure/energy.hpp; NaN unless the deck keeps it).
  double energy_boundary_work = 0, energy_normal = 0, energy_tangential = 0, energy_rotational_springs = 0;
  double energy_kinetic_translation = 0, energy_kinetic_rotation = 0, energy_friction = 0;
  double energy_rotational_friction = 0, energy_body_damping = 0, energy_contact_damping = 0;
  double energy_closure = 0, energy_closure_relative = 0;

  // Strain of component k (0-based, kComponentNames: e1 e2 e3 g12 g13 g23), compression positive.
  double strain(int k) const {
    const double e[6] = {e1, e2, e3, g12, g13, g23};
    return e[k];
  }
  // Stress of component k (s11 s22 s33 s12 s13 s23).
  double stress(int k) const {
    const double s[6] = {s11, s22, s33, s12, s13, s23};
    return s[k];
  }
  double normal_stress(int k) const { return stress(k); }
};

// b (axis and principal) is written only where the stress difference s1 - s3 exceeds this fraction of p.
inline constexpr double kBNoise = 0.01;

enum class ColumnFormat { Count, Real };  // "%.0f", "%.10g"

struct SeriesColumn {
  std::string_view name;  // in the CSV header (an interface: tools read these names)
  double SeriesRow::*field;
  ColumnFormat format;
  std::string_view unit;  // "-" for dimensionless
  std::string_view meaning;
  bool must_be_finite;    // a non-finite value stops the run (trouble shows here first)
};

// The columns in file order.
std::span<const SeriesColumn> series_columns();
const SeriesColumn* find_series_column(std::string_view name);

// Dilatancy index DI = -d(ev)/d(e1), centred: for each row, the least-squares slope of ev against e1 over
// the contiguous rows (in row order) whose e1 lies within kDilatancyWindow / 2 of the row's, on both sides,
// so the index does not lag the curve. A window in strain, not in rows, so the output interval does not
// change its smoothing. NaN where the rows found span less than half the window (the ends of a stage,
// the turns of a cycle). It needs the rows after a row: a stage writes its DI column when it ends.
inline constexpr double kDilatancyWindow = 0.0025;
void fill_dilatancy(std::vector<SeriesRow>& rows, double width = kDilatancyWindow);

// The row of the current state from its contact measures (DI: NaN, see fill_dilatancy); a running stage
// measures the contacts once per row and hands the same record to the health checks.
SeriesRow series_row(const Model& model, const State& state, const ContactMeasures& contacts);
// The same, measuring the contacts first.
SeriesRow measure_series_row(const Model& model, const State& state);

// The row as series.csv holds it (every value through its column's format): what a resumed run reads back,
// so summaries built from these are the same whether or not the run was interrupted.
SeriesRow as_printed(const SeriesRow& row);

std::string series_header();
std::string format_series_row(const SeriesRow& row);
// Parses a line written by format_series_row under `header` (the file's column names); nullopt if the
// line does not have one field per column. Columns the file lacks stay 0.
std::optional<SeriesRow> parse_series_row(const std::vector<std::string>& header, const std::string& line);

// The column table as Markdown (README) and as the JSON sidecar written next to each series.csv.
std::string series_columns_markdown();
std::string series_columns_json();

}  // namespace celldem
