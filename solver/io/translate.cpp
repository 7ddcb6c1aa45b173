#include "io/translate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>

#include "core/plan.hpp"
#include "io/translate_parts.hpp"

namespace celldem {
namespace translation {

ProgramFeatures test_features(const Deck& d) {
  ProgramFeatures f;
  for (const TestDef& t : d.tests) f.add(t.legs);
  return f;
}

std::string axis_text(const AxisControl& a) {
  switch (a.mode) {
    case AxisMode::StrainIncrement: return "strain increment " + num(a.value) + " per step";
    case AxisMode::StrainRate: return "strain rate " + num(a.value) + " 1/s";
    case AxisMode::Stress: return "stress " + num(a.value) + " Pa";
    case AxisMode::B: return "b " + num(a.value);
    case AxisMode::MeanStress: return "mean stress " + num(a.value) + " Pa";
    case AxisMode::ConstantVolume: return "constant volume";
    case AxisMode::StressRamp: return "stress ramp from " + num(a.value) + " Pa at " + num(a.rate) + " Pa/s";
    case AxisMode::Held: return "held";
  }
  return "";
}

LammpsDamping lammps_damping(const Deck& deck) {
  LammpsDamping d;
  const bool rotational =
      deck.damping.rotational > 0.0 && reference_stiffness(deck.contact, deck.sample).tangential > 0.0;
  for (const AtomType& t : atom_types(deck)) {
    double g = t.c_t;
    if (rotational) {
      const double s = (10.0 / 3.0) * t.inertia / t.c_r;
      d.langevin_scale.push_back(s);
      g = t.c_t - t.mass / s;
    }
    if (g < 0.0) {
      d.clamped = true;
      g = 0.0;
    }
    d.viscous_scale.push_back(g);
  }
  return d;
}

bool plain_linear(const ContactDef& c) {
  return c.normal == NormalModel::Linear && c.tangential == TangentialModel::LinearHistory &&
         c.rolling == RollingModel::None && c.twisting == TwistingModel::None;
}

std::string deck_name(const Deck& deck) { return std::filesystem::path(deck.source).filename().string(); }

}  // namespace translation

using namespace translation;

TargetCode parse_target_code(const std::string& name) {
  if (name == "lammps") return TargetCode::Lammps;
  if (name == "liggghts") return TargetCode::Liggghts;
  throw DeckError("--to: unknown code \"" + name + "\"; expected \"lammps\" or \"liggghts\"");
}

const char* target_code_name(TargetCode code) { return code == TargetCode::Lammps ? "lammps" : "liggghts"; }

std::string script_file_name(const TestDef& test, TargetCode code) {
  return test.name + "." + target_code_name(code) + ".in";
}

std::string series_file_name(const TestDef& test, TargetCode code) {
  return test.name + "." + target_code_name(code) + ".csv";
}

std::string preparation_script_name(TargetCode code) { return std::string("prepare.") + target_code_name(code) + ".in"; }

std::string preparation_series_name(TargetCode code) { return std::string("prepare.") + target_code_name(code) + ".csv"; }

namespace {
void require_listed_sizes(const Deck& deck) {
  if (deck.sample.grading)
    throw DeckError("sample.diameters.grading: the translated scripts give one atom type per listed diameter "
                    "(per-type damping), which a graded sample does not have: translate a deck with a `list`");
}
}  // namespace

std::vector<AtomType> atom_types(const Deck& deck) {
  require_listed_sizes(deck);
  std::vector<AtomType> types;
  for (double d : deck.sample.diameters) {
    if (std::any_of(types.begin(), types.end(), [d](const AtomType& t) { return t.diameter == d; })) continue;
    AtomType t;
    t.diameter = d;
    const BodyProperties b = body_properties(0.5 * d, deck.sample.density, deck.damping, reference_stiffness(deck.contact, deck.sample));
    t.mass = b.mass;
    t.inertia = b.inertia;
    t.c_t = b.translational_drag;
    t.c_r = b.rotational_drag;
    types.push_back(t);
  }
  return types;
}

namespace {
// The contact normal stiffness of the servo's nominal modulus: kn; for hertz the tangent stiffness 2 E* a at the
// mean contact of the deck's largest stress (core/plan's mean_contact), which is what celldem's servo measures
// on average (its axis stiffness sums the contacts' tangent stiffnesses).
double nominal_normal_stiffness(const Deck& deck) {
  const ContactDef& c = deck.contact;
  if (c.normal == NormalModel::Linear) return c.kn;
  const std::optional<MeanContact> mean = mean_contact(deck);
  if (!mean) return reference_stiffness(c, deck.sample).normal;
  return 2.0 * c.effective_modulus() * mean->contact_radius;
}
}  // namespace

TranslatedServo translated_servo(const Deck& deck, double time_step) {
  require_listed_sizes(deck);
  // Nominal affine axis stiffness of a dense random packing, K = (1/V) sum kn (n_k l_k)^2 with <n_k^4> = 1/5:
  // K = kn Z phi <l^2> / (10 <v_s>), Z = 6, phi = 0.64, l = r_i + r_j, sizes drawn with equal probability.
  // (The 300-sphere test state: 1.89e8 nominal against 1.94e8-2.00e8 measured.)
  double d1 = 0, d2 = 0, d3 = 0;
  for (double d : deck.sample.diameters) d1 += d, d2 += d * d, d3 += d * d * d;
  const double n = static_cast<double>(deck.sample.diameters.size());
  d1 /= n, d2 /= n, d3 /= n;
  const double l2 = 0.5 * (d2 + d1 * d1), vs = M_PI / 6.0 * d3;
  TranslatedServo s;
  const double k = nominal_normal_stiffness(deck) * 6.0 * 0.64 * l2 / (10.0 * vs);
  const double decade = std::pow(10.0, std::floor(std::log10(k)) - 2.0);
  s.modulus = std::round(k / decade) * decade;  // 3 significant digits: it is a nominal value
  s.pdamp = time_step / (3.0 * deck.servo.gain);
  return s;
}

std::string translate_data(const Deck& deck, const State& state, TargetCode code, const std::string& state_label,
                           const std::vector<std::string>& differences) {
  const Mat3& h = state.cell.h;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (r != c && h(r, c) != 0.0)
        throw DeckError("the state's cell is not orthogonal (h(" + std::to_string(r) + "," + std::to_string(c) +
                        ") = " + num(h(r, c)) + "); only orthogonal cells can be translated");
  const std::vector<AtomType> types = atom_types(deck);
  const Particles& p = state.particles;
  std::vector<int> type(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double d = 2.0 * p.radius[i];
    int found = -1;
    for (std::size_t k = 0; k < types.size(); ++k)
      if (std::abs(d - types[k].diameter) <= 1e-9 * types[k].diameter) found = static_cast<int>(k);
    if (found < 0)
      throw DeckError("sample.diameters: particle " + std::to_string(i) + " of the state has diameter " + num(d) +
                      " m, which is not in the deck's list (the translated scripts give one atom type per listed "
                      "diameter)");
    type[i] = found + 1;
  }

  std::ostringstream o;
  o << "celldem translate: " << p.size() << " particles of state \"" << state_label << "\" for "
    << (code == TargetCode::Lammps ? "LAMMPS atom_style sphere" : "LIGGGHTS atom_style granular") << " (deck "
    << deck_name(deck) << ")\n\n";
  o << "# Atoms: id type diameter [m] density [kg/m^3] x y z [m]; Velocities: id vx vy vz [m/s] wx wy wz [rad/s]\n";
  o << "# (the non-affine velocities and the spins of the state). Type k has diameter sample.diameters[k-1].\n";
  for (const std::string& w : differences) o << "# warning: " << w << "\n";
  o << "\n" << p.size() << " atoms\n" << types.size() << " atom types\n\n";
  for (int k = 0; k < 3; ++k)
    o << "0 " << num(h(k, k)) << " " << kAxisName[k] << "lo " << kAxisName[k] << "hi\n";
  o << "\nAtoms # " << (code == TargetCode::Lammps ? "sphere" : "granular") << "\n\n";
  for (std::size_t i = 0; i < p.size(); ++i) {
    o << i + 1 << " " << type[i] << " " << num(2.0 * p.radius[i]) << " " << num(deck.sample.density);
    for (int k = 0; k < 3; ++k) {
      const double s = p.scaled[i][k] - std::floor(p.scaled[i][k]);
      double x = h(k, k) * s;
      if (!(x < h(k, k))) x = 0.0;  // s just below 1 can round up to L
      o << " " << num(x);
    }
    o << "\n";
  }
  o << "\nVelocities\n\n";
  for (std::size_t i = 0; i < p.size(); ++i) {
    o << i + 1;
    for (int k = 0; k < 3; ++k) o << " " << num(p.velocity[i][k]);
    for (int k = 0; k < 3; ++k) o << " " << num(p.spin[i][k]);
    o << "\n";
  }
  return o.str();
}

}  // namespace celldem
