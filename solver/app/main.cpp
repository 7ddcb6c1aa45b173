// The celldem command line: a thin front end over the library. Exit codes: 0 success, 1 run-time error,
// 2 invalid input (deck, state file or arguments), 130 stopped by a signal after writing a checkpoint.
#include <cstdio>
#include <exception>
#include <vector>

#include "app/commands.hpp"
#include "io/deck_reader.hpp"
#include "io/files.hpp"
#include "io/state_file.hpp"
#include "run/runner.hpp"

int main(int argc, char** argv) {
  CLI::App app{"celldem: discrete element simulations of granular element tests in a periodic cell"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "celldem " CELLDEM_VERSION);
  const std::vector<celldem::app::Command> commands = {
      celldem::app::add_run_command(app),
      celldem::app::add_check_command(app),
      celldem::app::add_bench_command(app),
      celldem::app::add_translate_command(app),
      celldem::app::add_schema_command(app),
      celldem::app::add_plan_command(app),
  };
  try {
    app.parse(argc, argv);
    for (const auto& command : commands)
      if (const int rc = command(); rc >= 0) return rc;
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const celldem::DeckError& e) {
    std::fprintf(stderr, "celldem: invalid deck: %s\n", e.what());
    return 2;
  } catch (const celldem::StateFileError& e) {
    std::fprintf(stderr, "celldem: invalid state file: %s\n", e.what());
    return 2;
  } catch (const celldem::IoError& e) {  // before any input error: a failed write is never bad input
    std::fprintf(stderr, "\ncelldem: error: %s\n", e.what());
    return 1;
  } catch (const celldem::Interrupted& e) {
    std::fprintf(stderr, "\ncelldem: %s\n", e.what());
    return 130;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\ncelldem: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
