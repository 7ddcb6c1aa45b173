// The catalogue of differences: what LAMMPS or LIGGGHTS cannot express of a deck's physics, its programs and a
// state, and the smaller notes the script headers list.

#include <algorithm>
#include <cstdio>

#include "core/plan.hpp"
#include "io/translate_parts.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace translation {
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
// The servo's pdamp is made from each stage's time step: `time_steps` are the distinct time steps of the stages
// the scripts run (one number when they share it).
void program_differences(const Deck& deck, const ServoDef& servo, const std::vector<double>& time_steps, TargetCode code,
                         const ProgramFeatures& f, std::vector<std::string>& out) {
  const bool lmp = code == TargetCode::Lammps;
  if (f.stress) {
    const TranslatedServo s = translated_servo(deck, time_steps.front());
    const std::string pdamp = time_steps.size() == 1 ? "pdamp " + num(s.pdamp) + " s"
                                                     : "pdamp dt / (3 gain) at each test's own time step";
    out.push_back("servo: celldem's stress servo is proportional-integral with the stiffness measured from the "
                  "contacts each step (gain " + num(deck.servo.gain) + ", integral_gain " +
                  num(deck.servo.integral_gain) + ", cap " +
                  (servo.max_strain_increment_given
                       ? num(servo.max_strain_increment)
                       : "max(" + num(kDefaultServoCap) + ", " + num(kServoCapFactor) + " x each leg's driving strain per step)") +
                  "); " +
                  (lmp ? "fix press/berendsen" : "the fix deform variable servo (the press/berendsen law)") +
                  " is proportional only, with a fixed nominal stiffness (modulus " + num(s.modulus) + " Pa, " + pdamp +
                  ": the same proportional gain at that stiffness) and no cap, so it trails a "
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
    if (key_used(keys::contact_reference_overlap, c.selection())) {
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

// A stage that runs at its own time step (prepare.time_step, tests[].time_step, or a deck resolved by --tolerance).
void time_step_notes(const Deck& deck, const std::vector<double>& time_steps, bool preparation,
                     std::vector<std::string>& out) {
  if (time_steps.size() == 1 && time_steps.front() == deck.time_step) return;
  out.push_back(std::string("per-stage time steps: ") +
                (preparation ? "the preparation runs at its own prepare.time_step"
                             : "each test runs at its own time step (tests[].time_step, else the deck's)") +
                ", as celldem's stages do: each script sets its stage's `timestep` before its first run (one script "
                "runs one stage, so it never changes within a script) and makes from it what celldem makes per step "
                "(fix deform rates of strain increments, increment / dt; the servo's pdamp, dt / (3 gain); the "
                "steps of strain ends; the series' time, steps x dt)");
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

// The distinct time steps of the deck's tests, in order of appearance (the deck's when it has no tests).
std::vector<double> test_time_steps(const Deck& deck) {
  std::vector<double> steps;
  for (const TestDef& t : deck.tests)
    if (std::find(steps.begin(), steps.end(), deck.stage_time_step(t)) == steps.end()) steps.push_back(deck.stage_time_step(t));
  if (steps.empty()) steps.push_back(deck.time_step);
  return steps;
}

}  // namespace
}  // namespace translation

using namespace translation;

std::vector<std::string> model_differences(const Deck& deck, TargetCode code) {
  std::vector<std::string> out = contact_differences(deck, code);
  program_differences(deck, deck.servo, test_time_steps(deck), code, test_features(deck), out);
  if (std::any_of(deck.tests.begin(), deck.tests.end(), [](const TestDef& t) { return t.snapshots.any(); }))
    out.push_back("snapshots (tests[].snapshots): not translated; the scripts write the series only (add a dump "
                  "for particle snapshots)");
  if (std::any_of(deck.tests.begin(), deck.tests.end(), [](const TestDef& t) { return t.verify_rate.has_value(); }))
    out.push_back("rate check (tests[].verify_rate): not translated; the scripts run each test once, at its rate");
  if (std::any_of(deck.tests.begin(), deck.tests.end(), [](const TestDef& t) { return t.probes.has_value(); }))
    out.push_back("probes (tests[].probes): not translated; the scripts run each test's own program only");
  if (std::any_of(deck.tests.begin(), deck.tests.end(), [](const TestDef& t) {
        return std::any_of(t.legs.begin(), t.legs.end(), [](const Leg& leg) { return leg.adaptive.has_value(); });
      }))
    out.push_back("adaptive loading rate (tests[].adaptive_rate): not translated; the scripts run those legs at the "
                  "deck's fixed rate (factor 1)");
  return out;
}

std::vector<std::string> model_notes(const Deck& deck, TargetCode code) {
  std::vector<std::string> out = common_notes(deck, code);
  time_step_notes(deck, test_time_steps(deck), false, out);
  program_notes(code, test_features(deck), out);
  return out;
}

std::vector<std::string> preparation_differences(const Deck& deck, TargetCode code) {
  if (!deck.prepare) throw DeckError("prepare: the deck has no preparation to translate");
  std::vector<std::string> out = contact_differences(deck, code);
  ProgramFeatures f;
  f.add(deck.prepare->legs);
  program_differences(deck, deck.stage_servo(*deck.prepare), {deck.stage_time_step(*deck.prepare)}, code, f, out);
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
  time_step_notes(deck, {deck.stage_time_step(*deck.prepare)}, true, out);
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

}  // namespace celldem
