// The celldem command line: a thin front end over the library. Exit codes: 0 success, 1 run-time error
// (a failed write included: io/files.hpp's IoError), 2 invalid input or usage (deck, state file, arguments, a
// run folder that already holds results), 130 stopped by a signal after writing a checkpoint.
#include <unistd.h>

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "io/deck_reader.hpp"
#include "io/state_file.hpp"
#include "run/runner.hpp"

namespace {
// "celldem: <kind><message>" on stderr. Errors during a run start on a new line: the progress line may be
// unfinished.
int report_error(bool during_run, const char* kind, const std::exception& e, int exit_code) {
  std::fprintf(stderr, "%scelldem: %s%s\n", during_run ? "\n" : "", kind, e.what());
  return exit_code;
}
}  // namespace

int main(int argc, char** argv) {
  // A log file (a batch job's stdout) gets every line as it is written, so a killed run's log says where it was.
  if (!isatty(STDOUT_FILENO)) std::setvbuf(stdout, nullptr, _IOLBF, 0);
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
      celldem::app::add_summarize_command(app),
      celldem::app::add_merge_command(app),
  };
  try {
    app.parse(argc, argv);
    for (const auto& command : commands)
      if (const int rc = command(); rc >= 0) return rc;
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const celldem::DeckError& e) {
    return report_error(false, "invalid deck: ", e, 2);
  } catch (const celldem::StateFileError& e) {
    return report_error(false, "invalid state file: ", e, 2);
  } catch (const celldem::UsageError& e) {
    return report_error(false, "", e, 2);
  } catch (const celldem::Interrupted& e) {
    return report_error(true, "", e, 130);
  } catch (const std::exception& e) {
    return report_error(true, "error: ", e, 1);
  }
  return 0;
}
