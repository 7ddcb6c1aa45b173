// `--tolerance T`: a deck's cost knobs rewritten by the time-to-answer rules, a table of data calibrated by the
// speed-accuracy study (io/time_to_answer_rules.json, compiled into the binary; tools/study.py analyse
// --write-rules writes it) instead of constants in code. T is in noise floors: the error the study measures,
// the mean over seeds of a setting's paired difference from the paper's settings over the seed-to-seed spread.
#pragma once
#include <string>
#include <vector>

#include "core/deck.hpp"

namespace celldem {

// One level of the table: the knobs at a tolerance.
struct ToleranceLevel {
  double tolerance = 0.0;                    // [noise floors]
  double time_step_fraction = 0.0;           // the tests' time step / the stability limit (critical_time_step)
  double prepare_time_step_fraction = 0.0;   // the preparation's
  double inertial_number = 0.0;              // strain-driven test legs: I = rate d_mean sqrt(rho / p)
  double fast_strain_increment_scale = 1.0;  // the preparation's fast (strain-driven) legs: strain per step x this
  double damping_scale = 1.0;                // body damping x this
};

struct ToleranceRules {
  std::vector<ToleranceLevel> levels;  // ascending tolerance, at least one
  // The particle count of the scene the levels were measured on ("particles"; 0: not given). Its floors are
  // sqrt(N / particles) times a deck of N spheres' (floors as 1/sqrt(N): tools/study.py floors, docs/study.md),
  // and a rate's bias does not shrink with N.
  int particles = 0;
};

// T floors of a deck of `particles` spheres in floors of the rules' scene: T sqrt(rules.particles / N) for a
// larger deck (its floors are narrower, the bias the same); T itself for a smaller one (its wider floors are not
// spent: the floor model is measured from 500 spheres up) or where the rules give no count.
double calibration_tolerance(const ToleranceRules& rules, double tolerance, double particles);

// The table as the binary carries it (CMake embeds the file at build time: no file is read at run time).
const std::string& time_to_answer_rules_text();
const ToleranceRules& time_to_answer_rules();
// Parses a table; DeckError naming the entry on a malformed one (levels not ascending, a number not positive).
ToleranceRules parse_tolerance_rules(const std::string& json_text);

// The knobs at `tolerance`: between the two levels around it, each number's logarithm linear in T. Outside
// the table's range a DeckError names `key_path` ("tolerance" or "--tolerance") and the range.
ToleranceLevel interpolate_rules(const ToleranceRules& rules, double tolerance, const std::string& key_path);

// The deck (as written, and its JSON text) rewritten for `tolerance` floors of its own (calibration_tolerance
// carries it to the rules' scene; below their lowest level the deck runs as written, above their largest the
// tolerance is refused) and read again: every stage gets its own
// time step at the level's fraction of the stability limit; each strain-driven test leg the strain rate of the
// level's inertial number at the leg's confining stress (its stress targets, else the test's, else the deck's
// largest), its strain-driven axes scaled together and its step ends kept at their strain; the preparation's
// fast legs their strain per step x the scale; legs without a strain-driven axis keep the physical time of their
// step ends; equilibrium min_steps and check_interval and the preparation's output interval their physical time;
// the tests' output intervals their rows per unit strain; an explicit servo cap rises with the fastest leg's
// strain per step. The result records `tolerance` and, as JSON text, the resolved settings of every stage
// beside the deck's (tolerance_settings). `key_path` names where the tolerance came from.
Deck resolve_tolerance(const Deck& written, const std::string& json_text, double tolerance,
                       const std::string& key_path = "tolerance");

// A resolved deck as its run directory keeps it (resolved_deck.json): the deck celldem ran, which runs again as
// written, with initial_state made absolute (the run directory is elsewhere than the deck).
std::string resolved_deck_json(const Deck& deck);

}  // namespace celldem
