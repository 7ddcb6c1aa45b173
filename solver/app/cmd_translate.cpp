// celldem translate: a deck and a state as LAMMPS or LIGGGHTS input (data file + one script per test; for a
// deck that prepares its own sample also the preparation script and the initial grid sample's data file).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>

#include "app/commands.hpp"
#include "core/plan.hpp"
#include "io/deck_reader.hpp"
#include "io/state_file.hpp"
#include "io/translate.hpp"
#include "run/sample.hpp"

namespace celldem::app {
namespace fs = std::filesystem;

Command add_translate_command(CLI::App& app) {
  struct Args {
    std::string deck, to, state, out;
    bool force = false, no_data = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "translate", "Write LAMMPS or LIGGGHTS input for a deck: a data file with the particles of a state, one "
                   "input script per test (load programs: one block per leg) and, for a deck that prepares its "
                   "sample, the preparation script with the initial grid sample's data file (differences the "
                   "target cannot express are printed as warnings)");
  cmd->add_option("deck", args->deck, "Deck file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--to", args->to, "Target code")->required()->check(CLI::IsMember({"lammps", "liggghts"}));
  cmd->add_option("--state", args->state,
                  "State file for the tests (default: the deck's initial_state; a deck that prepares its sample "
                  "without --state: the tests read the preparation script's prepared.data)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", args->out, "Folder for the data file and the scripts")->required();
  cmd->add_flag("--force", args->force, "Overwrite files already there");
  cmd->add_flag("--no-data", args->no_data, "Write the scripts only (they depend on the deck alone)");
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    if (args->no_data && !args->state.empty()) throw CLI::ValidationError("--no-data and --state exclude each other");
    const Deck deck = read_deck(args->deck);
    if (deck.prepare && deck.initial_state)  // the preparation script starts from celldem's grid sample
      throw DeckError("initial_state: translate writes the preparation from celldem's grid sample, not from a state "
                      "(a deck with both \"prepare\" and \"initial_state\"); translate the run's prepared.state "
                      "with a deck that tests it instead");
    const TargetCode code = parse_target_code(args->to);

    // The files to write, all decided (and checked) before anything is written.
    std::vector<std::pair<fs::path, std::string>> files;
    std::vector<std::string> warnings = model_differences(deck, code);
    const fs::path out(args->out);
    if (!args->no_data) {
      std::string state_path = args->state;
      if (state_path.empty() && deck.initial_state)
        state_path = (fs::path(deck.source).parent_path() / *deck.initial_state).string();
      if (!state_path.empty()) {
        std::string label;
        const State state = read_state(state_path, &label);
        const std::vector<std::string> from_state = state_differences(state, code);
        warnings.insert(warnings.end(), from_state.begin(), from_state.end());
        files.emplace_back(out / kTranslatedDataName, translate_data(deck, state, code, label, from_state));
      }
      if (deck.prepare)  // the preparation starts from celldem's initial grid sample
        files.emplace_back(out / kTranslatedSampleName,
                           translate_data(deck, make_grid_sample(deck.sample, skin_length(deck)), code,
                                          "initial grid sample", {}));
    }
    if (deck.prepare) {
      files.emplace_back(out / preparation_script_name(code), translate_preparation(deck, code));
      // What the preparation adds to the tests' differences (the contact model is the same).
      for (const std::string& w : preparation_differences(deck, code))
        if (std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back("prepare: " + w);
    }
    for (const TestDef& test : deck.tests)
      files.emplace_back(out / script_file_name(test, code), translate_test(deck, test, code));
    if (deck.tests.empty()) warnings.push_back("the deck has no tests: no input script was written");

    if (!args->force) {
      std::string existing;
      for (const auto& [path, _] : files)
        if (fs::exists(path)) existing += (existing.empty() ? "" : ", ") + path.string();
      if (!existing.empty())
        throw std::runtime_error("translate: " + existing + " already exist(s); use --force to overwrite");
    }
    fs::create_directories(out);
    for (const auto& [path, text] : files) {
      std::ofstream file(path, std::ios::binary | std::ios::trunc);
      file << text;
      if (!file.flush()) throw std::runtime_error(path.string() + ": cannot write");
    }

    for (const std::string& w : warnings) std::fprintf(stderr, "celldem translate: warning: %s\n", w.c_str());
    for (const auto& [path, _] : files) std::printf("wrote %s\n", path.string().c_str());
    const std::string exe = code == TargetCode::Lammps ? "lmp" : "liggghts";
    const bool from_prepared = deck.prepare && args->state.empty();
    if (deck.prepare)
      std::printf("run: cd %s && %s -in %s%s\n", out.string().c_str(), exe.c_str(), preparation_script_name(code).c_str(),
                  from_prepared ? "   (writes the prepared sample prepared.data)" : "");
    if (!deck.tests.empty())
      std::printf("run: cd %s && %s -in %s%s\n", out.string().c_str(), exe.c_str(),
                  script_file_name(deck.tests.front(), code).c_str(), from_prepared ? " -var data prepared.data" : "");
    return 0;
  };
}

}  // namespace celldem::app
