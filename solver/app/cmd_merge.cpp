#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "run/merge.hpp"

namespace celldem::app {

Command add_merge_command(CLI::App& app) {
  struct Args {
    std::string into;
    std::vector<std::string> from;
    bool include_uncontrolled = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand(
      "merge",
      "Gather a run split over jobs into DIR and recompute its tables: the probes of `run --probes K-L` jobs (each "
      "its own run folder of the same deck) and the seeds of `run --seeds k-k` jobs (DIR/ensemble.json over every "
      "complete seed-<k>/)");
  cmd->add_option("dir", args->into, "The folder to gather into (a run folder, or an ensemble folder)")->required();
  cmd->add_option("from", args->from, "The other jobs' folders")->check(CLI::ExistingDirectory);
  cmd->add_flag("--include-uncontrolled", args->include_uncontrolled,
                "Keep tests whose control failed in the ensemble statistics (left out by default)");
  return [cmd, args]() -> int {
    if (!cmd->parsed()) return -1;
    std::vector<std::filesystem::path> from(args->from.begin(), args->from.end());
    bool incomplete = false;
    for (const std::string& line : merge_runs(args->into, from, args->include_uncontrolled, &incomplete))
      std::printf("%s\n", line.c_str());
    if (incomplete) {  // gathered what was whole; the job array is not done
      std::fprintf(stderr, "celldem: merge: a share is not complete (above): its results are left out; resume it "
                   "(celldem run ... --resume) and merge again\n");
      return 1;
    }
    return 0;
  };
}

}  // namespace celldem::app
