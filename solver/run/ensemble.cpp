#include "run/ensemble.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include <boost/math/distributions/students_t.hpp>

#include "io/files.hpp"
#include "run/run_directory.hpp"
#include "run/runner.hpp"
#include "run/verify_rate.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// A quantity of the peak: meaningless when the test's largest s11/s33 is its last row (no peak reached).
bool is_peak_quantity(const std::string& path) { return path.find("peak") != std::string::npos; }

// The tests of a summary that the statistics may use, and what is left out of each (summary.json's
// "controlled" and "peak_reached"; a summary without them, from before they existed, counts as both true).
struct TestUse {
  bool use = true;        // false: the test's control failed and uncontrolled tests are left out
  bool peak = true;       // false: no peak reached, its peak quantities are left out
};

TestUse test_use(const Json& test, bool include_uncontrolled) {
  TestUse u;
  u.use = include_uncontrolled || test.value("controlled", true);
  u.peak = test.value("peak_reached", true);
  return u;
}

// Every numeric leaf of a summary object, by its dotted path ("peak_state.sigma1", "end_window.ev").
void numeric_leaves(const Json& j, const std::string& prefix, std::map<std::string, double>& out) {
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) numeric_leaves(value, prefix.empty() ? key : prefix + "." + key, out);
  } else if (j.is_array()) {
    for (std::size_t k = 0; k < j.size(); ++k) numeric_leaves(j[k], prefix + "[" + std::to_string(k) + "]", out);
  } else if (j.is_number()) {
    out[prefix] = j.get<double>();
  }
}

// quantity -> values over the seeds that have it.
using Columns = std::map<std::string, std::vector<double>>;

Json describe_all(const Columns& columns) {
  Json out = Json::object();
  for (const auto& [name, values] : columns) out[name] = describe(values);
  return out;
}

}  // namespace

std::vector<std::uint64_t> parse_seed_list(const std::string& text, bool allow_one) {
  std::vector<std::uint64_t> seeds;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    const auto dash = item.find('-');
    try {
      std::size_t used = 0;
      const std::uint64_t a = std::stoull(item.substr(0, dash), &used);
      if (used != item.substr(0, dash).size()) throw std::invalid_argument(item);
      std::uint64_t b = a;
      if (dash != std::string::npos) {
        b = std::stoull(item.substr(dash + 1), &used);
        if (used != item.substr(dash + 1).size() || b < a) throw std::invalid_argument(item);
      }
      if (b - a > 10000) throw std::invalid_argument(item);
      for (std::uint64_t k = a; k <= b; ++k)
        if (std::find(seeds.begin(), seeds.end(), k) == seeds.end()) seeds.push_back(k);
    } catch (const std::logic_error&) {
      throw DeckError("--seeds: \"" + item + "\" is not a seed or a range: give seeds (whole numbers from 0) "
                      "as K, K-L with K <= L, or a comma-separated list of them (e.g. 1-8 or 1,3,5), at most "
                      "10001 seeds per range");
    }
  }
  if (seeds.size() < (allow_one ? 1u : 2u)) throw DeckError("--seeds: an ensemble needs at least two seeds");
  return seeds;
}

Json describe(const std::vector<double>& values) {
  const std::size_t n = values.size();
  if (n == 0) return {{"n", 0}};
  double mean = 0.0;
  for (double v : values) mean += v / static_cast<double>(n);
  double var = 0.0;
  for (double v : values) var += (v - mean) * (v - mean);
  const double sd = n > 1 ? std::sqrt(var / static_cast<double>(n - 1)) : 0.0;
  const double se = sd / std::sqrt(static_cast<double>(n));
  const double t = n > 1 ? student_t_quantile(0.975, static_cast<double>(n - 1)) : 0.0;
  const double half = t * se;                                                  // of the mean
  const double half_one = t * sd * std::sqrt(1.0 + 1.0 / static_cast<double>(n));  // of one more sample
  return {{"n", n}, {"mean", mean}, {"std", sd}, {"sem", se}, {"ci95", {mean - half, mean + half}},
          {"pi95", {mean - half_one, mean + half_one}}, {"values", values}};
}

double student_t_quantile(double p, double dof) {
  return boost::math::quantile(boost::math::students_t_distribution<double>(dof), p);
}

Json ensemble_statistics(const std::vector<std::uint64_t>& seeds, const std::vector<Json>& summaries,
                         bool include_uncontrolled) {
  Columns prepared;
  std::map<std::string, Columns> tests;
  std::map<std::string, std::map<std::string, std::map<std::uint64_t, double>>> by_seed;  // test -> q -> seed
  Json excluded = Json::object();  // test -> {"uncontrolled": [seeds], "no_peak": [seeds]}
  for (std::size_t k = 0; k < summaries.size(); ++k) {
    std::map<std::string, double> leaves;
    numeric_leaves(summaries[k].value("prepared", Json::object()), "", leaves);
    for (const auto& [q, v] : leaves) prepared[q].push_back(v);
    const Json tests_of_seed = summaries[k].value("tests", Json::object());  // items() needs a live object
    for (const auto& [name, test] : tests_of_seed.items()) {
      if (!excluded.contains(name)) excluded[name] = {{"uncontrolled", Json::array()}, {"no_peak", Json::array()}};
      const TestUse use = test_use(test, include_uncontrolled);
      if (!use.use) {
        excluded[name]["uncontrolled"].push_back(seeds[k]);
        continue;
      }
      if (!use.peak) excluded[name]["no_peak"].push_back(seeds[k]);
      std::map<std::string, double> t;
      numeric_leaves(test, "", t);
      for (const auto& [q, v] : t) {
        if (!use.peak && is_peak_quantity(q)) continue;
        tests[name][q].push_back(v);
        by_seed[name][q][seeds[k]] = v;
      }
    }
  }
  Json out = {{"seeds", seeds},
              {"statistics", "mean, std (n - 1), sem = std / sqrt(n), ci95 = mean -+ t(0.975, n - 1) sem (the "
                             "interval of the mean), pi95 = mean -+ t(0.975, n - 1) std sqrt(1 + 1/n) (the "
                             "interval of one more sample: compare a single published value with it); t from "
                             "Boost.Math"},
              {"excluded", {{"rule", include_uncontrolled
                                         ? "no-peak tests' peak quantities left out; uncontrolled tests kept "
                                           "(--include-uncontrolled)"
                                         : "uncontrolled tests (summary.json \"controlled\": false) left out "
                                           "entirely; no-peak tests (\"peak_reached\": false) left out of the "
                                           "peak quantities"},
                            {"tests", excluded}}},
              {"prepared", describe_all(prepared)},
              {"tests", Json::object()},
              {"paired", Json::object()}};
  for (const auto& [name, columns] : tests) out["tests"][name] = describe_all(columns);
  // The rate check over the seeds that ran it: TOST on the mean paired error (run/verify_rate.hpp).
  if (Json rate = rate_check_across_seeds(seeds, summaries); !rate.empty()) out["verify_rate"] = rate;
  // --tolerance's check after each test, per seed (io/tolerance check_tolerance): the seeds that kept T.
  for (std::size_t k = 0; k < summaries.size(); ++k) {
    const Json tests_of_seed = summaries[k].value("tests", Json::object());
    for (const auto& [name, test] : tests_of_seed.items()) {
      if (!test.contains("tolerance") || !test["tolerance"].is_object()) continue;
      Json& t = out["tolerance"][name];
      if (t.is_null()) t = {{"seeds", 0}, {"kept", 0}, {"not_kept", Json::array()}, {"not_checked", Json::array()}};
      t["seeds"] = t["seeds"].get<int>() + 1;
      const Json& kept = test["tolerance"].value("kept", Json());
      if (kept.is_boolean() && kept.get<bool>())
        t["kept"] = t["kept"].get<int>() + 1;
      else
        (kept.is_boolean() ? t["not_kept"] : t["not_checked"]).push_back(seeds[k]);
    }
  }
  // Paired differences on the same seeds (the same sample): B - A for every quantity both tests have.
  for (auto a = by_seed.begin(); a != by_seed.end(); ++a)
    for (auto b = std::next(a); b != by_seed.end(); ++b) {
      Columns diff;
      for (const auto& [q, values_a] : a->second) {
        // verify_rate.* and tolerance.* are the checks' own settings and verdicts (floors, steps, margins), not
        // results of the test: their difference between two tests means nothing.
        if (q.rfind("verify_rate.", 0) == 0 || q.rfind("tolerance.", 0) == 0) continue;
        const auto it = b->second.find(q);
        if (it == b->second.end()) continue;
        for (const auto& [seed, va] : values_a)
          if (const auto vb = it->second.find(seed); vb != it->second.end()) diff[q].push_back(vb->second - va);
      }
      out["paired"][b->first + "-" + a->first] = describe_all(diff);
    }
  return out;
}

void write_ensemble(const fs::path& dir, const std::vector<std::uint64_t>& seeds, const std::vector<Json>& summaries,
                    bool include_uncontrolled, bool quiet) {
  const Json statistics = ensemble_statistics(seeds, summaries, include_uncontrolled);
  write_file_atomic(dir / "ensemble.json", statistics.dump(1));
  // What was left out is printed whether or not the run is quiet: a mean over fewer seeds must be seen.
  for (const auto& [name, ex] : statistics["excluded"]["tests"].items()) {
    if (!ex["uncontrolled"].empty())
      std::fprintf(stderr, "ensemble: %s: %zu of %zu seeds left out, their control failed (%s)\n", name.c_str(),
                   ex["uncontrolled"].size(), seeds.size(),
                   include_uncontrolled ? "kept: --include-uncontrolled" : "--include-uncontrolled keeps them");
    if (!ex["no_peak"].empty())
      std::fprintf(stderr, "ensemble: %s: %zu of %zu seeds reached no peak (largest s11/s33 at the test's end); "
                           "their peak quantities left out\n",
                   name.c_str(), ex["no_peak"].size(), seeds.size());
  }
  if (statistics.contains("verify_rate"))  // the verdicts over the seeds, on the console as in the file
    for (const auto& [name, t] : statistics["verify_rate"].items()) {
      for (const auto& [q, r] : t["quantities"].items())
        std::printf("ensemble: %s: rate check %-20s mean error %+.2f floors over %zu seeds, 95 %% bounds [%+.2f, %+.2f]: "
                    "%s\n", name.c_str(), q.c_str(), r["mean"].get<double>(), r["values"].size(),
                    r.contains("bounds95") ? r["bounds95"][0].get<double>() : NAN,
                    r.contains("bounds95") ? r["bounds95"][1].get<double>() : NAN, r["verdict"].get<std::string>().c_str());
      std::printf("ensemble: %s: rate check over the seeds (TOST, T = %g floors): %s\n", name.c_str(),
                  t["tolerance_floors"].get<double>(), t["verdict"].get<std::string>().c_str());
    }
  if (statistics.contains("tolerance"))  // the promise's check over the seeds: a seed that missed it is seen
    for (const auto& [name, t] : statistics["tolerance"].items())
      std::printf("ensemble: %s: tolerance kept on %d of %d seeds%s\n", name.c_str(), t["kept"].get<int>(),
                  t["seeds"].get<int>(),
                  t["not_kept"].empty() ? "" : (" (not kept: seeds " + t["not_kept"].dump() + ")").c_str());
  if (!quiet) std::printf("wrote %s\n", (dir / "ensemble.json").c_str());
}

void run_ensemble(const Deck& deck, const RunOptions& options, const std::vector<std::uint64_t>& seeds,
                  bool include_uncontrolled) {
  if (!deck.prepare) throw DeckError("--seeds: the deck has no \"prepare\": a seed ensemble prepares its samples");
  if (deck.initial_state)  // every seed would prepare the same loaded state: one sample, not an ensemble
    throw DeckError("initial_state: --seeds draws a new grid sample per seed; a preparation from initial_state is "
                    "the same for every seed");
  const fs::path dir(options.out_dir);
  FolderLock lock(dir);  // the ensemble folder's own (each seed-<k>/ has its run's)
  if (!options.resume && !options.force && fs::exists(dir / "ensemble.json"))
    throw UsageError(dir.string() + " already holds an ensemble; use --force to overwrite it or --resume");
  lock.claim();
  std::vector<Json> summaries;
  for (const std::uint64_t seed : seeds) {
    Deck d = deck;
    d.sample.seed = seed;
    Json canonical = Json::parse(deck.canonical);
    canonical["sample"]["seed"] = seed;
    d.canonical = canonical.dump();
    RunOptions o = options;
    o.out_dir = (dir / ("seed-" + std::to_string(seed))).string();
    o.kind = seeds.size() == 1 ? "seed share" : "ensemble";
    o.resume = options.resume && fs::exists(fs::path(o.out_dir) / "progress.json");
    if (!options.quiet) std::printf("== seed %llu -> %s\n", static_cast<unsigned long long>(seed), o.out_dir.c_str());
    run_deck(d, o);
    summaries.push_back(Json::parse(read_file(fs::path(o.out_dir) / "summary.json")));
  }
  if (seeds.size() == 1) {  // one share of a job array: the statistics are the merge's, over every share
    if (!options.quiet)
      std::printf("one seed: a share of an ensemble; `celldem merge DIR SHARES...` writes ensemble.json over the "
                  "shares\n");
    return;
  }
  write_ensemble(dir, seeds, summaries, include_uncontrolled, options.quiet);
}

}  // namespace celldem
