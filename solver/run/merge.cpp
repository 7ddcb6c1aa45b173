#include "run/merge.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "io/deck_reader.hpp"
#include "io/files.hpp"
#include "run/ensemble.hpp"
#include "run/probes.hpp"
#include "run/runner.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// The deck a run folder ran (progress.json's, as the run read it); UsageError for a folder that is not a run.
std::string run_deck_text(const fs::path& dir) {
  const fs::path progress = dir / "progress.json";
  if (!fs::exists(progress)) throw UsageError(dir.string() + ": not a run folder (no progress.json)");
  return Json::parse(read_file(progress)).at("deck").get<std::string>();
}

std::vector<std::uint64_t> seeds_in(const fs::path& dir) {
  std::vector<std::uint64_t> seeds;
  if (!fs::is_directory(dir)) return seeds;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_directory() && name.rfind("seed-", 0) == 0 && name.size() > 5 &&
        name.find_first_not_of("0123456789", 5) == std::string::npos)
      seeds.push_back(std::stoull(name.substr(5)));
  }
  std::sort(seeds.begin(), seeds.end());
  return seeds;
}

bool same_bytes(const fs::path& a, const fs::path& b) { return read_file(a) == read_file(b); }

// The probes of one run folder gathered from the others of the same deck, and its tables recomputed.
void merge_probes(const fs::path& into, const std::vector<fs::path>& from, std::vector<std::string>& done) {
  const std::string text = run_deck_text(into);
  const Deck deck = parse_deck(text, (into / "progress.json").string());
  for (const fs::path& other : from)
    if (run_deck_text(other) != text)
      throw UsageError(other.string() + ": a run of another deck than " + into.string() + "'s (progress.json)");
  for (const TestDef& test : deck.tests) {
    if (!test.probes) continue;
    const fs::path mine = into / test.name / "probes";
    if (!fs::exists(mine)) continue;  // the test did not finish in this folder
    int copied = 0;
    for (const fs::path& other : from) {
      const fs::path theirs = other / test.name / "probes";
      if (!fs::exists(theirs)) continue;
      for (const std::string& point : probe_point_names(*test.probes)) {
        const fs::path a = mine / point / "point.state", b = theirs / point / "point.state";
        if (!fs::exists(b)) continue;
        if (!fs::exists(a) || !same_bytes(a, b))
          throw UsageError(b.string() + ": not the state of " + a.string() + " (the jobs' tests differ: merge only "
                           "runs of the same deck and binary)");
        for (const fs::directory_entry& e : fs::directory_iterator(theirs / point))
          if (e.is_directory() && fs::exists(e.path() / "result.json") && !fs::exists(mine / point / e.path().filename())) {
            fs::copy(e.path(), mine / point / e.path().filename(), fs::copy_options::recursive);
            ++copied;
          }
      }
    }
    const Json probes = tabulate_probes(into, deck, test);
    const fs::path summary_path = into / "summary.json";
    Json summary = Json::parse(read_file(summary_path));
    summary["tests"][test.name]["probes"] = probes;
    write_file_atomic(summary_path, summary.dump(1));
    done.push_back(into.string() + ": " + test.name + ": " + std::to_string(copied) +
                   " probe folders gathered; probes.csv recomputed");
  }
}

}  // namespace

std::vector<std::string> merge_runs(const fs::path& into, const std::vector<fs::path>& from, bool include_uncontrolled) {
  std::vector<std::string> done;
  std::vector<std::uint64_t> seeds = seeds_in(into);
  bool ensemble = !seeds.empty();
  for (const fs::path& other : from) ensemble = ensemble || !seeds_in(other).empty();
  if (!ensemble) {
    merge_probes(into, from, done);
    return done;
  }
  fs::create_directories(into);
  for (const fs::path& other : from)
    for (const std::uint64_t seed : seeds_in(other)) {
      const std::string name = "seed-" + std::to_string(seed);
      if (!fs::exists(into / name)) {
        fs::copy(other / name, into / name, fs::copy_options::recursive);
        done.push_back(into.string() + ": " + name + " copied from " + other.string());
      }
    }
  seeds = seeds_in(into);
  std::vector<std::uint64_t> complete;
  std::vector<Json> summaries;
  for (const std::uint64_t seed : seeds) {
    const fs::path dir = into / ("seed-" + std::to_string(seed));
    std::vector<fs::path> same_seed;
    for (const fs::path& other : from)
      if (fs::exists(other / dir.filename() / "progress.json") && !fs::equivalent(other / dir.filename(), dir))
        same_seed.push_back(other / dir.filename());
    merge_probes(dir, same_seed, done);
    // A seed counts when every stage of its deck is complete (progress.json's list).
    const Json progress = Json::parse(read_file(dir / "progress.json"));
    const Deck deck = parse_deck(progress.at("deck").get<std::string>(), (dir / "progress.json").string());
    std::size_t stages = deck.tests.size() + (deck.prepare ? 1 : 0);
    if (progress.at("completed").size() < stages) {
      done.push_back(dir.string() + ": not complete; left out of ensemble.json");
      continue;
    }
    complete.push_back(seed);
    summaries.push_back(Json::parse(read_file(dir / "summary.json")));
  }
  if (complete.empty()) throw UsageError(into.string() + ": no complete seed-<k> folder to make an ensemble of");
  write_ensemble(into, complete, summaries, include_uncontrolled, /*quiet=*/true);
  done.push_back(into.string() + ": ensemble.json over " + std::to_string(complete.size()) + " seeds");
  return done;
}

}  // namespace celldem
