// The celldem command line: a thin front end over the library. Exit codes: 0 success, 1 run-time error
// (a failed write included: io/files.hpp's IoError), 2 invalid input or usage (deck, state file, arguments, a
// run folder that already holds results), 130 stopped by a signal after writing a checkpoint.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
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

// Every option of every command that takes a value refuses an empty one: CLI11 reads '' as 0 or as "not
// given", so a batch script's unset variable (--tolerance "$T") would run the deck differently without a word.
// Every number option (CLI11's FLOAT type) refuses a value that is not finite: CLI11 reads nan, inf and 1e400
// (as inf), and its range checks let NaN through (each comparison is false). Added after each option's own
// checks, with no description, so the help text is unchanged; the messages name the option (CLI11 prefixes it).
void refuse_empty_and_non_finite_values(CLI::App& app) {
  for (CLI::Option* option : app.get_options()) {
    if (option->get_type_size_max() == 0) continue;  // a flag: no value
    const std::string type = option->get_type_name();
    const bool number = type.rfind("FLOAT", 0) == 0;
    option->check(CLI::Validator(
        [number](const std::string& value) -> std::string {
          if (value.empty()) return "an empty value (an unset variable?): give a value or leave the option out";
          if (!number) return "";
          char* end = nullptr;
          const double x = std::strtod(value.c_str(), &end);
          if (end != value.c_str() && !std::isfinite(x))
            return value + " is not a finite number (nan, inf and numbers beyond 1.8e308 are refused)";
          return "";  // not a number at all: CLI11's own conversion names it
        },
        ""));
  }
  for (CLI::App* command : app.get_subcommands(std::function<bool(CLI::App*)>()))
    refuse_empty_and_non_finite_values(*command);
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
  refuse_empty_and_non_finite_values(app);
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
