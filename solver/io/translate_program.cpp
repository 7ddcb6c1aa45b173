// The load-program writer: how each leg of a script runs (its control fixes, its length, its end).

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "cell/control.hpp"
#include "core/plan.hpp"
#include "io/translate_parts.hpp"

namespace celldem::translation {
namespace {

// The run of a leg checked while running that the deck does not limit (a solid-fraction end): nominal length.
constexpr std::int64_t kUnboundedSteps = 1000000000;

// fix deform erate [1/s] of a strain-controlled axis (compression positive in the deck, L = L0 (1 + erate t)).
double engineering_rate(const AxisControl& a, double time_step) {
  return a.mode == AxisMode::StrainRate ? -a.value : -a.value / time_step;
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
    case LegEndKind::Strain:
      if (is_shear_component(e.axis)) {  // g_ij = -(tilt - tilt(test start)) / L_j(test start), as the series' g_ij
        static constexpr const char* kTilt[3] = {"xy", "xz", "yz"};
        const int a = e.axis - 3;
        return {"-(" + std::string(kTilt[a]) + "-v_T0" + kTilt[a] + ")/v_L0" + std::to_string(kShearAxisEntries[a][1] + 1),
                true};
      }
      return {"1.0-l" + std::string(kAxisName[e.axis]) + "/v_L0" + i, true};
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

// celldem's stress_targets() (cell/control.hpp) as formulas of this step's contact stresses c_P[1..3]: the
// target of each stress-driven axis (empty for the others). A mean_stress minor axis beside a b axis is
// referred to by its variable t<tag><axis>. A stress_ramp target moves with the steps since the leg start v_S<tag>
// (celldem aims each step at the target of the step's end; LAMMPS evaluates the variable during the step).
std::array<std::string, 3> servo_targets(const Leg& leg, const std::string& tag, double time_step) {
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
    if (a.mode == AxisMode::StressRamp)
      target[k] = "(" + lit(a.value) + "+" + lit(a.rate * time_step) + "*(step-v_S" + tag + "))";
    if (a.mode == AxisMode::MeanStress) {
      ++mean_axes, mean = a.value;
    } else if (a.mode != AxisMode::B) {
      known += std::string(known.empty() ? "" : "+") +
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

}  // namespace

bool program_shears(const ScriptProgram& p) {
  for (const Leg& leg : p.legs)
    for (int a = 0; a < 3; ++a)
      if (leg.strain_per_step(3 + a, 1.0) != 0.0) return true;
  return false;
}

ScriptProgram test_program(const Deck& deck, const TestDef& test) {
  return {test.name, test.legs, test.friction, test.output_interval, nullptr, test.rolling_friction,
          deck.stage_time_step(test)};
}

// Each leg's length, following the strains of the strain-driven axes from the program's start (exactly as
// celldem's legs start: e = e(leg start) + n d) for as long as every leg's length is known.
std::vector<LegRun> plan_runs(const Deck& /*deck*/, const ScriptProgram& p) {
  std::vector<LegRun> runs;
  std::array<bool, kComponents> known = {true, true, true, true, true, true};
  std::array<double, kComponents> strain = {};
  for (std::size_t j = 0; j < p.legs.size(); ++j) {
    const Leg& leg = p.legs[j];
    const LegEnd& e = leg.end;
    // A shear stress axis has no counterpart in the scripts (fix deform drives a tilt, no barostat holds one
    // at a shear stress here); a strain-driven one is fix deform's tilt (controls()).
    for (int a = 0; a < 3; ++a)
      if (leg.axes[3 + a].stress_driven())
        throw DeckError((p.preparation() ? std::string("prepare") : "test \"" + p.name + "\"") + ", leg " +
                        std::to_string(j + 1) + ": axes." + std::string(kShearAxisNames[a]) +
                        " (a stress-controlled shear axis: zero_shear_stress, rotate_principal_axes too) is not translated: the scripts "
                        "drive a tilt only by its strain");
    LegRun r;
    if (e.kind == LegEndKind::Steps) {
      r.steps = e.steps;
    } else if (e.kind == LegEndKind::Strain && leg.axes[static_cast<std::size_t>(e.axis)].strain_driven()) {
      if (known[e.axis]) {
        const double per_step = leg.strain_per_step(e.axis, p.time_step);
        if ((e.value - strain[e.axis]) * per_step < 0.0)
          throw DeckError((p.preparation() ? std::string("prepare") : "test \"" + p.name + "\"") + ", leg " +
                          std::to_string(j + 1) + ": axis " + std::string(kComponentNames[e.axis]) +
                          " moves away from its end strain " + num(e.value) + " (it starts the leg at " +
                          num(strain[e.axis]) + ")");
        r.steps = leg_steps(leg, p.time_step, strain[e.axis]);
      } else {
        r.length = LegLength::FromStrain;
        r.limit = e.max_steps;
      }
    } else if (e.kind == LegEndKind::Equilibrium) {
      if (!p.preparation())  // its unbalanced force ratio is measured by the preparation's script only
        throw DeckError("test \"" + p.name + "\", leg " + std::to_string(j + 1) +
                        ": end.equilibrium (a test leg that ends in equilibrium) is not translated; end the leg on "
                        "steps to translate the test");
      r.length = LegLength::Equilibrium;
      r.limit = e.max_steps > 0 ? e.max_steps : p.equilibrium->max_steps;
    } else {
      r.length = LegLength::Halt;
      r.limit = e.max_steps;
    }
    for (int k = 0; k < kComponents; ++k) {
      // A component the leg drives moves n d; a shear axis the leg does not name keeps its tilt; the rest: unknown.
      const AxisControl& a = leg.axes[static_cast<std::size_t>(k)];
      known[k] = known[k] && r.length == LegLength::Known && (a.strain_driven() || a.mode == AxisMode::Held);
      if (known[k]) strain[k] += static_cast<double>(r.steps) * leg.strain_per_step(k, p.time_step);
    }
    runs.push_back(r);
  }
  return runs;
}

std::string end_text(const Leg& leg, const LegRun& run) {
  const LegEnd& e = leg.end;
  const std::string i = std::to_string(e.axis + 1);
  std::string s;
  switch (e.kind) {
    case LegEndKind::Strain:
      s = is_shear_component(e.axis) ? "until g" + std::string(kComponentNames[e.axis]).substr(1) + " = " + num(e.value)
                                     : "until e" + i + " = " + num(e.value);
      break;
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

ProgramWriter::ProgramWriter(std::ostringstream& o, const Deck& deck, const ScriptProgram& p, TargetCode code)
    : o_(o), deck_(deck), p_(p), lmp_(code == TargetCode::Lammps), runs_(plan_runs(deck, p)) {}

const std::vector<LegRun>& ProgramWriter::runs() const { return runs_; }

// Before the series output is defined: the stresses of the state for the first leg's end (LAMMPS; LIGGGHTS
// runs 0 steps at the start of each leg it checks while running). fix print would write step 0 twice.
void ProgramWriter::state_stresses() {
  const LegEndKind k = p_.legs[0].end.kind;
  if (!lmp_ || runs_[0].length != LegLength::Halt || (k != LegEndKind::Ratio && k != LegEndKind::Stress)) return;
  o_ << "\n# the contact stresses of the state, for the first leg's end condition (a run of 0 steps moves nothing)\n"
     << pad("run") << "0 post no\n";
}

// The one-leg form: the leg's controls (the end follows the series output, see end()).
void ProgramWriter::controls_of_one_leg() { controls(0); }

// The load program: one block per leg.
void ProgramWriter::program() {
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
void ProgramWriter::end(int j) {
  switch (runs_[j].length) {
    case LegLength::Known:
      if (!p_.one_leg()) o_ << pad("run") << runs_[j].steps << "\n";
      break;
    case LegLength::FromStrain: from_strain(j); break;
    case LegLength::Halt: lmp_ ? halt(j) : chunks(j); break;
    case LegLength::Equilibrium: equilibrium(j); break;
  }
}

std::string ProgramWriter::tag(int j) const { return p_.one_leg() ? "" : std::to_string(j + 1); }
// Runs of the leg in chunks, checked between them (LIGGGHTS halts, equilibrium): fix deform must not
// depend on the run's start then (its variable style does not, erate and vel do).
bool ProgramWriter::chunked(int j) const {
  return runs_[j].length == LegLength::Equilibrium || (!lmp_ && runs_[j].length == LegLength::Halt);
}

void ProgramWriter::var(const std::string& name, const std::string& formula) { o_ << pad("variable") << name << " equal " << formula << "\n"; }
// `variable NAME equal <the formula's value when the script reaches this line>`: LAMMPS $(...) with 17
// digits; LIGGGHTS has no immediate variables: ${} of a helper (15 significant digits).
void ProgramWriter::freeze(const std::string& name, const std::string& formula) {
  if (lmp_) {
    var(name, "$(" + formula + ":%.17g)");
  } else {
    var(name + "_f", formula);
    var(name, "${" + name + "_f}");
  }
}
void ProgramWriter::fail(const std::string& condition, const std::string& message) {
  o_ << pad("if") << "\"" << condition << "\" then \"print 'celldem translate: " << message << "'\" \""
     << (lmp_ ? "quit 1" : "quit") << "\"\n";
}
std::string ProgramWriter::leg_name(int j) const { return p_.one_leg() ? "the test" : "leg " + std::to_string(j + 1); }

void ProgramWriter::controls(int j) {
  const Leg& leg = p_.legs[j];
  const std::string t = tag(j);
  const bool volume = has_mode(leg, AxisMode::ConstantVolume);
  const bool triclinic = program_shears(p_);  // the box is made triclinic (shear axes driven by their strain)
  // Strain axes by erate in a first leg of known length (L = L0 (1 + rate t), its run starting at the test
  // start). Otherwise LAMMPS uses vel (erate refuses a nominal run longer than the box allows), LIGGGHTS a fix
  // deform variable (independent of how the leg's runs are cut into chunks).
  const bool by_erate = j == 0 && runs_[j].length == LegLength::Known;
  const bool strain_variable = !lmp_ && !by_erate;
  const bool strain_vel = lmp_ && !by_erate;
  const TranslatedServo servo = translated_servo(deck_, p_.time_step);
  const std::array<std::string, 3> target = servo_targets(leg, t, p_.time_step);
  const bool ramp = has_mode(leg, AxisMode::StressRamp);
  if (strain_variable || chunked(j) || ramp) freeze("S" + t, "step");

  std::string deform, baro, vars;
  bool units_box = false, coupled = false;
  for (int k = 0; k < 3; ++k) {
    const AxisControl& a = leg.axes[k];
    const std::string ax = kAxisName[k], i = std::to_string(k + 1), l0 = "v_L0" + i;
    switch (a.mode) {
      case AxisMode::StrainIncrement:
      case AxisMode::StrainRate: {
        const double rate = engineering_rate(a, p_.time_step);  // [1/s]: L = L0 (1 + rate t) from the test start
        if (rate == 0.0 && !volume) break;                // a fixed axis is left alone
        if (strain_variable) {
          vars += pad("variable") + "d" + t + ax + " equal " + lit(-leg.strain_per_step(k, p_.time_step)) + "*" +
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
        if (lmp_ && !volume && !triclinic) {  // (fix press/berendsen refuses a triclinic box)
          baro += " " + ax + " " + num(a.value) + " " + num(a.value) + " " + num(servo.pdamp);
          break;
        }
        [[fallthrough]];
      case AxisMode::StressRamp:  // a moving target: the press/berendsen law as a fix deform variable
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
        vars += pad("variable") + "d" + t + ax + " equal l" + ax + "*(1.0-" + num(p_.time_step) + "/" +
                num(servo.pdamp) + "*(" + goal + "-c_P[" + i + "])/" + num(servo.modulus) + ")^(1.0/3.0)-" +
                start + "\n" + pad("variable") + "r" + t + ax + " equal 0.0\n";
        deform += " " + ax + " variable v_d" + t + ax + " v_r" + t + ax;
        break;
      }
      case AxisMode::ConstantVolume:
        deform += " " + ax + " volume";
        break;
      case AxisMode::Held:  // (a shear axis's mode: the normal axes are always named)
        break;
    }
  }
  tilt_deform(j, by_erate, deform, units_box);
  control_comments(servo.modulus, coupled, volume);
  if (coupled && !ramp)
    o_ << "# b / mean_stress targets from this step's contact stresses, as celldem's stress_targets()\n";
  if (ramp)
    o_ << "# stress_ramp targets: from + rate dt (steps since the leg start), as celldem's stress_targets()\n";
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

// Strain-driven shear axes: fix deform's tilt (the box made triclinic after read_data), added to `deform`.
void ProgramWriter::tilt_deform(int j, bool by_erate, std::string& deform, bool& units_box) {
  // celldem's tilt is h_ij = h_ij(test start) - L_j(test start) g_ij, LAMMPS's erate T = T0 + L0 erate t with L0
  // the perpendicular length at the run's start: erate = -dg/dt in a first leg of known length (its run starts at the test start),
  // else vel V = -L_j(test start) dg/dt, which adds the same per step from the tilt at the leg start.
  const Leg& leg = p_.legs[j];
  for (int a = 0; a < 3; ++a) {
    const double per_step = leg.strain_per_step(3 + a, p_.time_step);
    if (per_step == 0.0) continue;
    static constexpr const char* kTilt[3] = {"xy", "xz", "yz"};
    const double rate = -per_step / p_.time_step;  // [1/s] d(tilt)/dt over L_j
    const std::string l0 = "v_L0" + std::to_string(kShearAxisEntries[a][1] + 1);
    if (by_erate) {
      deform += std::string(" ") + kTilt[a] + " erate " + num(rate);
    } else if (lmp_) {
      deform += std::string(" ") + kTilt[a] + " vel $(" + lit(rate) + "*" + l0 + ":%.17g)";
      units_box = true;
    } else {
      throw DeckError("test \"" + p_.name + "\", leg " + std::to_string(j + 1) + ": axes." +
                      std::string(kShearAxisNames[a]) + " is translated for LIGGGHTS only in a first leg of known "
                      "length (its fix deform has no variable style for a tilt)");
    }
  }
}

// What the control lines of a one-leg test say they do (the scripts of one-leg tests, as they were before programs).
void ProgramWriter::control_comments(double modulus, bool coupled, bool volume) {
  if (p_.one_leg() && !coupled && !volume) {  // the scripts of one-leg tests, as they were before programs
    if (lmp_) {
      o_ << "\n# control: strain axes by fix deform (remap x: positions follow the box affinely, v is the non-affine\n"
         << "# velocity), stress axes by press/berendsen on the contact stress; a fixed axis is left alone\n";
    } else {
      o_ << "\n# control: strain axes by fix deform erate (remap x); stress axes by the press/berendsen law written as a\n"
         << "# fix deform variable (L = L_start + d): L *= (1 - dt/pdamp (target - s)/modulus)^(1/3) per step,\n"
         << "# celldem's proportional gain " << num(deck_.servo.gain) << " at stiffness " << num(modulus)
         << " Pa\n";
    }
  } else if (p_.one_leg()) {
    o_ << "\n# control: strain axes by fix deform erate (remap x); stress, b and mean_stress axes by the press/berendsen\n"
       << "# law, L *= (1 - dt/pdamp (target - s)/modulus)^(1/3) per step, "
       << (lmp_ ? "fix press/berendsen for a stress axis beside no\n# constant-volume axis, otherwise "
                : "")
       << "as a fix deform variable (L = L_start + d);\n# constant-volume axes by fix deform volume\n";
  }
}

// A strain end of a strain-driven axis whose start strain only the run knows: celldem's leg_steps, at run time.
void ProgramWriter::from_strain(int j) {
  const Leg& leg = p_.legs[j];
  const LegEnd& e = leg.end;
  const std::string t = tag(j), now = std::string("(") + num(e.value) + "-(" + end_watch(deck_, e).value + "))";
  const bool shear = is_shear_component(e.axis);
  std::string name = shear ? "g" : "e";
  name.append(shear ? std::string(kComponentNames[e.axis]).substr(1) : std::to_string(e.axis + 1));
  const double per_step = leg.end_strain_per_step(p_.time_step);
  o_ << "# the steps to " << name << " = " << num(e.value) << " from the strain at the leg start (celldem's leg_steps)\n";
  var("n" + t, "round(" + now + "/" + lit(per_step) + ")");
  var("away" + t, now + "*" + lit(per_step) + "<0.0");
  fail("${away" + t + "}", leg_name(j) + ": axis " +
                               std::string(kComponentNames[e.axis]) +
                               " moves away from its end strain " + num(e.value));
  std::string steps = "n" + t;
  if (runs_[j].limit > 0) {
    const std::string m = std::to_string(runs_[j].limit);
    var("m" + t, "v_n" + t + "-(v_n" + t + "-" + m + ")*(v_n" + t + ">" + m + ")");
    steps = "m" + t;
  }
  o_ << pad("run") << "${" << steps << "}\n";
}

// LAMMPS: fix halt on the leg's end condition, checked every step.
void ProgramWriter::halt(int j) {
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
void ProgramWriter::chunks(int j) {
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
void ProgramWriter::equilibrium(int j) {
  const Leg& leg = p_.legs[j];
  const EquilibriumDef& c = *p_.equilibrium;
  const std::string t = tag(j), label = "leg" + t;
  const Vec3 target = stress_targets(leg.axes, Vec3::Zero(), 0.0);  // stress and mean_stress axes only: constants
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

}  // namespace celldem::translation
