// The LAMMPS and LIGGGHTS input scripts: header, settings, contact law, damping, observation and series around
// the load program (translate_program.cpp).

#include <sstream>

#include "core/plan.hpp"
#include "io/translate_parts.hpp"

namespace celldem {
namespace translation {
namespace {

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

std::string law_text(const ContactDef& c) {
  std::string s = c.normal == NormalModel::Hertz ? "hertz" : "linear";
  s += " + " + std::string(name_of(c.tangential, kTangentialModelNames));
  if (c.rolling == RollingModel::Sds) s += " + rolling sds";
  if (c.twisting == TwistingModel::Marshall) s += " + twisting marshall";
  return s;
}

// LAMMPS pair granular coefficients of the deck's law (pair_coeff * * ...), all damping coefficients 0:
// the deck's damping is body damping. Normal: `hooke kn 0` (F = kn d) or `hertz/material E 0 nu`
// (F = 4/3 E* a d, E* = E / (2 (1 - nu^2)) by LAMMPS's mixing of one material); `damping viscoelastic` with
// coefficient 0 is no damping. Tangential: `linear_history kt 0 mu`, `mindlin kt 0 mu` or `mindlin_rescale kt 0 mu`
// (k = kt a; kt = NULL gives 8 G*, G* = E / (4 (2 - nu)(1 + nu)), but only after a material normal model: after
// hooke it is written as the number). Rolling `sds k_roll gamma_roll mu_roll`, twisting `marshall` (no coefficients).
std::string lammps_granular_coeffs(const ContactDef& c, double mu, double mu_roll) {
  std::ostringstream o;
  if (c.normal == NormalModel::Hertz)
    o << "hertz/material " << num(c.youngs_modulus) << " 0.0 " << num(c.poisson_ratio);
  else
    o << "hooke " << num(c.kn) << " 0.0";
  o << " damping viscoelastic tangential ";
  if (is_mindlin(c.tangential))
    o << name_of(c.tangential, kTangentialModelNames) << " "
      << (c.normal == NormalModel::Hertz ? std::string("NULL") : num(8.0 * c.effective_shear_modulus()));
  else
    o << "linear_history " << num(c.kt);
  o << " 0.0 " << num(mu);
  if (c.rolling == RollingModel::Sds)
    o << " rolling sds " << num(c.rolling_stiffness) << " " << num(c.rolling_damping) << " " << num(mu_roll);
  if (c.twisting == TwistingModel::Marshall) o << " twisting marshall";
  return o.str();
}

std::string vector_of(std::size_t n, double value) {
  std::string s;
  const std::string v = num(value);
  for (std::size_t k = 0; k < n; ++k) {
    s += ' ';
    s += v;
  }
  return s;
}

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

void header(std::ostringstream& o, const Deck& deck, const ScriptProgram& p, TargetCode code,
            const std::vector<LegRun>& runs) {
  const bool lmp = code == TargetCode::Lammps;
  const std::string exe = lmp ? "lmp" : "liggghts";
  const std::string script = p.preparation() ? preparation_script_name(code) : p.name + "." + target_code_name(code) + ".in";
  const std::string series = p.preparation() ? preparation_series_name(code) : p.name + "." + target_code_name(code) + ".csv";
  const bool known = p.one_leg() && runs[0].length == LegLength::Known;
  o << "# ==============================================================================================\n"
    << "# " << (lmp ? "LAMMPS (29 Sep 2021)" : "LIGGGHTS-PUBLIC (3.8.0)") << " input for "
    << (p.preparation() ? std::string("the preparation") : "test \"" + p.name + "\"") << " of the celldem deck "
    << deck_name(deck) << "\n"
    << "# Written by `celldem translate`; it depends on the deck only. Regenerate it rather than edit it.\n";
  if (p.preparation()) {
    o << "# Data file: `celldem translate DECK --to " << target_code_name(code) << " --out DIR` writes DIR/"
      << kTranslatedSampleName << ", celldem's initial grid sample\n"
      << "# (atom type k = k-th diameter of sample.diameters, one type per diameter for per-type damping).\n"
      << "# Run in DIR:  " << exe << " -in " << script << "   [-var data FILE] [-var out FILE] [-var prepared FILE]\n"
      << "#   then the tests from the prepared sample:  " << exe << " -in TEST." << target_code_name(code)
      << ".in -var data " << kTranslatedPreparedName << "\n";
  } else {
    o << "# Data file: `celldem translate DECK --to " << target_code_name(code)
      << " --state FILE --out DIR` writes DIR/" << kTranslatedDataName << "\n"
      << "# (atom type k = k-th diameter of sample.diameters, one type per diameter for per-type damping).\n"
      << "# Run in DIR:  " << exe << " -in " << script << "   [-var data FILE] [-var out FILE]" << (known ? " [-var steps N]" : "")
      << "\n";
  }
  o << "#   in parallel, unchanged:  mpirun -np 4 " << exe << " -in " << script
    << "   (as root: mpirun --allow-run-as-root ...)\n";
  o << "# Writes " << series << ": " << kTranslatedSeriesHeader << (program_shears(p) ? kTranslatedShearColumns : "")
    << "\n"
    << "#   e = 1 - L/L0 (compression +), ev = 1 - V/V0, s = contact stress [Pa] (compression +), Z = 2 contacts/N,\n"
    << "#   kinetic energy [J] translation + rotation; lengths l [m] and stresses are those of the step's force\n"
    << "#   evaluation (taken before fix deform / the servo move the box at the end of the step).\n"
    << "#\n";
  if (p.one_leg()) {
    const Leg& leg = p.legs[0];
    o << "# Test: x1 " << axis_text(leg.axes[0]) << ", x2 " << axis_text(leg.axes[1]) << ", x3 " << axis_text(leg.axes[2])
      << "; friction " << num(p.friction) << "; ";
    if (known && leg.end.kind == LegEndKind::Strain)
      o << runs[0].steps << " steps (e" << leg.end.axis + 1 << " = " << num(leg.end.value) << ")";
    else
      o << end_text(leg, runs[0]);
    o << ", output every " << p.output_interval << "\n";
  } else {
    o << "# " << (p.preparation() ? "Preparation" : "Test") << ": a load program of " << p.legs.size()
      << " leg(s), run one after the other; friction " << num(p.friction) << "; output every " << p.output_interval
      << "\n";
    for (std::size_t j = 0; j < p.legs.size(); ++j) o << "#   leg " << j + 1 << ": " << leg_text(p.legs[j], runs[j]) << "\n";
  }
  std::vector<std::string> differences = p.preparation() ? preparation_differences(deck, code) : model_differences(deck, code);
  if (!p.preparation())
    differences.push_back("contact history cannot be carried by a data file: the run starts with zero tangential "
                          "springs (exact only when the state's history is zero, e.g. after a frictionless "
                          "preparation; celldem translate checks the state and warns otherwise)");
  comment_block(o, "Differences from the deck's physics that " + std::string(lmp ? "LAMMPS" : "LIGGGHTS") +
                       " cannot express (celldem translate also prints these):",
                differences);
  comment_block(o, "Notes (discretisation and output):", p.preparation() ? preparation_notes(deck, code) : model_notes(deck, code));
  o << "# ==============================================================================================\n";
}

// Observation before the box moves: fix ave/time evaluates at end_of_step in definition order, so placed
// before fix deform / the servo it sees the box and virial of this step's force evaluation.
void observation(std::ostringstream& o, const ScriptProgram& p, TargetCode code, bool shear) {
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
    << (shear ? "variable        xynow equal xy\nvariable        xznow equal xz\nvariable        yznow equal yz\n" : "")
    << "fix             obs all ave/time 1 1 1 v_l1now v_l2now v_l3now c_P[1] c_P[2] c_P[3] c_nc2 c_ket c_ker"
    << (shear ? " v_xynow v_xznow v_yznow c_P[4] c_P[5] c_P[6]" : "") << "\n"
    << "# lengths at the test start (frozen now), for engineering strains\n";
  for (int k = 0; k < 3; ++k)
    o << "variable        L0" << k + 1 << " equal " << (lmp ? std::string("$(l") + kAxisName[k] + ":%.17g)" : "${l" + std::to_string(k + 1) + "now}") << "\n";
  o << "variable        time equal step*" << num(p.time_step) << "\n"
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
  if (!shear) return;
  o << "# shear: g_ij = -(tilt - tilt(test start)) / L_j(test start) (celldem's sign), s_ij = the virial's P_ij\n";
  const char* tilt[3] = {"xy", "xz", "yz"};
  for (int a = 0; a < 3; ++a)
    o << "variable        T0" << tilt[a] << " equal "
      << (lmp ? std::string("$(") + tilt[a] + ":%.17g)" : std::string("${") + tilt[a] + "now}") << "\n";
  for (int a = 0; a < 3; ++a) {
    const std::string name = std::string(kShearAxisNames[a]).substr(1);  // "12"
    o << "variable        g" << name << " equal -(f_obs[" << 10 + a << "]-v_T0" << tilt[a] << ")/v_L0"
      << kShearAxisEntries[a][1] + 1 << "\n"
      << "variable        s" << name << " equal f_obs[" << 13 + a << "]\n";
  }
}

// The preparation's unbalanced force ratio (measure/micro.hpp): mean |net contact force| over the particles
// (fix store/force, defined before the damping fixes, holds the pair forces) over the mean contact normal force.
void unbalanced_force(std::ostringstream& o, const Deck& deck, TargetCode code) {
  const bool lmp = code == TargetCode::Lammps;
  o << "\n# unbalanced force ratio: mean |net contact force| / mean contact normal force (celldem's; v_ubf is in the\n"
    << "# thermo output so that its computes are current at the end of each run)\n"
    << "variable        fnet atom sqrt(f_sf[1]^2+f_sf[2]^2+f_sf[3]^2)\n"
    << "compute         fnetm all reduce ave v_fnet\n";
  if (lmp) {
    o << "compute         pfn all pair/local force\n"
      << "compute         fns all reduce sum c_pfn\n"
      << "variable        fnsum equal c_fns\n";
  } else if (deck.contact.normal == NormalModel::Linear) {
    o << "# normal forces: kn * overlap (hooke/stiffness without damping), summed over the contacts\n"
      << "compute         pdl all pair/gran/local delta\n"
      << "compute         dls all reduce sum c_pdl[1]\n"
      << "variable        fnsum equal " << num(deck.contact.kn) << "*c_dls\n";
  } else {
    // Hertz: no per-contact product can be reduced in LIGGGHTS; sum fn l = trace(sigma) V exactly (l parallel
    // to n), so sum fn ~ trace(sigma) V / <l> with <l> ~ the mean diameter (a named difference).
    o << "# normal forces (hertz): sum fn |l| = (s11 + s22 + s33) V exactly, so sum fn ~ that / mean diameter "
         "(approximate)\n"
      << "variable        fnsum equal (f_obs[4]+f_obs[5]+f_obs[6])*vol/" << num(mean_diameter(deck.sample)) << "\n";
  }
  o << "variable        ubf equal c_fnetm*0.5*f_obs[7]/(v_fnsum+(v_fnsum<=0.0))\n";
}

// The series output; the one-leg form of a test of known length also runs here.
void output(std::ostringstream& o, const ScriptProgram& p, TargetCode code, bool run_steps) {
  const bool lmp = code == TargetCode::Lammps, shear = program_shears(p);
  const std::string header = std::string(kTranslatedSeriesHeader) + (shear ? kTranslatedShearColumns : "");
  o << "\n# series (LAMMPS prints step 0 too; LIGGGHTS starts at the first output step)\n";
  if (lmp) {
    o << "fix             out all print " << p.output_interval
      << " \"$(step),$(v_time:%.10g),$(v_e1:%.10g),$(v_e2:%.10g),$(v_e3:%.10g),$(v_ev:%.10g),"
         "$(v_s11:%.10g),$(v_s22:%.10g),$(v_s33:%.10g),$(v_Z:%.10g),$(v_nc:%.0f),$(v_ek:%.10g),"
         "$(v_l1:%.17g),$(v_l2:%.17g),$(v_l3:%.17g)"
      << (shear ? ",$(v_s12:%.10g),$(v_s13:%.10g),$(v_s23:%.10g),$(v_g12:%.10g),$(v_g13:%.10g),$(v_g23:%.10g)" : "")
      << "\" file ${out} screen no title \"" << header << "\"\n";
  } else {
    o << "variable        st equal step\n"
      << "fix             out all print " << p.output_interval
      << " \"${st},${time},${e1},${e2},${e3},${ev},${s11},${s22},${s33},${Z},${nc},${ek},${l1},${l2},${l3}"
      << (shear ? ",${s12},${s13},${s23},${g12},${g13},${g23}" : "") << "\" file ${out} screen no title \""
      << header << "\"\n";
  }
  o << "thermo_style    custom step v_e1 v_e2 v_e3 v_s11 v_s22 v_s33 v_Z" << (p.preparation() ? " v_ubf" : "") << "\n"
    << "thermo_modify   norm no\n"
    << "thermo          " << p.output_interval << "\n";
  if (run_steps)
    o << "# one run per test: fix deform strains are relative to the box at the start of the run\n"
      << "run             ${steps}\n";
}

// The file names and run length, each overridable with -var NAME VALUE on the command line.
void script_variables(std::ostringstream& o, const Deck& deck, const ScriptProgram& p, TargetCode code,
                      const std::vector<LegRun>& runs) {
  if (p.preparation()) {
    o << "variable        data index " << kTranslatedSampleName << "\n"
      << "variable        out index " << preparation_series_name(code) << "\n"
      << "variable        prepared index " << kTranslatedPreparedName << "\n";
  } else {
    o << "variable        data index " << kTranslatedDataName << "\n"
      << "variable        out index " << p.name << "." << target_code_name(code) << ".csv\n";
    if (p.one_leg() && runs[0].length == LegLength::Known) o << "variable        steps index " << runs[0].steps << "\n";
  }
  o << "read_data       ${data}\n";
  if (program_shears(p)) o << "change_box      all triclinic    # (the shear axes tilt the box)\n";
  o
    << "neighbor        " << num(skin_length(deck)) << " bin\n"
    << "neigh_modify    delay 0 every 1 check yes\n";
}

// What follows the measurements: the control, the series and the runs of every leg.
void program_body(std::ostringstream& o, const Deck& deck, const ScriptProgram& p, TargetCode code,
                  ProgramWriter& w) {
  const bool lmp = code == TargetCode::Lammps;
  if (p.preparation()) unbalanced_force(o, deck, code);
  if (p.one_leg()) {
    w.controls_of_one_leg();
    w.state_stresses();
    output(o, p, code, w.runs()[0].length == LegLength::Known);
    w.end(0);
    return;
  }
  w.state_stresses();
  output(o, p, code, false);
  o << "\n# load program: one block per leg; each removes the previous leg's control fixes and defines its own.\n"
    << "# Strain axes follow celldem's engineering strain against the TEST start exactly, L = L0 (1 - e(leg start) - n d):\n";
  if (lmp)
    o << "# a first leg of known length by erate (its run starts at the test start), other legs by vel V = -L0 d/dt\n"
      << "# (L0 = v_L0k, the test start), which adds -L0 d per step to the box at the leg start.\n";
  else
    o << "# a first leg of known length by erate (one run from the test start), other legs by a fix deform variable\n"
      << "# -L0 d (step - S), S the leg's first step (independent of how the leg's runs are cut into chunks).\n";
  o << "# Stress, b and mean_stress axes: the press/berendsen law " << (lmp ? "(fix press/berendsen for stress axes, a fix\n# deform variable for the others)" : "as a fix deform variable")
    << "; constant-volume axes: fix deform volume (the leg start's volume).\n";
  if (lmp)
    o << "# A leg that ends on an output step writes that step's row twice (the same values: fix print at the end\n"
      << "# of one run and at the start of the next).\n";
  w.program();
  if (p.preparation()) {
    o << "\n# the prepared sample, for the tests: " << (lmp ? "lmp" : "liggghts") << " -in TEST." << target_code_name(code)
      << ".in -var data " << kTranslatedPreparedName << "\n"
      << "write_data      ${prepared}" << (lmp ? " nocoeff" : "") << "\n";
  }
}

std::string lammps_script(const Deck& deck, const ScriptProgram& p) {
  std::ostringstream o;
  ProgramWriter w(o, deck, p, TargetCode::Lammps);
  header(o, deck, p, TargetCode::Lammps, w.runs());
  const LammpsDamping damping = lammps_damping(deck);
  const std::size_t ntypes = atom_types(deck).size();
  o << "units           si\n"
    << "atom_style      sphere\n"
    << "dimension       3\n"
    << "boundary        p p p\n"
    << "newton          off\n"
    << "comm_modify     vel yes\n";
  script_variables(o, deck, p, TargetCode::Lammps, w.runs());
  if (plain_linear(deck.contact)) {
    o << "\n# contact: F_n = kn overlap, incremental tangential spring kt with Coulomb limit, no contact damping\n"
      << "pair_style      gran/hooke/history " << num(deck.contact.kn) << " " << num(deck.contact.kt) << " 0.0 0.0 "
      << num(p.friction) << " 0\n"
      << "pair_coeff      * *\n";
  } else {
    o << "\n# contact: " << law_text(deck.contact) << " as pair granular sub-models, every contact damping "
      << "coefficient 0\n# (the deck's damping is body damping, below). The stored tangential"
      << (deck.contact.rotational_history() ? ", rolling and twisting" : "")
      << " history follows\n# the pairs across neighbour-list rebuilds (pair granular's own fix NEIGH_HISTORY; "
         "it needs comm_modify vel yes).\n"
      << "pair_style      granular\n"
      << "pair_coeff      * * " << lammps_granular_coeffs(deck.contact, p.friction, p.rolling_friction) << "\n";
  }
  o << "timestep        " << num(p.time_step) << "\n"
    << "fix             int all nve/sphere\n";
  if (p.preparation())
    o << "# the pair (contact) forces of each particle, before the damping fixes add theirs: the unbalanced force\n"
      << "fix             sf all store/force\n";
  o << "\n# body damping per type (" << ntypes << " types): c_t = " << num(deck.damping.translational)
    << " * 2 sqrt(m kn) on v, c_r = " << num(deck.damping.rotational) << " * 2 r sqrt(I kt) on omega\n";
  if (!damping.langevin_scale.empty())
    o << "# langevin at T = 0 is a pure drag: F = -m/s v, T = -(10/3) I/s omega; s = (10/3) I / c_r\n"
      << "fix             bdr all langevin 0.0 0.0 1.0 4928459 omega yes" << scales(damping.langevin_scale) << "\n"
      << "# viscous: the rest of c_t, g = c_t - m/s\n";
  if (deck.damping.translational > 0.0 || damping.clamped)
    o << "fix             bdt all viscous 1.0" << scales(damping.viscous_scale) << "\n";
  observation(o, p, TargetCode::Lammps, program_shears(p));
  program_body(o, deck, p, TargetCode::Lammps, w);
  return o.str();
}

std::string liggghts_script(const Deck& deck, const ScriptProgram& p) {
  std::ostringstream o;
  ProgramWriter w(o, deck, p, TargetCode::Liggghts);
  header(o, deck, p, TargetCode::Liggghts, w.runs());
  const std::vector<AtomType> types = atom_types(deck);
  const std::size_t n = types.size();
  o << "units           si\n"
    << "atom_style      granular\n"
    << "atom_modify     map array\n"
    << "boundary        p p p\n"
    << "newton          off\n"
    << "communicate     single vel yes\n";
  script_variables(o, deck, p, TargetCode::Liggghts, w.runs());
  const ContactDef& c = deck.contact;
  const bool rolling = c.rolling == RollingModel::Sds;
  if (c.normal == NormalModel::Hertz) {
    o << "\n# contact: " << law_text(c) << " as LIGGGHTS models: hertz F_n = 4/3 Y* sqrt(R* overlap) overlap, history "
      << "tangential spring\n# 8 G* sqrt(R* overlap) (Mindlin's, no rescaling), Coulomb limit"
      << (rolling ? ", rolling_friction epsd2 (an elastic-plastic torque spring, the closest to sds)" : "")
      << ";\n# coefficientRestitution 1 gives zero damping (beta = ln e / sqrt(ln^2 e + pi^2) = 0)\n";
    // LIGGGHTS refuses youngsModulus outside 5e6-1e9 Pa (SI) unless told.
    if (c.youngs_modulus > 1e9) o << "hard_particles  yes\n";
    if (c.youngs_modulus < 5e6) o << "soft_particles  yes\n";
    o
      << "fix             m1 all property/global youngsModulus peratomtype" << vector_of(n, c.youngs_modulus) << "\n"
      << "fix             m2 all property/global poissonsRatio peratomtype" << vector_of(n, c.poisson_ratio) << "\n"
      << "fix             m3 all property/global coefficientRestitution peratomtypepair " << matrix(n, 1.0) << "\n"
      << "fix             m4 all property/global coefficientFriction peratomtypepair " << matrix(n, p.friction) << "\n";
    if (rolling)
      o << "fix             m5 all property/global coefficientRollingFriction peratomtypepair "
        << matrix(n, p.rolling_friction) << "\n";
    o << "pair_style      gran model hertz tangential history" << (rolling ? " rolling_friction epsd2" : "")
      << " tangential_damping off\n"
      << "pair_coeff      * *\n";
  } else {
    o << "\n# contact: hooke/stiffness F_n = kn overlap (absolute kn), history tangential spring kt, Coulomb limit;\n"
      << "# gamman and gammat must be given (per type pair) even when zero\n"
      << "fix             m1 all property/global kn peratomtypepair " << matrix(n, deck.contact.kn) << "\n"
      << "fix             m2 all property/global kt peratomtypepair "
      << matrix(n, is_mindlin(c.tangential) ? reference_stiffness(c, deck.sample).tangential : c.kt)
      << "\n"
      << "fix             m3 all property/global gamman peratomtypepair " << matrix(n, 0.0) << "\n"
      << "fix             m4 all property/global gammat peratomtypepair " << matrix(n, 0.0) << "\n"
      << "fix             m5 all property/global coefficientFriction peratomtypepair " << matrix(n, p.friction)
      << "\n";
    if (rolling)
      o << "fix             m6 all property/global coefficientRollingFriction peratomtypepair "
        << matrix(n, p.rolling_friction) << "\n";
    o << "pair_style      gran model hooke/stiffness tangential history" << (rolling ? " rolling_friction epsd2" : "")
      << " tangential_damping off\n"
      << "pair_coeff      * *\n";
  }
  o << "timestep        " << num(p.time_step) << "\n"
    << "fix             integr all nve/sphere\n";
  if (p.preparation())
    o << "# the pair (contact) forces of each particle, before the damping fix adds its own: the unbalanced force\n"
      << "fix             sf all store/force\n";
  std::vector<double> ct;
  for (const AtomType& t : types) ct.push_back(t.c_t);
  o << "\n# body damping per type: c_t = " << num(deck.damping.translational)
    << " * 2 sqrt(m kn) on v; no rotational body damping exists in LIGGGHTS\n";
  if (deck.damping.translational > 0.0) o << "fix             bdt all viscous 1.0" << scales(ct) << "\n";
  observation(o, p, TargetCode::Liggghts, program_shears(p));
  program_body(o, deck, p, TargetCode::Liggghts, w);
  return o.str();
}

}  // namespace
}  // namespace translation

using namespace translation;

std::string translate_test(const Deck& deck, const TestDef& test, TargetCode code) {
  const ScriptProgram p = test_program(deck, test);
  return code == TargetCode::Lammps ? lammps_script(deck, p) : liggghts_script(deck, p);
}

std::string translate_preparation(const Deck& deck, TargetCode code) {
  if (!deck.prepare) throw DeckError("prepare: the deck has no preparation to translate");
  const PrepareDef& prep = *deck.prepare;
  const ScriptProgram p{"prepare", prep.legs, prep.friction, prep.output_interval, &prep.equilibrium,
                        prep.rolling_friction, deck.stage_time_step(prep)};
  return code == TargetCode::Lammps ? lammps_script(deck, p) : liggghts_script(deck, p);
}

}  // namespace celldem
