// celldem summarize: run/summary's definitions applied to any series file (celldem's own or another code's),
// so the tools and their tests never carry a second copy of them.
#include <cstdio>
#include <memory>

#include "app/commands.hpp"
#include "io/series_file.hpp"
#include "run/runner.hpp"
#include "run/summary.hpp"

namespace celldem::app {

Command add_summarize_command(CLI::App& app) {
  struct Args {
    std::string series;
    std::string end_axis = "x1";
  };
  auto a = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "summarize", "Print as JSON what summary.json says of a test that a series alone determines (peak of "
                   "s11/s33 and its plateau, robust peak, peak_reached, the last row, end-window means), for any "
                   "series CSV: celldem's, or a LAMMPS/LIGGGHTS run of a translated deck");
  cmd->add_option("series", a->series, "Series file (CSV with a header of celldem column names)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--end-axis", a->end_axis, "Axis of the test's last end condition (its end window)")
      ->check(CLI::IsMember({"x1", "x2", "x3"}));
  return [cmd, a]() -> int {
    if (!cmd->parsed()) return -1;
    std::vector<SeriesRow> rows;
    try {
      rows = read_series_file(a->series);
    } catch (const SeriesFileError& e) {
      throw UsageError(e.what());
    }
    std::printf("%s\n", nlohmann::json(summarize_series(rows, a->end_axis[1] - '1')).dump(1).c_str());
    return 0;
  };
}

}  // namespace celldem::app
