// Seed ensembles: the same deck prepared from several seeds (sample sizes and jitter), every test run on
// each sample, and the statistics of every summary quantity over the seeds: how sure each number is.
#pragma once
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "run/run_options.hpp"

namespace celldem {

// "1-8", "1,3,5", "1-4,10": the seeds, in order, without repeats. Throws DeckError on a malformed list, and on a
// single seed unless allow_one (a share of a job array, gathered by `celldem merge`).
std::vector<std::uint64_t> parse_seed_list(const std::string& text, bool allow_one = false);

// Runs the deck once per seed into DIR/seed-<k>/ (each a run directory of its own: --resume continues each
// where it stopped, a finished one is kept) and writes DIR/ensemble.json (not for a single seed: a share). Tests whose control failed are
// left out of the statistics unless include_uncontrolled; what was left out is printed on stderr.
void run_ensemble(const Deck& deck, const RunOptions& options, const std::vector<std::uint64_t>& seeds,
                  bool include_uncontrolled = false);

// Writes DIR/ensemble.json (ensemble_statistics) from the seeds' summaries and prints, quiet or not, what it left
// out (uncontrolled tests, peaks not reached): a mean over fewer seeds must be seen.
void write_ensemble(const std::filesystem::path& dir, const std::vector<std::uint64_t>& seeds,
                    const std::vector<nlohmann::json>& summaries, bool include_uncontrolled, bool quiet);

// The p-quantile of Student's t with dof degrees of freedom (Boost.Math).
double student_t_quantile(double p, double dof);

// Mean, standard deviation, standard error, the 95 % interval of the mean (ci95, mean -+ t(0.975, n-1) sem)
// and the 95 % prediction interval of one more sample (pi95, mean -+ t(0.975, n-1) std sqrt(1 + 1/n)) of the
// values; {"n": 0} when there are none.
nlohmann::json describe(const std::vector<double>& values);

// ensemble.json from the per-seed summaries: per test (and for the prepared sample) and per numeric
// quantity, describe() over the seeds; "paired": per pair of tests, the per-seed differences (B - A).
// A test with "controlled": false is left out (unless include_uncontrolled), a test with "peak_reached":
// false keeps all but its peak quantities (any path with "peak" in it); "excluded" lists the seeds of each.
nlohmann::json ensemble_statistics(const std::vector<std::uint64_t>& seeds, const std::vector<nlohmann::json>& summaries,
                                   bool include_uncontrolled = false);

}  // namespace celldem
