// Everything that can be checked before a run does any work, beyond what the deck reader checks on its own:
// the cell large enough for its particles, the initial state readable and agreeing with the deck's sample,
// the time step's warnings (its bounds are core/plan's, refused by the deck reader).
// `celldem check` and `celldem run` both call it, so check passes exactly what run accepts.
#pragma once
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/state.hpp"
#include "run/initial_sample.hpp"

namespace celldem {

// Throws DeckError (or StateFileError for an unreadable state) naming the key and both values; returns the
// warnings (printed by the caller, recorded in the summary by a run).
std::vector<std::string> preflight(const Deck& deck);

// What the servo can follow, for `check` to say before a run: the smallest ratio over every leg with a servo
// axis beside a driven one of its cap to its driving strain per step, and where (empty when no leg has both).
// Below kMinServoCapRatio preflight refuses the deck; `plan` lists every leg.
std::string describe_servo_caps(const Deck& deck);

// The stages' time steps and their fractions of the stability limit, for `check`, when some stage has its own
// (prepare.time_step, tests[].time_step); empty otherwise.
std::string describe_stage_time_steps(const Deck& deck);

// Stress ramps and test legs that end in equilibrium, for `check` to say before a run: the fastest ramp (Pa per
// step, where) and the steps a ramp's target takes to its end stress; each equilibrium leg's criterion. Empty
// when the deck has neither.
std::string describe_ramps_and_holds(const Deck& deck);

// A test loaded faster than a packing can follow (more than 1e-4 strain per step, or an inertial number ten times
// the quasi-static limit): "likely cause: <the loading>; otherwise ", which a runaway names before the time step
// (check and run warn of it too); empty otherwise.
std::string fast_loading_cause(const Deck& deck, const TestDef& test);

}  // namespace celldem
