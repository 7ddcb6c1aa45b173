// The series (solver/measure/series.hpp): the dilatancy window's slope, the column table and header, the row
// formatting and parsing, and a row measured on a lattice whose values are known.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "contact/contact_forces.hpp"
#include "helpers.hpp"
#include "measure/quasi_static.hpp"
#include "measure/series.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {


std::vector<SeriesRow> path(int count, double step, double (*ev)(double)) {
  std::vector<SeriesRow> rows(count);
  for (int k = 0; k < count; ++k) rows[k].e1 = k * step, rows[k].ev = ev(rows[k].e1);
  return rows;
}

// ev = 0.3 - 0.4 e1 (dilating as e1 grows): DI = -d(ev)/d(e1) = 0.4 wherever the centred window spans half
// its width, NaN at the very first row (nothing on one side and too little on the other) .
TEST(Dilatancy, SlopeOfLinearSeries) {
  std::vector<SeriesRow> rows = path(101, 1e-3, [](double e) { return 0.3 - 0.4 * e; });
  fill_dilatancy(rows, 0.01);
  for (const SeriesRow& r : rows) EXPECT_NEAR(r.DI, 0.4, 1e-9) << r.e1;
  rows = path(3, 1e-3, [](double e) { return 0.3 - 0.4 * e; });
  fill_dilatancy(rows, 0.01);  // three rows span 0.2 %, less than half the window
  for (const SeriesRow& r : rows) EXPECT_TRUE(std::isnan(r.DI));
}

// Centred, the index does not lag: on ev = -e1^2 the least-squares slope over a symmetric window is the
// derivative at its centre, -d(ev)/d(e1) = 2 e1, exactly (a trailing window would give 2 e1 - width/2).
TEST(Dilatancy, CentredWindowHasNoLag) {
  std::vector<SeriesRow> rows = path(201, 1e-4, [](double e) { return -e * e; });
  fill_dilatancy(rows, 0.004);
  for (std::size_t k = 20; k + 20 < rows.size(); ++k) EXPECT_NEAR(rows[k].DI, 2 * rows[k].e1, 1e-9) << rows[k].e1;
}

// A kink: compaction then dilation; away from the kink by half a window the slope is the local one, and a
// turn of e1 (unloading) splits the windows: rows on the other branch are not neighbours in row order.
TEST(Dilatancy, KinkAndTurn) {
  std::vector<SeriesRow> rows = path(201, 1e-4, [](double e) { return e < 0.01 ? 0.5 * e : 0.005 - 0.2 * (e - 0.01); });
  fill_dilatancy(rows, 0.004);
  for (const SeriesRow& r : rows) {
    if (r.e1 > 0.001 && r.e1 < 0.01 - 0.002 - 1e-9) { EXPECT_NEAR(r.DI, -0.5, 1e-9) << r.e1; }
    if (r.e1 > 0.01 + 0.002 + 1e-9 && r.e1 < 0.019) { EXPECT_NEAR(r.DI, 0.2, 1e-9) << r.e1; }
  }
  // Extension (e1 decreasing) is defined just the same: ev = 0.1 + 0.3 e1 gives DI = -0.3.
  std::vector<SeriesRow> back = path(101, -1e-3, [](double e) { return 0.1 + 0.3 * e; });
  fill_dilatancy(back, 0.01);
  EXPECT_NEAR(back[50].DI, -0.3, 1e-9);
}

TEST(SeriesRow, HeaderIsTheDocumentedColumnList) {
  // An interface: tools and users read these names.
  EXPECT_EQ(series_header(),
            "step,time,e1,e2,e3,ev,s11,s22,s33,s12,s13,s23,p,q,ratio13,b,sin_phi,DI,void_ratio,Z,Zm,"
            "sliding_fraction,n_contacts,n_strong,H11,H22,H33,H12,H13,H23,Hs11,Hs22,Hs33,Hw11,Hw22,Hw33,H11_H33,"
            "Hs11_Hs33,Hw11_Hw33,kinetic_energy,unbalanced_force,leg,sigma1,sigma2,sigma3,b_principal,"
            "ratio_principal,lode_angle,Zm_frictionless,g12,g13,g23,rate_factor,strain_rate,inertial_number,"
            "kinetic_to_elastic,imposed_inertial_number,energy_boundary_work,energy_normal,energy_tangential,"
            "energy_rotational_springs,energy_kinetic_translation,energy_kinetic_rotation,energy_friction,"
            "energy_rotational_friction,energy_body_damping,energy_contact_damping,energy_closure,"
            "energy_closure_relative\n");
  for (const SeriesColumn& c : series_columns()) {
    EXPECT_FALSE(c.unit.empty()) << c.name;
    EXPECT_FALSE(c.meaning.empty()) << c.name;
    EXPECT_EQ(find_series_column(c.name), &c);
  }
  EXPECT_EQ(find_series_column("nope"), nullptr);
}

TEST(SeriesRow, FormatsCountsAndNaNAndParsesBack) {
  SeriesRow row;
  for (const SeriesColumn& c : series_columns()) row.*c.field = 0.125;
  row.step = 1000;
  row.DI = std::nan("");
  row.n_contacts = 192;
  row.s11 = 1.0 / 3.0;  // more digits than the file keeps
  const std::string line = format_series_row(row);
  EXPECT_EQ(line.back(), '\n');
  EXPECT_EQ(line.rfind("1000,0.125,", 0), 0u);
  EXPECT_NE(line.find(",nan,"), std::string::npos);
  EXPECT_NE(line.find(",192,"), std::string::npos);
  EXPECT_NE(line.find(",0.3333333333,"), std::string::npos);
  EXPECT_EQ(std::count(line.begin(), line.end(), ','), static_cast<long>(series_columns().size() - 1));

  std::vector<std::string> header;
  for (const SeriesColumn& c : series_columns()) header.emplace_back(c.name);
  const std::optional<SeriesRow> back = parse_series_row(header, line.substr(0, line.size() - 1));
  ASSERT_TRUE(back.has_value());
  const SeriesRow printed = as_printed(row);
  EXPECT_EQ(printed.s11, 0.3333333333);
  for (const SeriesColumn& c : series_columns()) {
    if (std::isnan(printed.*c.field)) EXPECT_TRUE(std::isnan(back.value().*c.field)) << c.name;
    else EXPECT_EQ(back.value().*c.field, printed.*c.field) << c.name;
  }
  header.pop_back();  // one field too many for this header
  EXPECT_FALSE(parse_series_row(header, line.substr(0, line.size() - 1)).has_value());
}

// A simple cubic lattice (spacing a, overlap delta = 2R - a): p = s_ii = kn delta / a^2, q = 0, Z = 6, fabric
// I/3, 3N contacts, no strain yet.
TEST(SeriesRow, LatticeRowHasKnownValues) {
  const int n = 4;
  const double R = 0.5, a = 0.98, kn = 1e4, dt = 1e-4;
  const Model model = make_model(testing::model_deck(kn, kn, dt), std::vector<double>(n * n * n, R));
  State s = testing::lattice_state(n, R, Vec3(a, a, a), 0.05);
  s.control.stage_steps = 250;
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  const SeriesRow row = measure_series_row(model, s);
  const double p = kn * (2 * R - a) / (a * a);
  EXPECT_EQ(row.step, 250.0);
  EXPECT_NEAR(row.time, 250 * dt, 1e-15);
  for (double e : {row.e1, row.e2, row.e3, row.ev}) EXPECT_NEAR(e, 0.0, 1e-15);
  for (double x : {row.s11, row.s22, row.s33, row.p}) EXPECT_NEAR(x, p, 1e-9 * p);
  for (double x : {row.s12, row.s13, row.s23}) EXPECT_NEAR(x, 0.0, 1e-9 * p);
  EXPECT_NEAR(row.q, 0.0, 1e-9 * p);
  EXPECT_NEAR(row.ratio13, 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(row.DI));
  EXPECT_EQ(row.Z, 6.0);
  EXPECT_EQ(row.Zm, 6.0);
  EXPECT_EQ(row.n_contacts, 3.0 * n * n * n);
  // (Which of the equal forces count as "strong" is decided by rounding: not checked here.)
  for (double h : {row.H11, row.H22, row.H33}) EXPECT_NEAR(h, 1.0 / 3, 1e-12);
  for (double h : {row.H12, row.H13, row.H23}) EXPECT_NEAR(h, 0.0, 1e-12);
  EXPECT_NEAR(row.H11_H33, 1.0, 1e-12);
  EXPECT_NEAR(row.void_ratio, a * a * a / (4.0 / 3.0 * M_PI * R * R * R) - 1.0, 1e-12);
  EXPECT_EQ(row.sliding_fraction, 0.0);
  EXPECT_EQ(row.kinetic_energy, 0.0);
}

// The inertial number of the cell's own velocity gradient, against its analytic value I = gamma_dot d sqrt(rho/p),
// gamma_dot = sqrt(2 D':D'): an axial rate e with the two other axes at -e/2 (isochoric) gives sqrt(3) |e|, and
// adding an isotropic rate and a spin changes nothing; a simple shear L = g e1 e2^T gives |g|. The imposed column
// keeps the planned scale of the driven axes (state.inertial_rate); at a stage's step 0 the actual one is 0.
TEST(SeriesRow, InertialNumberOfTheCellsVelocityGradient) {
  const int n = 4;
  const double R = 0.5, a = 0.98, kn = 1e4, dt = 1e-4, rho = testing::kUnitMassDensity;
  const Model model = make_model(testing::model_deck(kn, kn, dt), std::vector<double>(n * n * n, R));
  State s = testing::lattice_state(n, R, Vec3(a, a, a), 0.05);
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  const double p = kn * (2 * R - a) / (a * a), d = 2 * R, e = 3e-2;
  Mat3 spin;
  spin << 0.0, 0.7, -0.2, -0.7, 0.0, 0.4, 0.2, -0.4, 0.0;
  s.cell.velocity_gradient = Vec3(-e, 0.5 * e, 0.5 * e).asDiagonal();
  s.cell.velocity_gradient += 0.11 * Mat3::Identity() + spin;
  s.inertial_rate = e;  // the planned scale: one driven axis at e
  EXPECT_NEAR(deviatoric_shear_rate(s.cell.velocity_gradient), std::sqrt(3.0) * e, 1e-15);
  s.control.stage_steps = 0;
  EXPECT_EQ(measure_series_row(model, s).inertial_number, 0.0);  // no step of the stage yet
  s.control.stage_steps = 10;
  SeriesRow row = measure_series_row(model, s);
  EXPECT_NEAR(row.inertial_number, std::sqrt(3.0) * e * d * std::sqrt(rho / p), 1e-12 * row.inertial_number);
  EXPECT_NEAR(row.imposed_inertial_number, e * d * std::sqrt(rho / p), 1e-12 * row.imposed_inertial_number);
  s.cell.velocity_gradient = Mat3::Zero();
  s.cell.velocity_gradient(0, 1) = -2 * e;  // simple shear: gamma_dot = |L12|
  row = measure_series_row(model, s);
  EXPECT_NEAR(row.inertial_number, 2 * e * d * std::sqrt(rho / p), 1e-12 * row.inertial_number);
  EXPECT_NEAR(cell_inertial_number(s, rho, p), row.inertial_number, 1e-15);
  EXPECT_TRUE(std::isnan(cell_inertial_number(s, rho, 0.0)));
}

// An anisotropic packing where every column is known by hand: a simple lattice with spacings ax < ay < az
// < 2R, so each sphere touches its x, y and z neighbours with overlaps 2R - a and forces f = kn (2R - a).
// Love-Weber: s_kk = f_k / (area of the cell face normal to k per sphere). All three forces differ, so b,
// sin phi, p, q, the ratios and the strong/weak split (mean force (fx + fy + fz)/3) are all non-trivial.
TEST(SeriesRow, AnisotropicLatticeRowEveryColumnByHand) {
  const int n = 4;
  const double R = 0.5, kn = 1e4, dt = 1e-4;
  const Vec3 a(0.97, 0.985, 0.995);
  const Model model = make_model(testing::model_deck(kn, kn, dt), std::vector<double>(n * n * n, R));
  State s = testing::lattice_state(n, R, a, 0.05);
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  const SeriesRow row = measure_series_row(model, s);

  const Vec3 f = kn * (Vec3::Constant(2 * R) - a);
  const double s11 = f[0] / (a[1] * a[2]), s22 = f[1] / (a[0] * a[2]), s33 = f[2] / (a[0] * a[1]);
  const double tol = 1e-9 * s11;
  EXPECT_NEAR(row.s11, s11, tol);
  EXPECT_NEAR(row.s22, s22, tol);
  EXPECT_NEAR(row.s33, s33, tol);
  for (double x : {row.s12, row.s13, row.s23}) EXPECT_NEAR(x, 0.0, tol);
  const double p = (s11 + s22 + s33) / 3.0;
  const double q = std::sqrt(0.5 * ((s11 - s22) * (s11 - s22) + (s22 - s33) * (s22 - s33) + (s33 - s11) * (s33 - s11)));
  EXPECT_NEAR(row.p, p, tol);
  EXPECT_NEAR(row.q, q, tol);
  EXPECT_NEAR(row.ratio13, s11 / s33, 1e-9);
  EXPECT_NEAR(row.b, (s22 - s33) / (s11 - s33), 1e-9);
  EXPECT_NEAR(row.sin_phi, (s11 - s33) / (s11 + s33), 1e-9);
  // Principal stresses are the axis stresses here (no shear), in descending order.
  EXPECT_NEAR(row.sigma1, s11, tol);
  EXPECT_NEAR(row.sigma2, s22, tol);
  EXPECT_NEAR(row.sigma3, s33, tol);
  EXPECT_NEAR(row.b_principal, row.b, 1e-9);
  EXPECT_NEAR(row.ratio_principal, row.ratio13, 1e-9);
  const double bb = (s22 - s33) / (s11 - s33);
  EXPECT_NEAR(row.lode_angle, std::atan((2 * bb - 1) / std::sqrt(3.0)) * 180 / M_PI, 1e-9);
  // Every sphere touches six neighbours: Z = Zm = 6 under both rattler rules; fabric I/3.
  EXPECT_EQ(row.n_contacts, 3.0 * n * n * n);
  EXPECT_EQ(row.Z, 6.0);
  EXPECT_EQ(row.Zm, 6.0);
  EXPECT_EQ(row.Zm_frictionless, 6.0);
  for (double h : {row.H11, row.H22, row.H33}) EXPECT_NEAR(h, 1.0 / 3, 1e-12);
  // Strong: above the mean normal force (fx + fy + fz)/3 = only the x contacts; weak: y and z.
  ASSERT_GT(f[0], f.mean());
  ASSERT_LT(f[1], f.mean());
  EXPECT_EQ(row.n_strong, 1.0 * n * n * n);
  EXPECT_NEAR(row.Hs11, 1.0, 1e-12);
  EXPECT_NEAR(row.Hs22, 0.0, 1e-12);
  EXPECT_NEAR(row.Hw11, 0.0, 1e-12);
  EXPECT_NEAR(row.Hw22, 0.5, 1e-12);
  EXPECT_NEAR(row.Hw33, 0.5, 1e-12);
  EXPECT_TRUE(std::isnan(row.Hs11_Hs33) || std::isinf(row.Hs11_Hs33));  // no strong z contacts
  EXPECT_NEAR(row.Hw11_Hw33, 0.0, 1e-12);
  EXPECT_NEAR(row.H11_H33, 1.0, 1e-12);
  EXPECT_NEAR(row.void_ratio, a.prod() / (4.0 / 3.0 * M_PI * R * R * R) - 1.0, 1e-12);
}

// The rows of a cell deformed so that ev = -0.4 e1 exactly (dilating), measured on the state and then given
// their centred dilatancy index as a stage does when it ends: DI = 0.4.
TEST(SeriesRow, DilatancyIndexOfAKnownPath) {
  const Model model = make_model(testing::model_deck(1e4, 1e4, 1e-4), std::vector<double>(27, 0.5));
  State s = testing::lattice_state(3, 0.5, Vec3(1.2, 1.2, 1.2), 0.05);
  const Vec3 l0 = s.cell.h.diagonal();
  std::vector<SeriesRow> rows;
  for (int k = 0; k <= 12; ++k) {
    const double e1 = 0.0005 * k, ev = -0.4 * e1;
    // (1 - e1) (1 - e2)^2 = 1 - ev: equal lateral strains carry the volume change.
    const double lateral = std::sqrt((1.0 - ev) / (1.0 - e1));
    s.cell.h = Vec3(l0[0] * (1.0 - e1), l0[1] * lateral, l0[2] * lateral).asDiagonal();
    rebuild_pairs(model, s);
    compute_contact_forces(model, 0.0, s);
    rows.push_back(as_printed(measure_series_row(model, s)));
    EXPECT_NEAR(rows.back().ev, ev, 1e-12);
    EXPECT_TRUE(std::isnan(rows.back().DI));  // not known until the rows after it are
  }
  fill_dilatancy(rows);
  // At the ends the window holds less than half its width (a row every 0.05 %, window 0.25 %): NaN there.
  EXPECT_TRUE(std::isnan(rows.front().DI));
  EXPECT_TRUE(std::isnan(rows.back().DI));
  int defined = 0;
  for (const SeriesRow& r : rows) {
    if (std::isnan(r.DI)) continue;
    EXPECT_NEAR(r.DI, 0.4, 1e-6) << r.e1;  // printed e1, ev: 10 digits
    ++defined;
  }
  EXPECT_GE(defined, 9);
}

// Strains in the row are engineering strains of the cell against the stage start, compression positive.
TEST(SeriesRow, StrainsAgainstStageStart) {
  const Model model = make_model(testing::model_deck(1e4, 1e4, 1e-4), std::vector<double>(27, 0.5));
  State s = testing::lattice_state(3, 0.5, Vec3(1.2, 1.2, 1.2), 0.05);  // nothing touches
  s.cell.h = Vec3(3.6 * 0.99, 3.6 * 1.02, 3.6).asDiagonal();
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  const SeriesRow row = measure_series_row(model, s);
  EXPECT_NEAR(row.e1, 0.01, 1e-14);
  EXPECT_NEAR(row.e2, -0.02, 1e-14);
  EXPECT_NEAR(row.e3, 0.0, 1e-14);
  EXPECT_NEAR(row.ev, 1.0 - 0.99 * 1.02, 1e-14);
  EXPECT_EQ(row.n_contacts, 0.0);
  EXPECT_EQ(row.unbalanced_force, 0.0);
}

}  // namespace
}  // namespace celldem
