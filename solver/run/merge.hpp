// Gathering a run split over jobs (a job array on a cluster): the probes of `celldem run --probes K-L` jobs, each
// in its own run folder of the same deck, and the seeds of `celldem run --seeds k-k` jobs, into one folder whose
// tables are then recomputed from what it holds (probes.csv, stiffness.json and summary.json's probes; the
// ensemble's ensemble.json).
#pragma once
#include <filesystem>
#include <string>
#include <vector>

namespace celldem {

// Merges `from` into `into` and recomputes its tables; returns what it did, a line per change. An ensemble (seed-<k>
// folders in either): the seeds `into` lacks are copied, the probes of a seed both hold are gathered as below, and
// ensemble.json is written over every complete seed. A run: the probe folders of each test's points that `into`
// lacks are copied from the runs of the same deck (the deck recorded in progress.json) whose point states are the
// same bytes. Throws UsageError naming both folders, before anything is copied, for a folder of another deck (the
// deck's fingerprint, progress.json) or of another kind (seed shares into a run folder, a run among seed shares), a
// point whose states differ, or a folder that is not a run. `incomplete` (if given) is set when a share or seed is
// not complete (left out).
std::vector<std::string> merge_runs(const std::filesystem::path& into, const std::vector<std::filesystem::path>& from,
                                    bool include_uncontrolled = false, bool* incomplete = nullptr);

}  // namespace celldem
