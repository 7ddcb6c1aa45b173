// Each subcommand lives in its own file and registers itself on the CLI11 app. The returned function runs
// the subcommand when it was chosen; it returns the exit code and lets exceptions reach main().
#pragma once
#include <CLI/CLI.hpp>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "core/deck.hpp"

namespace celldem::app {

using Command = std::function<int()>;

Command add_run_command(CLI::App& app);    // celldem run
Command add_check_command(CLI::App& app);  // celldem check
Command add_bench_command(CLI::App& app);  // celldem bench
Command add_translate_command(CLI::App& app);  // celldem translate
Command add_schema_command(CLI::App& app);     // celldem schema
Command add_plan_command(CLI::App& app);       // celldem plan
Command add_summarize_command(CLI::App& app);  // celldem summarize
Command add_merge_command(CLI::App& app);      // celldem merge

// One line on what a run of the deck costs: memory, steps and time (core/plan's estimate_run); a preparation
// from initial_state starts at start_solid_fraction (run/sample preparation_start; negative: none).
std::string describe_estimate(const Deck& deck, double start_solid_fraction = -1.0);

// What --tolerance did (io/tolerance's resolved settings per stage) and the particle-steps each stage is predicted
// to take, against the deck as written and the ratio (`plan --json`'s "tolerance", summary.json's "tolerance").
nlohmann::json tolerance_json(const Deck& written, const Deck& resolved);
// Its words in one line: the tolerance, the rules' settings and the predicted saving (`run` prints it).
std::string describe_tolerance(const nlohmann::json& tolerance);

}  // namespace celldem::app
