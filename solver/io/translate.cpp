#include "io/translate.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "core/plan.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {

// Shortest text that reads back to the same double: exact, and short for round deck values (1e+06, 0.05).
std::string num(double x) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, res.ptr);
}

const char* kAxisName[3] = {"x", "y", "z"};

bool any_stress_axis(const TestDef& t) {
  for (const Leg& leg : t.legs)
    for (const AxisControl& a : leg.axes)
      if (a.stress_driven()) return true;
  return false;
}
bool any_stress_axis(const Deck& d) {
  return std::any_of(d.tests.begin(), d.tests.end(), [](const TestDef& t) { return any_stress_axis(t); });
}


// fix deform erate [1/s] of a strain-controlled axis (compression positive in the deck, L = L0 (1 + erate t)).
double engineering_rate(const Deck& deck, const AxisControl& a) {
  return a.mode == AxisMode::StrainRate ? -a.value : -a.value / deck.time_step;
}

std::string axis_text(const AxisControl& a) {
  switch (a.mode) {
    case AxisMode::StrainIncrement: return "strain increment " + num(a.value) + " per step";
    case AxisMode::StrainRate: return "strain rate " + num(a.value) + " 1/s";
    case AxisMode::Stress: return "stress " + num(a.value) + " Pa";
    case AxisMode::B: return "b " + num(a.value);
    case AxisMode::MeanStress: return "mean stress " + num(a.value) + " Pa";
    case AxisMode::ConstantVolume: return "constant volume";
  }
  return "";
}

// Per-type fix langevin / fix viscous constants that give exactly c_r on the spin and c_t on the velocity
// (LAMMPS 29Sep2021, verified): langevin (T = 0, omega yes, damp 1.0, scale s) applies F = -m/s v and
// T = -(10/3) I/s w; viscous (gamma 1.0, scale g) applies F = -g v.
struct LammpsDamping {
  std::vector<double> langevin_scale;  // s_t = (10/3) I / c_r  (empty: no rotational damping)
  std::vector<double> viscous_scale;   // g_t = c_t - m / s_t, clamped at 0
  bool clamped = false;                // some g_t < 0: langevin alone exceeds c_t
};

LammpsDamping lammps_damping(const Deck& deck) {
  LammpsDamping d;
  const bool rotational = deck.damping.rotational > 0.0 && deck.contact.kt > 0.0;
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

std::string scales(const std::vector<double>& v) {
  std::string s;
  for (std::size_t k = 0; k < v.size(); ++k) s += " scale " + std::to_string(k + 1) + " " + num(v[k]);
  return s;
}

std::string matrix(std::size_t n, double value) {
  const std::string v = num(value);
  std::string s = std::to_string(n);
  for (std::size_t k = 0; k < n * n; ++k) {
    s += ' ';
    s += v;
  }
  return s;
}

std::string deck_name(const Deck& deck) { return std::filesystem::path(deck.source).filename().string(); }

void comment_block(std::ostringstream& o, const std::string& title, const std::vector<std::string>& items) {
  o << "# " << title << "\n";
  if (items.empty()) o << "#   (none)\n";
  for (const std::string& item : items) {
    // Wrap at about 100 columns, continuation lines indented under the text.
    std::istringstream words(item);
    std::string line = "#   - ", word;
    bool first = true;
    while (words >> word) {
      if (!first && line.size() + 1 + word.size() > 108) {
        o << line << "\n";
        line = "#     " + word;
      } else {
        line += (first ? "" : " ") + word;
      }
      first = false;
    }
    o << line << "\n";
  }
}

// ---- the parts of a script ----

void header(std::ostringstream& o, const Deck& deck, const TestDef& test, TargetCode code) {
  const bool lmp = code == TargetCode::Lammps;
  const std::string exe = lmp ? "lmp" : "liggghts";
  o << "# ==============================================================================================\n"
    << "# " << (lmp ? "LAMMPS (29 Sep 2021)" : "LIGGGHTS-PUBLIC (3.8.0)") << " input for test \"" << test.name
    << "\" of the celldem deck " << deck_name(deck) << "\n"
    << "# Written by `celldem translate`; it depends on the deck only. Regenerate it rather than edit it.\n"
    << "# Data file: `celldem translate DECK --to " << target_code_name(code)
    << " --state FILE --out DIR` writes DIR/" << kTranslatedDataName << "\n"
    << "# (atom type k = k-th diameter of sample.diameters, one type per diameter for per-type damping).\n"
    << "# Run in DIR:  " << exe << " -in " << script_file_name(test, code) << "   [-var data FILE] [-var out FILE] [-var steps N]\n";
  o << "#   in parallel, unchanged:  mpirun -np 4 " << exe << " -in " << script_file_name(test, code)
    << "   (as root: mpirun --allow-run-as-root ...)\n";
  o << "# Writes " << series_file_name(test, code) << ": " << kTranslatedSeriesHeader << "\n"
    << "#   e = 1 - L/L0 (compression +), ev = 1 - V/V0, s = contact stress [Pa] (compression +), Z = 2 contacts/N,\n"
    << "#   kinetic energy [J] translation + rotation; lengths l [m] and stresses are those of the step's force\n"
    << "#   evaluation (taken before fix deform / the servo move the box at the end of the step).\n"
    << "#\n"
    << "# Test: x1 " << axis_text(test.legs[0].axes[0]) << ", x2 " << axis_text(test.legs[0].axes[1]) << ", x3 "
    << axis_text(test.legs[0].axes[2]) << "; friction " << num(test.friction) << "; " << plan_test(deck, test).steps
    << " steps (e" << test.legs[0].end.axis + 1 << " = " << num(test.legs[0].end.value) << "), output every "
    << test.output_interval << "\n";
  std::vector<std::string> differences = model_differences(deck, code);
  differences.push_back("contact history cannot be carried by a data file: the run starts with zero tangential "
                        "springs (exact only when the state's history is zero, e.g. after a frictionless "
                        "preparation; celldem translate checks the state and warns otherwise)");
  comment_block(o, "Differences from the deck's physics that " + std::string(lmp ? "LAMMPS" : "LIGGGHTS") +
                       " cannot express (celldem translate also prints these):",
                differences);
  comment_block(o, "Notes (discretisation and output):", model_notes(deck, code));
  o << "# ==============================================================================================\n";
}

// Observation before the box moves: fix ave/time evaluates at end_of_step in definition order, so placed
// before fix deform / the servo it sees the box and virial of this step's force evaluation.
void observation(std::ostringstream& o, const Deck& deck, TargetCode code) {
  const bool lmp = code == TargetCode::Lammps;
  o << "\n# measurements: contact stress (virial only, no kinetic part) [Pa, compression +], contacts, energy\n"
    << (lmp ? "compute         P all pressure NULL virial\n" : "compute         P all pressure thermo_temp virial\n")
    << "compute         cpa all contact/atom\n"
    << "compute         nc2 all reduce sum c_cpa\n"
    << "compute         ket all ke\n"
    << "compute         ker all erotate/sphere\n"
    << "variable        l1now equal lx\n"
    << "variable        l2now equal ly\n"
    << "variable        l3now equal lz\n"
    << "# every step (the virial must be tallied each step); before the box moves (see the header)\n"
    << "fix             obs all ave/time 1 1 1 v_l1now v_l2now v_l3now c_P[1] c_P[2] c_P[3] c_nc2 c_ket c_ker\n"
    << "# lengths at the test start (frozen now), for engineering strains\n";
  for (int k = 0; k < 3; ++k)
    o << "variable        L0" << k + 1 << " equal " << (lmp ? std::string("$(l") + kAxisName[k] + ":%.17g)" : "${l" + std::to_string(k + 1) + "now}") << "\n";
  o << "variable        time equal step*" << num(deck.time_step) << "\n"
    << "variable        e1 equal 1.0-f_obs[1]/v_L01\n"
    << "variable        e2 equal 1.0-f_obs[2]/v_L02\n"
    << "variable        e3 equal 1.0-f_obs[3]/v_L03\n"
    << "variable        ev equal 1.0-f_obs[1]*f_obs[2]*f_obs[3]/(v_L01*v_L02*v_L03)\n"
    << "variable        s11 equal f_obs[4]\n"
    << "variable        s22 equal f_obs[5]\n"
    << "variable        s33 equal f_obs[6]\n"
    << "variable        Z equal f_obs[7]/atoms\n"
    << "variable        nc equal f_obs[7]/2\n"
    << "variable        ek equal f_obs[8]+f_obs[9]\n"
    << "variable        l1 equal f_obs[1]\n"
    << "variable        l2 equal f_obs[2]\n"
    << "variable        l3 equal f_obs[3]\n";
}

void output(std::ostringstream& o, const Deck& deck, const TestDef& test, TargetCode code) {
  const bool lmp = code == TargetCode::Lammps;
  (void)deck;
  o << "\n# series (LAMMPS prints step 0 too; LIGGGHTS starts at the first output step)\n";
  if (lmp) {
    o << "fix             out all print " << test.output_interval
      << " \"$(step),$(v_time:%.10g),$(v_e1:%.10g),$(v_e2:%.10g),$(v_e3:%.10g),$(v_ev:%.10g),"
         "$(v_s11:%.10g),$(v_s22:%.10g),$(v_s33:%.10g),$(v_Z:%.10g),$(v_nc:%.0f),$(v_ek:%.10g),"
         "$(v_l1:%.17g),$(v_l2:%.17g),$(v_l3:%.17g)\" file ${out} screen no title \""
      << kTranslatedSeriesHeader << "\"\n";
  } else {
    o << "variable        st equal step\n"
      << "fix             out all print " << test.output_interval
      << " \"${st},${time},${e1},${e2},${e3},${ev},${s11},${s22},${s33},${Z},${nc},${ek},${l1},${l2},${l3}\""
         " file ${out} screen no title \""
      << kTranslatedSeriesHeader << "\"\n";
  }
  o << "thermo_style    custom step v_e1 v_e2 v_e3 v_s11 v_s22 v_s33 v_Z\n"
    << "thermo_modify   norm no\n"
    << "thermo          " << test.output_interval << "\n"
    << "# one run per test: fix deform strains are relative to the box at the start of the run\n"
    << "run             ${steps}\n";
}

// The file names and run length, each overridable with -var NAME VALUE on the command line.
void script_variables(std::ostringstream& o, const Deck& deck, const TestDef& test, TargetCode code) {
  o << "variable        data index " << kTranslatedDataName << "\n"
    << "variable        out index " << series_file_name(test, code) << "\n"
    << "variable        steps index " << plan_test(deck, test).steps << "\n"
    << "read_data       ${data}\n"
    << "neighbor        " << num(skin_length(deck)) << " bin\n"
    << "neigh_modify    delay 0 every 1 check yes\n";
}

std::string lammps_script(const Deck& deck, const TestDef& test) {
  std::ostringstream o;
  header(o, deck, test, TargetCode::Lammps);
  const LammpsDamping damping = lammps_damping(deck);
  const std::size_t ntypes = atom_types(deck).size();
  o << "units           si\n"
    << "atom_style      sphere\n"
    << "dimension       3\n"
    << "boundary        p p p\n"
    << "newton          off\n"
    << "comm_modify     vel yes\n";
  script_variables(o, deck, test, TargetCode::Lammps);
  o << "\n# contact: F_n = kn overlap, incremental tangential spring kt with Coulomb limit, no contact damping\n"
    << "pair_style      gran/hooke/history " << num(deck.contact.kn) << " " << num(deck.contact.kt) << " 0.0 0.0 "
    << num(test.friction) << " 0\n"
    << "pair_coeff      * *\n"
    << "timestep        " << num(deck.time_step) << "\n"
    << "fix             int all nve/sphere\n"
    << "\n# body damping per type (" << ntypes << " types): c_t = " << num(deck.damping.translational)
    << " * 2 sqrt(m kn) on v, c_r = " << num(deck.damping.rotational) << " * 2 r sqrt(I kt) on omega\n";
  if (!damping.langevin_scale.empty())
    o << "# langevin at T = 0 is a pure drag: F = -m/s v, T = -(10/3) I/s omega; s = (10/3) I / c_r\n"
      << "fix             bdr all langevin 0.0 0.0 1.0 4928459 omega yes" << scales(damping.langevin_scale) << "\n"
      << "# viscous: the rest of c_t, g = c_t - m/s\n";
  if (deck.damping.translational > 0.0 || damping.clamped)
    o << "fix             bdt all viscous 1.0" << scales(damping.viscous_scale) << "\n";
  observation(o, deck, TargetCode::Lammps);

  std::string deform, baro;
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = test.legs[0].axes[k];
    if (a.mode == AxisMode::Stress) {
      baro += std::string(" ") + kAxisName[k] + " " + num(a.value) + " " + num(a.value) + " " +
              num(translated_servo(deck).pdamp);
    } else if (const double rate = engineering_rate(deck, a); rate != 0.0) {
      deform += std::string(" ") + kAxisName[k] + " erate " + num(rate);
    }
  }
  o << "\n# control: strain axes by fix deform (remap x: positions follow the box affinely, v is the non-affine\n"
    << "# velocity), stress axes by press/berendsen on the contact stress; a fixed axis is left alone\n";
  if (!deform.empty()) o << "fix             dfm all deform 1" << deform << " remap x\n";
  if (!baro.empty()) {
    const TranslatedServo servo = translated_servo(deck);
    o << "# per step L *= (1 - dt/pdamp (target - s)/modulus)^(1/3): celldem's proportional gain "
      << num(deck.servo.gain) << " at stiffness " << num(servo.modulus) << " Pa\n"
      << "fix             srv all press/berendsen" << baro << " couple none modulus " << num(servo.modulus)
      << " dilate all\n"
      << "fix_modify      srv press P\n";
  }
  output(o, deck, test, TargetCode::Lammps);
  return o.str();
}

std::string liggghts_script(const Deck& deck, const TestDef& test) {
  std::ostringstream o;
  header(o, deck, test, TargetCode::Liggghts);
  const std::vector<AtomType> types = atom_types(deck);
  const std::size_t n = types.size();
  o << "units           si\n"
    << "atom_style      granular\n"
    << "atom_modify     map array\n"
    << "boundary        p p p\n"
    << "newton          off\n"
    << "communicate     single vel yes\n";
  script_variables(o, deck, test, TargetCode::Liggghts);
  o << "\n# contact: hooke/stiffness F_n = kn overlap (absolute kn), history tangential spring kt, Coulomb limit;\n"
    << "# gamman and gammat must be given (per type pair) even when zero\n"
    << "fix             m1 all property/global kn peratomtypepair " << matrix(n, deck.contact.kn) << "\n"
    << "fix             m2 all property/global kt peratomtypepair " << matrix(n, deck.contact.kt) << "\n"
    << "fix             m3 all property/global gamman peratomtypepair " << matrix(n, 0.0) << "\n"
    << "fix             m4 all property/global gammat peratomtypepair " << matrix(n, 0.0) << "\n"
    << "fix             m5 all property/global coefficientFriction peratomtypepair " << matrix(n, test.friction)
    << "\n"
    << "pair_style      gran model hooke/stiffness tangential history tangential_damping off\n"
    << "pair_coeff      * *\n"
    << "timestep        " << num(deck.time_step) << "\n"
    << "fix             integr all nve/sphere\n";
  std::vector<double> ct;
  for (const AtomType& t : types) ct.push_back(t.c_t);
  o << "\n# body damping per type: c_t = " << num(deck.damping.translational)
    << " * 2 sqrt(m kn) on v; no rotational body damping exists in LIGGGHTS\n";
  if (deck.damping.translational > 0.0) o << "fix             bdt all viscous 1.0" << scales(ct) << "\n";
  observation(o, deck, TargetCode::Liggghts);

  std::string deform, servo_vars;
  const TranslatedServo servo = translated_servo(deck);
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = test.legs[0].axes[k];
    const std::string ax = kAxisName[k], i = std::to_string(k + 1);
    if (a.mode == AxisMode::Stress) {
      servo_vars += "variable        d" + ax + " equal l" + ax + "*(1.0-" + num(deck.time_step) + "/" +
                    num(servo.pdamp) + "*(" + num(a.value) + "-c_P[" + i + "])/" + num(servo.modulus) +
                    ")^(1.0/3.0)-v_L0" + i + "\n" + "variable        r" + ax + " equal 0.0\n";
      deform += " " + ax + " variable v_d" + ax + " v_r" + ax;
    } else if (const double rate = engineering_rate(deck, a); rate != 0.0) {
      deform += " " + ax + " erate " + num(rate);
    }
  }
  o << "\n# control: strain axes by fix deform erate (remap x); stress axes by the press/berendsen law written as a\n"
    << "# fix deform variable (L = L_start + d): L *= (1 - dt/pdamp (target - s)/modulus)^(1/3) per step,\n"
    << "# celldem's proportional gain " << num(deck.servo.gain) << " at stiffness " << num(servo.modulus) << " Pa\n"
    << servo_vars;
  if (!deform.empty()) o << "fix             dfm all deform 1" << deform << " remap x\n";
  output(o, deck, test, TargetCode::Liggghts);
  return o.str();
}

}  // namespace

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

std::vector<AtomType> atom_types(const Deck& deck) {
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

TranslatedServo translated_servo(const Deck& deck) {
  // Nominal affine axis stiffness of a dense random packing, K = (1/V) sum kn (n_k l_k)^2 with <n_k^4> = 1/5:
  // K = kn Z phi <l^2> / (10 <v_s>), Z = 6, phi = 0.64, l = r_i + r_j, sizes drawn with equal probability.
  // (The 300-sphere test state: 1.89e8 nominal against 1.94e8-2.00e8 measured.)
  double d1 = 0, d2 = 0, d3 = 0;
  for (double d : deck.sample.diameters) d1 += d, d2 += d * d, d3 += d * d * d;
  const double n = static_cast<double>(deck.sample.diameters.size());
  d1 /= n, d2 /= n, d3 /= n;
  const double l2 = 0.5 * (d2 + d1 * d1), vs = M_PI / 6.0 * d3;
  TranslatedServo s;
  const double k = deck.contact.kn * 6.0 * 0.64 * l2 / (10.0 * vs);
  const double decade = std::pow(10.0, std::floor(std::log10(k)) - 2.0);
  s.modulus = std::round(k / decade) * decade;  // 3 significant digits: it is a nominal value
  s.pdamp = deck.time_step / (3.0 * deck.servo.gain);
  return s;
}

std::vector<std::string> model_differences(const Deck& deck, TargetCode code) {
  const bool lmp = code == TargetCode::Lammps;
  const std::string target = lmp ? "LAMMPS" : "LIGGGHTS";
  std::vector<std::string> out;
  if (deck.kinematics == Kinematics::Affine)
    out.push_back("kinematics: the deck says \"affine\" (contacts see the affine velocity difference of the cell), "
                  "but with fix deform remap x " + target + " contacts see only the non-affine velocities, so the "
                  "affine part of the relative motion never loads the tangential springs (celldem "
                  "\"kinematics\": \"lammps\" matches " + target + ")");
  if (deck.contact.rotation == TangentialRotation::Rotate)
    out.push_back("contact.tangential_rotation: the deck says \"rotate\" (the spring keeps its length when the "
                  "tangent plane turns), " + target + " projects it onto the new plane without restoring the length "
                  "(celldem \"project\")");
  if (lmp && deck.contact.moment_arm == MomentArm::ContactPoint)
    out.push_back("contact.moment_arm: the deck says \"contact_point\" (lever arm r - overlap/2), LAMMPS "
                  "gran/hooke/history uses the full radius r for the torque and the rotational slip (celldem "
                  "\"radius\")");
  if (!lmp && deck.contact.moment_arm == MomentArm::Radius)
    out.push_back("contact.moment_arm: the deck says \"radius\", LIGGGHTS uses r - overlap/2 for the torque and the "
                  "rotational slip (celldem \"contact_point\")");
  if (!lmp && deck.damping.rotational > 0.0)
    out.push_back("damping.rotational = " + num(deck.damping.rotational) + ": LIGGGHTS 3.8 has no rotational body "
                  "damping (no fix langevin, no torque drag); only the translational damping is applied (celldem "
                  "damping.rotational 0 matches)");
  if (lmp && lammps_damping(deck).clamped)
    out.push_back("damping: fix langevin (omega yes) brings a translational drag 0.3 m c_r / I with the rotational "
                  "one, which exceeds c_t for some types here (kt/kn or rotational/translational too large); the "
                  "translational drag is larger than the deck's");
  if (any_stress_axis(deck)) {
    const TranslatedServo s = translated_servo(deck);
    out.push_back("servo: celldem's stress servo is proportional-integral with the stiffness measured from the "
                  "contacts each step (gain " + num(deck.servo.gain) + ", integral_gain " +
                  num(deck.servo.integral_gain) + ", cap " + num(deck.servo.max_strain_increment) + "); " +
                  (lmp ? "fix press/berendsen" : "the fix deform variable servo (the press/berendsen law)") +
                  " is proportional only, with a fixed nominal stiffness (modulus " + num(s.modulus) + " Pa, pdamp " +
                  num(s.pdamp) + " s: the same proportional gain at that stiffness) and no cap, so it trails a "
                  "dilating sample by about modulus * (lateral strain per step) / gain (compare curves in the "
                  "stresses each code actually held)");
  }
  return out;
}

std::vector<std::string> model_notes(const Deck& deck, TargetCode code) {
  const bool lmp = code == TargetCode::Lammps;
  std::vector<std::string> out;
  out.push_back("time integration: velocity Verlet with the body drag evaluated explicitly on the half-step "
                "velocity (post_force), where celldem's leapfrog treats the drag implicitly (midpoint); the "
                "difference is of order (c dt / 2m)^2 per step");
  out.push_back("the state's velocities and spins are half-step values; the data file gives them as the initial "
                "velocities (a difference of dt/2 F/m, negligible for an equilibrated state)");
  out.push_back("fix deform and the servo move the box at the end of a step, so the forces of step k see the box "
                "of step k-1 (celldem: of step k); the series reports the box of the force evaluation, so stresses "
                "compared at equal strain are consistent");
  if (lmp) {
    if (deck.damping.rotational > 0.0)
      out.push_back("fix langevin at zero temperature adds no noise; its random-number seed is irrelevant");
  } else {
    out.push_back("LIGGGHTS fix print does not write step 0; the first row is the first output step");
  }
  out.push_back("neighbour skin: neighbor_skin x the largest diameter, as celldem; it changes speed only");
  return out;
}

std::vector<std::string> state_differences(const State& state, TargetCode code) {
  std::vector<std::string> out;
  const std::vector<StoredContact> contacts = stored_contacts(state);
  std::size_t loaded = 0;
  double largest = 0.0;
  for (const StoredContact& c : contacts) {
    const double m = c.tangential.norm();
    if (m > 0.0) ++loaded, largest = std::max(largest, m);
  }
  if (loaded > 0) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%zu of %zu contacts (largest |xi| %.3g m)", loaded, contacts.size(), largest);
    out.push_back(std::string("the state holds tangential contact history in ") + buf + ", which a data file "
                  "cannot carry: " + (code == TargetCode::Lammps ? "LAMMPS" : "LIGGGHTS") +
                  " starts with zero tangential springs, so its forces differ from the first step on");
  }
  return out;
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

std::string translate_test(const Deck& deck, const TestDef& test, TargetCode code) {
  return code == TargetCode::Lammps ? lammps_script(deck, test) : liggghts_script(deck, test);
}

}  // namespace celldem
