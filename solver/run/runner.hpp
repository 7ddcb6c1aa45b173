// Runs a deck: prepare a sample (or load one), then each loading test from the same prepared state,
// writing series, state files, checkpoints and summary.json into the run directory.
#pragma once
#include "core/deck.hpp"
#include "run/errors.hpp"
#include "run/run_options.hpp"

namespace celldem {

void run_deck(const Deck& deck, const RunOptions& options);

}  // namespace celldem
