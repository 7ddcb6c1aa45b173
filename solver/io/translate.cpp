#include "io/translate.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "cell/control.hpp"
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

// The run of a leg checked while running that the deck does not limit (a solid-fraction end): nominal length.
constexpr std::int64_t kUnboundedSteps = 1000000000;

// What the programs of a script (or of every test of a deck) use, for the differences and notes they imply.
struct ProgramFeatures {
  bool stress = false;   // a stress-driven axis (stress, b, mean_stress)
  bool coupled = false;  // b or mean_stress axes: targets from the measured stresses
  bool volume = false;   // constant-volume axes
  bool halts = false;    // a leg whose end only running tells (ratio, stress, strain of a servo axis, solid fraction)
  bool programs = false; // more than one leg
  void add(const std::vector<Leg>& legs) {
    programs = programs || legs.size() > 1;
    for (const Leg& leg : legs) {
      for (const AxisControl& a : leg.axes) {
        stress = stress || a.stress_driven();
        coupled = coupled || a.mode == AxisMode::B || a.mode == AxisMode::MeanStress;
        volume = volume || a.mode == AxisMode::ConstantVolume;
      }
      const LegEnd& e = leg.end;
      halts = halts || e.kind == LegEndKind::Ratio || e.kind == LegEndKind::Stress ||
              e.kind == LegEndKind::SolidFraction ||
              (e.kind == LegEndKind::Strain && !leg.axes[e.axis].strain_driven());
    }
  }
};

ProgramFeatures test_features(const Deck& d) {
  ProgramFeatures f;
  for (const TestDef& t : d.tests) f.add(t.legs);
  return f;
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

// ---- the contact law in the target codes ----

// The paper's law (linear normal spring, linear tangential history, no rolling or twisting resistance): the
// scripts use gran/hooke/history (LAMMPS) and hooke/stiffness (LIGGGHTS), as they always did. Any other
// composition goes to LAMMPS's pair granular with the matching sub-models, and to LIGGGHTS's closest models.
bool plain_linear(const ContactDef& c) {
  return c.normal == NormalModel::Linear && c.tangential == TangentialModel::LinearHistory &&
         c.rolling == RollingModel::None && c.twisting == TwistingModel::None;
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

// ---- load programs: how each leg runs ----

// What a script translates: a test's program, or the preparation's.
struct ScriptProgram {
  std::string name;                               // the test's name, or "prepare"
  const std::vector<Leg>& legs;
  double friction = 0.0;
  std::int64_t output_interval = 1000;
  const EquilibriumDef* equilibrium = nullptr;    // the preparation only
  double rolling_friction = 0.0;                  // mu_roll (contact.rolling sds)
  bool preparation() const { return equilibrium != nullptr; }
  // The one-leg form of a test: the script of a single leg, as before load programs (`-var steps N`).
  bool one_leg() const { return legs.size() == 1 && !preparation(); }
};

ScriptProgram test_program(const TestDef& test) {
  return {test.name, test.legs, test.friction, test.output_interval, nullptr, test.rolling_friction};
}

// How a leg's length is decided in the script.
enum class LegLength {
  Known,        // run N: a step end, or the strain end of a strain-driven axis whose start strain is known here
  FromStrain,   // the strain end of a strain-driven axis that starts where only the run knows: N at run time
  Halt,         // ratio, stress, the strain of an axis that is not strain-driven, solid fraction: checked running
  Equilibrium,  // the preparation's equilibrium: checked every check_interval steps of the leg
};

struct LegRun {
  LegLength length = LegLength::Known;
  std::int64_t steps = 0;  // Known: the leg's steps (core/plan's leg_steps)
  std::int64_t limit = 0;  // the others: the most steps (0: none)
};

// Each leg's length, following the strains of the strain-driven axes from the program's start (exactly as
// celldem's legs start: e = e(leg start) + n d) for as long as every leg's length is known.
std::vector<LegRun> plan_runs(const Deck& deck, const ScriptProgram& p) {
  std::vector<LegRun> runs;
  std::array<bool, 3> known = {true, true, true};
  std::array<double, 3> strain = {0.0, 0.0, 0.0};
  for (std::size_t j = 0; j < p.legs.size(); ++j) {
    const Leg& leg = p.legs[j];
    const LegEnd& e = leg.end;
    LegRun r;
    if (e.kind == LegEndKind::Steps) {
      r.steps = e.steps;
    } else if (e.kind == LegEndKind::Strain && leg.axes[e.axis].strain_driven()) {
      if (known[e.axis]) {
        const double per_step = leg.strain_per_step(e.axis, deck.time_step);
        if ((e.value - strain[e.axis]) * per_step < 0.0)
          throw DeckError((p.preparation() ? std::string("prepare") : "test \"" + p.name + "\"") + ", leg " +
                          std::to_string(j + 1) + ": axis " + std::string(kAxisNames[e.axis]) +
                          " moves away from its end strain " + num(e.value) + " (it starts the leg at " +
                          num(strain[e.axis]) + ")");
        r.steps = leg_steps(leg, deck.time_step, strain[e.axis]);
      } else {
        r.length = LegLength::FromStrain;
        r.limit = e.max_steps;
      }
    } else if (e.kind == LegEndKind::Equilibrium) {
      r.length = LegLength::Equilibrium;
      r.limit = e.max_steps > 0 ? e.max_steps : p.equilibrium->max_steps;
    } else {
      r.length = LegLength::Halt;
      r.limit = e.max_steps;
    }
    for (int k = 0; k < 3; ++k) {
      known[k] = known[k] && r.length == LegLength::Known && leg.axes[k].strain_driven();
      if (known[k]) strain[k] += static_cast<double>(r.steps) * leg.strain_per_step(k, deck.time_step);
    }
    runs.push_back(r);
  }
  return runs;
}

// The end of a leg as the scripts check it: the value watched (a formula of the state after the step's box
// move and of the step's contact stresses) and whether celldem decides the side at the leg start.
struct EndWatch {
  std::string value;
  bool sided = true;  // reached from the side the leg starts on (a solid fraction: when value >= target)
};

EndWatch end_watch(const Deck& deck, const LegEnd& e) {
  const std::string i = std::to_string(e.axis + 1);
  switch (e.kind) {
    case LegEndKind::Strain: return {"1.0-l" + std::string(kAxisName[e.axis]) + "/v_L0" + i, true};
    case LegEndKind::Ratio: return {"f_obs[4]/f_obs[6]", true};
    case LegEndKind::Stress: return {"f_obs[" + std::to_string(4 + e.axis) + "]", true};
    case LegEndKind::SolidFraction: return {"mass(all)/(" + num(deck.sample.density) + "*vol)", false};
    default: return {"", false};
  }
}

// A number inside a formula (negative ones in parentheses).
std::string lit(double x) {
  if (x >= 0.0) return num(x);
  std::string s = "(";  // built in steps: GCC 12 warns (-Wrestrict) about "(" + num(x) + ")"
  s += num(x);
  s += ')';
  return s;
}

std::string end_text(const Leg& leg, const LegRun& run) {
  const LegEnd& e = leg.end;
  const std::string i = std::to_string(e.axis + 1);
  std::string s;
  switch (e.kind) {
    case LegEndKind::Strain: s = "until e" + i + " = " + num(e.value); break;
    case LegEndKind::Ratio: s = "until s11/s33 = " + num(e.value); break;
    case LegEndKind::Stress: s = "until s" + i + i + " = " + num(e.value) + " Pa"; break;
    case LegEndKind::Steps: s = "for " + std::to_string(e.steps) + " steps"; break;
    case LegEndKind::SolidFraction: s = "until the solid fraction reaches " + num(e.value); break;
    case LegEndKind::Equilibrium: s = "until equilibrium"; break;
  }
  const std::string most = run.limit > 0 ? ", at most " + std::to_string(run.limit) + " steps" : "";
  switch (run.length) {
    case LegLength::Known:
      if (e.kind != LegEndKind::Steps) s += " (" + std::to_string(run.steps) + " steps)";
      break;
    case LegLength::FromStrain: s += " (steps counted at run time from the strain at the leg start" + most + ")"; break;
    case LegLength::Halt: s += " (checked while running" + most + ")"; break;
    case LegLength::Equilibrium: s += " (checked every check_interval steps" + most + ")"; break;
  }
  return s;
}

std::string leg_text(const Leg& leg, const LegRun& run) {
  return "x1 " + axis_text(leg.axes[0]) + ", x2 " + axis_text(leg.axes[1]) + ", x3 " + axis_text(leg.axes[2]) + "; " +
         end_text(leg, run);
}

// celldem's stress_targets() (cell/control.hpp) as formulas of this step's contact stresses c_P[1..3]: the
// target of each stress-driven axis (empty for the others). A mean_stress minor axis beside a b axis is
// referred to by its variable t<tag><axis>.
std::array<std::string, 3> servo_targets(const Leg& leg, const std::string& tag) {
  std::array<std::string, 3> target;
  int major = -1, b_axis = -1, minor = -1, mean_axes = 0;
  double mean = 0.0;
  std::string known;  // the stresses of the axes that are neither mean_stress nor b
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = leg.axes[k];
    if (a.strain_driven()) major = k;
    if (a.mode == AxisMode::B) b_axis = k;
    if (a.mode == AxisMode::Stress || a.mode == AxisMode::MeanStress) minor = k;
    if (a.mode == AxisMode::Stress) target[k] = lit(a.value);
    if (a.mode == AxisMode::MeanStress) {
      ++mean_axes, mean = a.value;
    } else if (a.mode != AxisMode::B) {
      known += (known.empty() ? "" : "+") +
               (a.mode == AxisMode::Stress ? lit(a.value) : "c_P[" + std::to_string(k + 1) + "]");
    }
  }
  if (b_axis >= 0) {
    const double b = leg.axes[b_axis].value;
    const std::string s_major = "c_P[" + std::to_string(major + 1) + "]";
    std::string t_minor = target[minor];
    if (leg.axes[minor].mode == AxisMode::MeanStress) {
      target[minor] = "(" + lit(3.0 * mean) + "-" + lit(1.0 + b) + "*" + s_major + ")/" + lit(2.0 - b);
      t_minor = "v_t" + tag + kAxisName[minor];
    }
    target[b_axis] = t_minor + "+" + lit(b) + "*(" + s_major + "-" + t_minor + ")";
  } else if (mean_axes > 0) {
    for (int k = 0; k < 3; ++k)
      if (leg.axes[k].mode == AxisMode::MeanStress)
        target[k] = "(" + lit(3.0 * mean) + (known.empty() ? "" : "-(" + known + ")") + ")/" + std::to_string(mean_axes);
  }
  return target;
}

bool has_mode(const Leg& leg, AxisMode mode) {
  return std::any_of(leg.axes.begin(), leg.axes.end(), [mode](const AxisControl& a) { return a.mode == mode; });
}

std::string pad(const std::string& command) {
  return command + std::string(command.size() < 16 ? 16 - command.size() : 1, ' ');
}

// Writes the control and the run of each leg.
class ProgramWriter {
 public:
  ProgramWriter(std::ostringstream& o, const Deck& deck, const ScriptProgram& p, TargetCode code)
      : o_(o), deck_(deck), p_(p), lmp_(code == TargetCode::Lammps), runs_(plan_runs(deck, p)) {}

  const std::vector<LegRun>& runs() const { return runs_; }

  // Before the series output is defined: the stresses of the state for the first leg's end (LAMMPS; LIGGGHTS
  // runs 0 steps at the start of each leg it checks while running). fix print would write step 0 twice.
  void state_stresses() {
    const LegEndKind k = p_.legs[0].end.kind;
    if (!lmp_ || runs_[0].length != LegLength::Halt || (k != LegEndKind::Ratio && k != LegEndKind::Stress)) return;
    o_ << "\n# the contact stresses of the state, for the first leg's end condition (a run of 0 steps moves nothing)\n"
       << pad("run") << "0 post no\n";
  }

  // The one-leg form: the leg's controls (the end follows the series output, see end()).
  void controls_of_one_leg() { controls(0); }

  // The load program: one block per leg.
  void program() {
    const std::size_t n = p_.legs.size();
    for (std::size_t j = 0; j < n; ++j) {
      o_ << "\n# ---- leg " << j + 1 << " of " << n << ": " << leg_text(p_.legs[j], runs_[j]) << "\n";
      if (!fixes_.empty()) {
        for (const std::string& f : fixes_) o_ << pad("unfix") << f << "\n";
        fixes_.clear();
      }
      controls(static_cast<int>(j));
      end(static_cast<int>(j));
    }
  }

  // How the leg ends (the one-leg form of a leg of known length ends with `run ${steps}` in output()).
  void end(int j) {
    switch (runs_[j].length) {
      case LegLength::Known:
        if (!p_.one_leg()) o_ << pad("run") << runs_[j].steps << "\n";
        break;
      case LegLength::FromStrain: from_strain(j); break;
      case LegLength::Halt: lmp_ ? halt(j) : chunks(j); break;
      case LegLength::Equilibrium: equilibrium(j); break;
    }
  }

 private:
  std::string tag(int j) const { return p_.one_leg() ? "" : std::to_string(j + 1); }
  // Runs of the leg in chunks, checked between them (LIGGGHTS halts, equilibrium): fix deform must not
  // depend on the run's start then (its variable style does not, erate and vel do).
  bool chunked(int j) const {
    return runs_[j].length == LegLength::Equilibrium || (!lmp_ && runs_[j].length == LegLength::Halt);
  }

  void var(const std::string& name, const std::string& formula) { o_ << pad("variable") << name << " equal " << formula << "\n"; }
  // `variable NAME equal <the formula's value when the script reaches this line>`: LAMMPS $(...) with 17
  // digits; LIGGGHTS has no immediate variables: ${} of a helper (15 significant digits).
  void freeze(const std::string& name, const std::string& formula) {
    if (lmp_) {
      var(name, "$(" + formula + ":%.17g)");
    } else {
      var(name + "_f", formula);
      var(name, "${" + name + "_f}");
    }
  }
  void fail(const std::string& condition, const std::string& message) {
    o_ << pad("if") << "\"" << condition << "\" then \"print 'celldem translate: " << message << "'\" \""
       << (lmp_ ? "quit 1" : "quit") << "\"\n";
  }
  std::string leg_name(int j) const { return p_.one_leg() ? "the test" : "leg " + std::to_string(j + 1); }

  void controls(int j) {
    const Leg& leg = p_.legs[j];
    const std::string t = tag(j);
    const bool volume = has_mode(leg, AxisMode::ConstantVolume);
    // Strain axes by erate in a first leg of known length (L = L0 (1 + rate t), its run starting at the test
    // start). Otherwise LAMMPS uses vel (erate refuses a nominal run longer than the box allows), LIGGGHTS a fix
    // deform variable (independent of how the leg's runs are cut into chunks).
    const bool by_erate = j == 0 && runs_[j].length == LegLength::Known;
    const bool strain_variable = !lmp_ && !by_erate;
    const bool strain_vel = lmp_ && !by_erate;
    const TranslatedServo servo = translated_servo(deck_);
    const std::array<std::string, 3> target = servo_targets(leg, t);
    if (strain_variable || chunked(j)) freeze("S" + t, "step");

    std::string deform, baro, vars;
    bool units_box = false, coupled = false;
    for (int k = 0; k < 3; ++k) {
      const AxisControl& a = leg.axes[k];
      const std::string ax = kAxisName[k], i = std::to_string(k + 1), l0 = "v_L0" + i;
      switch (a.mode) {
        case AxisMode::StrainIncrement:
        case AxisMode::StrainRate: {
          const double rate = engineering_rate(deck_, a);  // [1/s]: L = L0 (1 + rate t) from the test start
          if (rate == 0.0 && !volume) break;                // a fixed axis is left alone
          if (strain_variable) {
            vars += pad("variable") + "d" + t + ax + " equal " + lit(-leg.strain_per_step(k, deck_.time_step)) + "*" +
                    l0 + "*(step-v_S" + t + ")\n" + pad("variable") + "r" + t + ax + " equal " + lit(rate) + "*" + l0 +
                    "\n";
            deform += " " + ax + " variable v_d" + t + ax + " v_r" + t + ax;
          } else if (strain_vel) {
            deform += " " + ax + " vel $(" + lit(rate) + "*" + l0 + ":%.17g)";
            units_box = true;
          } else {
            deform += " " + ax + " erate " + num(rate);
          }
          break;
        }
        case AxisMode::Stress:
          if (lmp_ && !volume) {
            baro += " " + ax + " " + num(a.value) + " " + num(a.value) + " " + num(servo.pdamp);
            break;
          }
          [[fallthrough]];
        case AxisMode::B:
        case AxisMode::MeanStress: {
          std::string goal = target[k];
          if (a.mode != AxisMode::Stress) {
            vars += pad("variable") + "t" + t + ax + " equal " + target[k] + "\n";
            goal = "v_t" + t + ax;
            coupled = true;
          }
          std::string start = l0;  // the box length at the leg start (fix deform variable: L = L_start + d)
          if (j > 0) {
            std::ostringstream f;
            std::swap(f, o_);  // freeze() writes to o_; collect into vars to keep the order
            freeze("Ls" + t + ax, "l" + ax);
            std::swap(f, o_);
            vars += f.str();
            start = "v_Ls" + t + ax;
          }
          vars += pad("variable") + "d" + t + ax + " equal l" + ax + "*(1.0-" + num(deck_.time_step) + "/" +
                  num(servo.pdamp) + "*(" + goal + "-c_P[" + i + "])/" + num(servo.modulus) + ")^(1.0/3.0)-" +
                  start + "\n" + pad("variable") + "r" + t + ax + " equal 0.0\n";
          deform += " " + ax + " variable v_d" + t + ax + " v_r" + t + ax;
          break;
        }
        case AxisMode::ConstantVolume:
          deform += " " + ax + " volume";
          break;
      }
    }
    if (p_.one_leg() && !coupled && !volume) {  // the scripts of one-leg tests, as they were before programs
      if (lmp_) {
        o_ << "\n# control: strain axes by fix deform (remap x: positions follow the box affinely, v is the non-affine\n"
           << "# velocity), stress axes by press/berendsen on the contact stress; a fixed axis is left alone\n";
      } else {
        o_ << "\n# control: strain axes by fix deform erate (remap x); stress axes by the press/berendsen law written as a\n"
           << "# fix deform variable (L = L_start + d): L *= (1 - dt/pdamp (target - s)/modulus)^(1/3) per step,\n"
           << "# celldem's proportional gain " << num(deck_.servo.gain) << " at stiffness " << num(servo.modulus)
           << " Pa\n";
      }
    } else if (p_.one_leg()) {
      o_ << "\n# control: strain axes by fix deform erate (remap x); stress, b and mean_stress axes by the press/berendsen\n"
         << "# law, L *= (1 - dt/pdamp (target - s)/modulus)^(1/3) per step, "
         << (lmp_ ? "fix press/berendsen for a stress axis beside no\n# constant-volume axis, otherwise "
                  : "")
         << "as a fix deform variable (L = L_start + d);\n# constant-volume axes by fix deform volume\n";
    }
    if (coupled)
      o_ << "# b / mean_stress targets from this step's contact stresses, as celldem's stress_targets()\n";
    if (!lmp_ || !vars.empty()) o_ << vars;
    if (!deform.empty()) {
      o_ << pad("fix") << "dfm all deform 1" << deform << " remap x" << (units_box ? " units box" : "") << "\n";
      fixes_.push_back("dfm");
    }
    if (!baro.empty()) {
      o_ << "# per step L *= (1 - dt/pdamp (target - s)/modulus)^(1/3): celldem's proportional gain "
         << num(deck_.servo.gain) << " at stiffness " << num(servo.modulus) << " Pa\n"
         << pad("fix") << "srv all press/berendsen" << baro << " couple none modulus " << num(servo.modulus)
         << " dilate all\n"
         << pad("fix_modify") << "srv press P\n";
      fixes_.push_back("srv");
    }
  }

  // A strain end of a strain-driven axis whose start strain only the run knows: celldem's leg_steps, at run time.
  void from_strain(int j) {
    const Leg& leg = p_.legs[j];
    const LegEnd& e = leg.end;
    const std::string t = tag(j), now = "(" + num(e.value) + "-(" + end_watch(deck_, e).value + "))";
    const double per_step = leg.strain_per_step(e.axis, deck_.time_step);
    o_ << "# the steps to e" << e.axis + 1 << " = " << num(e.value) << " from the strain at the leg start (celldem's leg_steps)\n";
    var("n" + t, "round(" + now + "/" + lit(per_step) + ")");
    var("away" + t, now + "*" + lit(per_step) + "<0.0");
    fail("${away" + t + "}", leg_name(j) + ": axis x" + std::to_string(e.axis + 1) + " moves away from its end strain " +
                                 num(e.value));
    std::string steps = "n" + t;
    if (runs_[j].limit > 0) {
      const std::string m = std::to_string(runs_[j].limit);
      var("m" + t, "v_n" + t + "-(v_n" + t + "-" + m + ")*(v_n" + t + ">" + m + ")");
      steps = "m" + t;
    }
    o_ << pad("run") << "${" << steps << "}\n";
  }

  // LAMMPS: fix halt on the leg's end condition, checked every step.
  void halt(int j) {
    const Leg& leg = p_.legs[j];
    const LegEnd& e = leg.end;
    const EndWatch w = end_watch(deck_, e);
    const std::string t = tag(j);
    const std::int64_t limit = runs_[j].limit > 0 ? runs_[j].limit : kUnboundedSteps;
    o_ << "# the end, checked by fix halt every 1 step (LAMMPS checks halt every N steps, N as set here; 1 is\n"
       << "# celldem's check before every step), after the step's box move; error continue ends the run only\n";
    var("now" + t, w.value);
    if (w.sided) {
      freeze("side" + t, "2*(v_now" + t + "<" + lit(e.value) + ")-1");
      var("end" + t, "v_side" + t + "*(v_now" + t + "-" + lit(e.value) + ")");
    } else {
      var("end" + t, "v_now" + t + "-" + lit(e.value));
    }
    o_ << pad("fix") << "hlt all halt 1 v_end" << t << " >= 0.0 error continue message yes\n";
    fixes_.push_back("hlt");
    o_ << "# celldem checks before each step: a leg whose end holds at its start runs 0 steps\n";
    var("run" + t, "(v_end" + t + "<0.0)*" + std::to_string(limit) + (runs_[j].limit > 0 ? "" : "    # no limit in the deck"));
    o_ << pad("run") << "${run" << t << "}\n";
    if (runs_[j].limit > 0)
      fail("$(v_end" + t + ") < 0.0", leg_name(j) + " did not reach its end condition in " + std::to_string(limit) +
                                          " steps (end.max_steps)");
  }

  // LIGGGHTS (no fix halt): the leg in chunks of kLiggghtsCheckSteps, its end checked before each.
  void chunks(int j) {
    const Leg& leg = p_.legs[j];
    const LegEnd& e = leg.end;
    const EndWatch w = end_watch(deck_, e);
    const std::string t = tag(j), label = "leg" + (t.empty() ? std::string("1") : t);
    o_ << "# the end: LIGGGHTS 3.8 has no fix halt, so the leg runs in chunks of " << kLiggghtsCheckSteps
       << " steps and is checked before each\n# (a run of 0 steps sets the leg's fixes up; the chunks run with pre no)\n"
       << pad("run") << "0 post no\n";
    var("now" + t, w.value);
    if (w.sided) {
      freeze("side" + t, "2*(v_now" + t + "<" + lit(e.value) + ")-1");
      var("done" + t, "v_side" + t + "*(v_now" + t + "-" + lit(e.value) + ")>=0.0");
    } else {
      var("done" + t, "v_now" + t + ">=" + lit(e.value));
    }
    if (runs_[j].limit > 0) var("over" + t, "step-v_S" + t + ">=" + std::to_string(runs_[j].limit));
    o_ << pad("label") << label << "\n"
       << pad("if") << "\"${done" << t << "}\" then \"jump SELF " << label << "_end\"\n";
    if (runs_[j].limit > 0)
      fail("${over" + t + "}", leg_name(j) + " did not reach its end condition in " + std::to_string(runs_[j].limit) +
                                   " steps (end.max_steps)");
    o_ << pad("run") << kLiggghtsCheckSteps << " pre no post no\n"
       << pad("jump") << "SELF " << label << "\n"
       << pad("label") << label << "_end\n";
  }

  // The preparation's equilibrium (measure/quasi_static.hpp): every check_interval steps of the leg, once
  // min_steps are done; the run stops with an error at the limit.
  void equilibrium(int j) {
    const Leg& leg = p_.legs[j];
    const EquilibriumDef& c = *p_.equilibrium;
    const std::string t = tag(j), label = "leg" + t;
    const Vec3 target = stress_targets(leg.axes, Vec3::Zero());  // stress and mean_stress axes only: constants
    const double p = target[0] == target[1] && target[1] == target[2] ? target[0] : target.mean();
    o_ << "# equilibrium, celldem's criterion (prepare.equilibrium): |p - p*|/p* <= " << num(c.pressure_tolerance)
       << ", every |s_kk - t_k|/t_k <= " << num(c.stress_tolerance) << ",\n# unbalanced force ratio <= "
       << num(c.unbalanced_force_ratio) << " (v_ubf), at least one contact; checked every " << c.check_interval
       << " steps of the leg after " << c.min_steps << "\n";
    std::string eq = "(f_obs[7]>0)&&(abs((f_obs[4]+f_obs[5]+f_obs[6])/3-" + num(p) + ")/" + num(p) +
                     "<=" + num(c.pressure_tolerance) + ")";
    for (int k = 0; k < 3; ++k)
      eq += "&&(abs(f_obs[" + std::to_string(4 + k) + "]-" + num(target[k]) + ")/" + num(target[k]) + "<=" +
            num(c.stress_tolerance) + ")";
    eq += "&&(v_ubf<=" + num(c.unbalanced_force_ratio) + ")";
    var("eq" + t, eq);
    var("done" + t, "(step-v_S" + t + ">=" + std::to_string(c.min_steps) + ")&&v_eq" + t);
    var("over" + t, "step-v_S" + t + ">=" + std::to_string(runs_[j].limit));
    o_ << pad("run") << c.check_interval << " post no\n"
       << pad("label") << label << "\n"
       << pad("if") << "\"${done" << t << "}\" then \"jump SELF " << label << "_end\"\n";
    fail("${over" + t + "}", leg_name(j) + " did not reach equilibrium in " + std::to_string(runs_[j].limit) +
                                 " steps; raise prepare.equilibrium.max_steps or relax its tolerances");
    o_ << pad("run") << c.check_interval << " pre no post no\n"
       << pad("jump") << "SELF " << label << "\n"
       << pad("label") << label << "_end\n";
  }

  std::ostringstream& o_;
  const Deck& deck_;
  const ScriptProgram& p_;
  bool lmp_;
  std::vector<LegRun> runs_;
  std::vector<std::string> fixes_;  // the control fixes of the leg now defined
};

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
  o << "# Writes " << series << ": " << kTranslatedSeriesHeader << "\n"
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
  const bool lmp = code == TargetCode::Lammps;
  o << "\n# series (LAMMPS prints step 0 too; LIGGGHTS starts at the first output step)\n";
  if (lmp) {
    o << "fix             out all print " << p.output_interval
      << " \"$(step),$(v_time:%.10g),$(v_e1:%.10g),$(v_e2:%.10g),$(v_e3:%.10g),$(v_ev:%.10g),"
         "$(v_s11:%.10g),$(v_s22:%.10g),$(v_s33:%.10g),$(v_Z:%.10g),$(v_nc:%.0f),$(v_ek:%.10g),"
         "$(v_l1:%.17g),$(v_l2:%.17g),$(v_l3:%.17g)\" file ${out} screen no title \""
      << kTranslatedSeriesHeader << "\"\n";
  } else {
    o << "variable        st equal step\n"
      << "fix             out all print " << p.output_interval
      << " \"${st},${time},${e1},${e2},${e3},${ev},${s11},${s22},${s33},${Z},${nc},${ek},${l1},${l2},${l3}\""
         " file ${out} screen no title \""
      << kTranslatedSeriesHeader << "\"\n";
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
  o << "read_data       ${data}\n"
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
  o << "timestep        " << num(deck.time_step) << "\n"
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
  observation(o, deck, TargetCode::Lammps);
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
  o << "timestep        " << num(deck.time_step) << "\n"
    << "fix             integr all nve/sphere\n";
  if (p.preparation())
    o << "# the pair (contact) forces of each particle, before the damping fix adds its own: the unbalanced force\n"
      << "fix             sf all store/force\n";
  std::vector<double> ct;
  for (const AtomType& t : types) ct.push_back(t.c_t);
  o << "\n# body damping per type: c_t = " << num(deck.damping.translational)
    << " * 2 sqrt(m kn) on v; no rotational body damping exists in LIGGGHTS\n";
  if (deck.damping.translational > 0.0) o << "fix             bdt all viscous 1.0" << scales(ct) << "\n";
  observation(o, deck, TargetCode::Liggghts);
  program_body(o, deck, p, TargetCode::Liggghts, w);
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

TranslatedServo translated_servo(const Deck& deck) {
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
  s.pdamp = deck.time_step / (3.0 * deck.servo.gain);
  return s;
}

namespace {

// What LAMMPS's pair granular does differently from celldem's law (pair_granular.cpp of 2021, read in the source;
// crosscheck/README.md "Other contact laws" has the measured effect). Same in both: hertz/material's
// F = 4/3 E* a d and mindlin's 8 G* a (NULL: LAMMPS's mixing of one material gives E/(2(1 - nu^2)) and
// E/(4(2 - nu)(1 + nu))), mindlin's displacement history without rescaling when a changes (mindlin_rescale's
// scaled by a / a_old when a shrinks, a_old the last step's, kept per pair as LAMMPS's history[3]), the Coulomb cap
// mu |F_n| with the spring set back, the sds rolling velocity R* (w_i - w_j) x n, its spring-dashpot-slider and
// moment R* n x f_r, Marshall's k_tw = 0.5 k_t a^2 and cap 2/3 a mu F_n.
void granular_differences(const Deck& deck, std::vector<std::string>& out) {
  const ContactDef& c = deck.contact;
  out.push_back(std::string("contact.moment_arm: LAMMPS pair granular takes the tangential slip velocity with the "
                            "full radii, (v_i - v_j)_t + n x (r_i w_i + r_j w_j), and the torque of the tangential "
                            "force with the arm r - overlap/2; celldem uses one arm for both (the deck: \"") +
                (c.moment_arm == MomentArm::ContactPoint ? "contact_point\", r - overlap/2: the slip differs"
                                                         : "radius\", r: the torque differs") +
                " by the overlap/2 part, a relative 1e-3-1e-2 of the rotational terms)");
  if (c.rotation == TangentialRotation::Project)
    out.push_back("contact.tangential_rotation: the deck says \"project\"; pair granular brings the tangential "
                  "history into the new tangent plane and restores its length (celldem \"rotate\")");
  out.push_back("tangential frame update: pair granular turns the stored tangential displacement into the tangent "
                "plane only when |xi . n| k_t > 1e-10 mu F_n (celldem: every step); below that the out-of-plane "
                "part stays in the spring");
  if (c.rolling == RollingModel::Sds)
    out.push_back("rolling sds: as celldem's law, except that the rolling displacement is turned into the tangent "
                  "plane (keeping its length) only when |xi_r . n| k_roll > 1e-10 mu_roll F_n (celldem: every "
                  "step)");
  if (c.twisting == TwistingModel::Marshall)
    out.push_back("twisting marshall: at the cap LAMMPS sets the moment to -sign(twist rate) 2/3 a mu F_n and the "
                  "angle to sign(rate) M_crit / k_tw, celldem keeps the sign of the spring moment -k_tw theta "
                  "(they differ only in a step where the twist rate opposes the stored twist while the cap is "
                  "exceeded)");
}

// The closest LIGGGHTS 3.8 models of a law other than the plain linear one, and what they cannot express.
void liggghts_law_differences(const Deck& deck, std::vector<std::string>& out) {
  const ContactDef& c = deck.contact;
  if (c.normal == NormalModel::Hertz && c.tangential == TangentialModel::LinearHistory)
    out.push_back("contact.tangential: the deck says \"linear_history\" (constant kt = " + num(c.kt) +
                  " N/m) with hertz; LIGGGHTS's hertz model always sets the tangential stiffness to Mindlin's "
                  "8 G* sqrt(R* overlap): the scripts use that (celldem \"mindlin\" matches)");
  if (c.tangential == TangentialModel::MindlinRescale)
    out.push_back("contact.tangential: the deck says \"mindlin_rescale\"; LIGGGHTS 3.8 cannot express it (its "
                  "tangential models are history and no_history, neither rescales the stored displacement when the "
                  "contact radius shrinks): the scripts use Mindlin's stiffness without the rescaling (celldem "
                  "\"mindlin\")");
  if (c.normal == NormalModel::Linear && is_mindlin(c.tangential))
    out.push_back("contact.tangential: the deck says \"" + std::string(name_of(c.tangential, kTangentialModelNames)) +
                  "\" (8 G* a, following the contact radius) with a "
                  "linear normal spring; LIGGGHTS's hooke/stiffness takes a constant kt: the scripts use 8 G* a at "
                  "contact.reference_overlap, " + num(reference_stiffness(c, deck.sample).tangential) + " N/m");
  if (c.normal == NormalModel::Hertz)
    out.push_back("hertz: LIGGGHTS's history tangential spring projects the stored displacement onto the new "
                  "tangent plane after adding the step's slip, without restoring its length; its torque arm and "
                  "rotational slip use r - overlap/2 (see contact.moment_arm)");
  if (c.rolling == RollingModel::Sds)
    out.push_back("contact.rolling: LIGGGHTS 3.8 has no sds rolling model; the scripts use rolling_friction epsd2, "
                  "an incremental torque spring on the tangential relative spin capped at mu_roll R* |F_n| (the "
                  "same cap as sds), but with the rotational stiffness k_t R*^2 (k_t the tangential stiffness" +
                  std::string(is_mindlin(c.tangential) ? ", 8 G* a" : "") +
                  ") instead of k_roll R*^2 = " + num(c.rolling_stiffness) + " R*^2, no dashpot (rolling_damping " +
                  num(c.rolling_damping) + " ignored), the stored torque neither turned into the tangent plane nor "
                  "rescaled when k_t changes");
  if (c.twisting == TwistingModel::Marshall)
    out.push_back("contact.twisting: LIGGGHTS 3.8 cannot express twisting resistance at all (no twisting model; "
                  "epsd2 drops the normal part of the relative spin): the scripts run without Marshall's twisting "
                  "moment");
}

// The contact model and the damping: the same in every script of the deck.
std::vector<std::string> contact_differences(const Deck& deck, TargetCode code) {
  const bool lmp = code == TargetCode::Lammps;
  const std::string target = lmp ? "LAMMPS" : "LIGGGHTS";
  std::vector<std::string> out;
  if (deck.kinematics == Kinematics::Affine)
    out.push_back("kinematics: the deck says \"affine\" (contacts see the affine velocity difference of the cell), "
                  "but with fix deform remap x " + target + " contacts see only the non-affine velocities, so the "
                  "affine part of the relative motion never loads the tangential springs (celldem "
                  "\"kinematics\": \"lammps\" matches " + target + ")");
  if (lmp && !plain_linear(deck.contact)) {
    granular_differences(deck, out);
  } else if (!lmp && !plain_linear(deck.contact)) {
    liggghts_law_differences(deck, out);
  }
  if (deck.contact.rotation == TangentialRotation::Rotate && !(lmp && !plain_linear(deck.contact)))
    out.push_back("contact.tangential_rotation: the deck says \"rotate\" (the spring keeps its length when the "
                  "tangent plane turns), " + target + " projects it onto the new plane without restoring the length "
                  "(celldem \"project\")");
  if (lmp && plain_linear(deck.contact) && deck.contact.moment_arm == MomentArm::ContactPoint)
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
  return out;
}

// The controls and the ends of the legs.
void program_differences(const Deck& deck, TargetCode code, const ProgramFeatures& f, std::vector<std::string>& out) {
  const bool lmp = code == TargetCode::Lammps;
  if (f.stress) {
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
  if (f.coupled)
    out.push_back("b and mean_stress axes: their targets are celldem's (stress_targets: s_minor + b (s_major - "
                  "s_minor), with a mean_stress minor axis s_minor = (3p - (1 + b) s_major)/(2 - b); mean_stress "
                  "alone: 3p minus the other axes' stresses), computed each step from the contact stresses c_P, "
                  "and the proportional law of the stress axes moves the box towards them as a fix deform variable. "
                  "Unlike celldem's PI servo it has no integral term and no cap, and its stiffness is the nominal "
                  "modulus: while the major stress rises the targets move and the axes trail them, so b and p are "
                  "held less tightly (compare b and p as each code held them)");
  if (!lmp && f.halts)
    out.push_back("leg ends that only running tells (ratio, stress, the strain of an axis that is not strain-driven, "
                  "solid fraction): LIGGGHTS 3.8 has no fix halt, so such a leg runs in chunks of " +
                  std::to_string(kLiggghtsCheckSteps) + " steps and its end is checked between them: it ends up to " +
                  std::to_string(kLiggghtsCheckSteps - 1) + " steps after celldem's (which checks before every step)");
}

std::vector<std::string> common_notes(const Deck& deck, TargetCode code) {
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
  const ContactDef& c = deck.contact;
  if (!plain_linear(c)) {
    if (c.normal != NormalModel::Linear || c.tangential != TangentialModel::LinearHistory) {
      const ContactStiffness k = reference_stiffness(c, deck.sample);
      out.push_back("body damping constants: kn and kt in 2 sqrt(m kn) and 2 r sqrt(I kt) are the tangent "
                    "stiffnesses at contact.reference_overlap (" + num(c.reference_overlap) + " m: " + num(k.normal) +
                    " and " + num(k.tangential) + " N/m), as celldem's");
    }
    if (lmp)
      out.push_back("pair granular computes as celldem: hertz/material F_n = 4/3 E* a d, mindlin 8 G* a with the "
                    "displacement history not rescaled when a changes (mindlin_rescale: scaled by a / a_old when a "
                    "shrinks, not when it grows), the Coulomb cap with the spring set back, "
                    "sds rolling (velocity R* (w_j - w_i) x n, spring-dashpot-slider, moment R* n x f_r), Marshall "
                    "twisting (0.5 k_t a^2, cap 2/3 a mu F_n); every damping coefficient 0; its histories are not "
                    "incremented in the setup force call of a run (as gran/hooke/history)");
  }
  return out;
}

void program_notes(TargetCode code, const ProgramFeatures& f, std::vector<std::string>& out) {
  const bool lmp = code == TargetCode::Lammps;
  if (f.programs)
    out.push_back("load programs: one block per leg in one script (unfix the previous leg's control fixes, define "
                  "the leg's, run); legs of known length run their steps (core/plan's leg_steps, counted from the "
                  "strain at the leg start, at run time when only the run knows it); strain axes follow celldem's "
                  "engineering strain against the test start exactly (erate in a first leg of known length; other legs " +
                  std::string(lmp ? "fix deform vel -L0 d/dt" : "a fix deform variable -L0 d (step - S)") +
                  " from the box at the leg start)");
  if (f.volume)
    out.push_back("constant_volume axes: fix deform volume holds the volume of the leg start exactly (two such axes "
                  "scale by one common factor, as celldem's); it sees only the axes fix deform moves itself, so " +
                  std::string(lmp ? "a stress axis beside them is servo-controlled by the same fix deform (variable) "
                                    "instead of press/berendsen"
                                  : "every axis of such a leg is in the one fix deform"));
  if (f.halts || f.programs) {
    if (lmp)
      out.push_back("ends checked while running: fix halt every 1 step (LAMMPS checks halt every N steps, N as set "
                    "in the script; 1 is celldem's check before every step) at the end of the step, after the box "
                    "moved, on the stresses of the step's force evaluation (one step behind celldem's, see the box "
                    "lag above); a leg not ended within end.max_steps stops the script with exit status 1 (celldem: "
                    "a run error)");
    else
      out.push_back("a leg not ended within end.max_steps (or whose strain end moves away) stops the script with a "
                    "message and quit, whose exit status is 0 in LIGGGHTS (quit takes no status): check the log");
  }
}

}  // namespace

std::vector<std::string> model_differences(const Deck& deck, TargetCode code) {
  std::vector<std::string> out = contact_differences(deck, code);
  program_differences(deck, code, test_features(deck), out);
  if (std::any_of(deck.tests.begin(), deck.tests.end(), [](const TestDef& t) { return t.snapshots.any(); }))
    out.push_back("snapshots (tests[].snapshots): not translated; the scripts write the series only (add a dump "
                  "for particle snapshots)");
  return out;
}

std::vector<std::string> model_notes(const Deck& deck, TargetCode code) {
  std::vector<std::string> out = common_notes(deck, code);
  program_notes(code, test_features(deck), out);
  return out;
}

std::vector<std::string> preparation_differences(const Deck& deck, TargetCode code) {
  if (!deck.prepare) throw DeckError("prepare: the deck has no preparation to translate");
  std::vector<std::string> out = contact_differences(deck, code);
  ProgramFeatures f;
  f.add(deck.prepare->legs);
  program_differences(deck, code, f, out);
  if (deck.prepare->snapshots.any())
    out.push_back("snapshots (prepare.snapshots): not translated; the script writes the series only (add a dump "
                  "for particle snapshots)");
  if (code == TargetCode::Liggghts && deck.contact.normal == NormalModel::Hertz &&
      deck.prepare->equilibrium.unbalanced_force_ratio > 0.0)
    out.push_back("equilibrium (hertz): LIGGGHTS cannot sum the contacts' Hertz forces, so the unbalanced force "
                  "ratio's mean normal force is estimated as (s11 + s22 + s33) V / (contacts x the mean diameter), "
                  "exact only when every branch has the mean length");
  if (deck.prepare->friction > 0.0)
    out.push_back("prepare.friction = " + num(deck.prepare->friction) + ": write_data cannot carry the contact "
                  "history, so tests from the prepared data file start with zero tangential springs (celldem's "
                  "prepared.state keeps them)");
  return out;
}

std::vector<std::string> preparation_notes(const Deck& deck, TargetCode code) {
  if (!deck.prepare) throw DeckError("prepare: the deck has no preparation to translate");
  const bool lmp = code == TargetCode::Lammps;
  std::vector<std::string> out = common_notes(deck, code);
  ProgramFeatures f;
  f.add(deck.prepare->legs);
  f.programs = true;
  program_notes(code, f, out);
  out.push_back("the data file holds celldem's initial grid sample (make_grid_sample: the same sizes, positions and "
                "zero velocities), but a preparation is chaotic, so the prepared samples differ in detail; for "
                "code-to-code comparisons of tests prepare with celldem and translate with --state");
  out.push_back(std::string("equilibrium: celldem's criterion, checked every check_interval steps of the leg once "
                            "min_steps are done: |p - p*|/p*, every |s_kk - t_k|/t_k and the unbalanced force ratio "
                            "= mean |net contact force| over the particles (fix store/force before the damping "
                            "fixes: the pair forces only) / mean contact normal force (") +
                (lmp ? "compute pair/local force" : "kn times the sum of the overlaps of compute pair/gran/local delta, "
                                                    "exact for hooke/stiffness without damping") +
                "), with at least one contact: the same number as celldem's on the same state (checked to 1e-10 on a "
                "300-sphere state" + (lmp ? "" : " on one rank") + ")");
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
  const ScriptProgram p = test_program(test);
  return code == TargetCode::Lammps ? lammps_script(deck, p) : liggghts_script(deck, p);
}

std::string translate_preparation(const Deck& deck, TargetCode code) {
  if (!deck.prepare) throw DeckError("prepare: the deck has no preparation to translate");
  const PrepareDef& prep = *deck.prepare;
  const ScriptProgram p{"prepare", prep.legs, prep.friction, prep.output_interval, &prep.equilibrium,
                        prep.rolling_friction};
  return code == TargetCode::Lammps ? lammps_script(deck, p) : liggghts_script(deck, p);
}

}  // namespace celldem
