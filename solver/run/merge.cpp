#include "run/merge.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "io/deck_reader.hpp"
#include "io/files.hpp"
#include "run/ensemble.hpp"
#include "run/probes.hpp"
#include "run/run_directory.hpp"
#include "run/errors.hpp"

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

// A folder a merge copies is first written as a hidden sibling `.NAME.merge-partial`, read back against its source,
// then renamed to NAME: the rename is the commit, so a folder at NAME is a whole copy, and what a merge stopped
// part-way left is only a temporary, removed by the next merge.
constexpr const char* kPartialSuffix = ".merge-partial";
const std::vector<std::string> kNotCopied = {kLockName};  // a lock is its own folder's

fs::path partial_of(const fs::path& to) {
  std::string name(1, '.');  // (built by appending: GCC 12 warns falsely on "." + string)
  name.append(to.filename().string()).append(kPartialSuffix);
  return to.parent_path() / name;
}

// Copies `from` to the temporary beside `to`, read back against `from`; returns the temporary (removed on failure).
fs::path copy_aside(const fs::path& from, const fs::path& to) {
  const fs::path tmp = partial_of(to);
  try {
    fs::remove_all(tmp);
    copy_tree(from, tmp, kNotCopied);
    if (const std::string d = tree_difference(from, tmp, kNotCopied); !d.empty())
      throw IoError((tmp / d).string() + ": the copy read back differs from " + (from / d).string());
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(tmp, ignored);  // (also frees the space of a full disk)
    throw;
  }
  return tmp;
}

void commit(const fs::path& tmp, const fs::path& to) {
  if (::rename(tmp.c_str(), to.c_str()) != 0) {
    const int error = errno;
    std::error_code ignored;
    fs::remove_all(tmp, ignored);
    throw_io_error(to, "cannot rename " + tmp.string() + " to", error);
  }
  sync_folder(to.parent_path());
}

void copy_committed(const fs::path& from, const fs::path& to) { commit(copy_aside(from, to), to); }

// Replaces the folder `to` by a copy of `from`: the old one is moved to a temporary of its own just before the
// copy is committed (killed in between, the next merge finds neither and copies `to` again), then removed.
void replace_committed(const fs::path& from, const fs::path& to) {
  const fs::path tmp = copy_aside(from, to);
  fs::path stale_name = to;
  stale_name += ".stale";
  const fs::path stale = partial_of(stale_name);
  fs::remove_all(stale);
  fs::rename(to, stale);
  commit(tmp, to);
  fs::remove_all(stale);
}

// Removes the temporaries a merge stopped part-way left in `dir`.
void remove_partials(const fs::path& dir) {
  if (!fs::is_directory(dir)) return;
  std::vector<fs::path> partials;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.size() > std::string(kPartialSuffix).size() + 1 && name.front() == '.' &&
        name.ends_with(kPartialSuffix))
      partials.push_back(e.path());
  }
  for (const fs::path& p : partials) fs::remove_all(p);
}

// What a seed folder in the folder gathered into lacks to be a run's (its progress.json, and the files of each stage
// it lists complete), or "" when whole. A merge of an earlier version stopped part-way left such folders.
std::string missing_in_run(const fs::path& dir) {
  if (!fs::exists(dir / "progress.json")) return "progress.json";
  Json progress;
  try {
    progress = Json::parse(read_file(dir / "progress.json"));
    progress.at("deck").get<std::string>();
  } catch (const Json::exception&) {
    return "a readable progress.json";
  }
  const Json completed = progress.value("completed", Json::array());
  for (const Json& stage : completed) {
    if (!stage.is_string()) return "a readable progress.json";
    const std::string name = stage.get<std::string>();
    std::vector<fs::path> files = {fs::path(name) / "series.csv",
                                   name == "prepare" ? fs::path("prepared.state") : fs::path(name) / "final.state"};
    for (const fs::path& f : files)
      if (!fs::exists(dir / f)) return f.string();
  }
  if (!completed.empty() && !fs::exists(dir / "summary.json")) return "summary.json";
  return "";
}

// What a run folder says it is (progress.json): its deck's fingerprint (computed from its deck when an older run did
// not record it) and its kind ("unknown" when not recorded).
struct Origin {
  std::string fingerprint, kind;
};
Origin origin_of(const fs::path& dir) {
  const Json progress = Json::parse(read_file(dir / "progress.json"));
  return {progress.contains("fingerprint") ? progress["fingerprint"].get<std::string>()
                                           : deck_fingerprint(progress.at("deck").get<std::string>()),
          progress.value("kind", std::string("unknown"))};
}
bool seed_kind(const std::string& kind) { return kind == "seed share" || kind == "ensemble" || kind == "unknown"; }
bool run_kind(const std::string& kind) { return kind == "single" || kind == "probe share" || kind == "unknown"; }
std::string describe(const fs::path& dir, const Origin& o) {
  return dir.string() + " (deck fingerprint " + o.fingerprint + ", kind " + o.kind + ")";
}
// Every folder of `dirs` is of the deck of the first, and of a kind `fits` accepts: else UsageError naming both.
void check_origins(const std::vector<fs::path>& dirs, bool (*fits)(const std::string&), const char* wanted) {
  if (dirs.empty()) return;
  const Origin first = origin_of(dirs.front());
  for (const fs::path& dir : dirs) {
    const Origin o = origin_of(dir);
    if (o.fingerprint != first.fingerprint)
      throw UsageError(describe(dir, o) + " is a run of another deck than " + describe(dirs.front(), first) +
                       ": merge gathers only the shares of one deck; nothing was copied");
    if (!fits(o.kind))
      throw UsageError(describe(dir, o) + " is not " + wanted + " like " + describe(dirs.front(), first) +
                       ": nothing was copied");
  }
}

// Whether a run folder's every stage is complete (progress.json's list against its deck's stages).
bool run_complete(const fs::path& dir) {
  const Json progress = Json::parse(read_file(dir / "progress.json"));
  const Deck deck = parse_deck(progress.at("deck").get<std::string>(), (dir / "progress.json").string());
  return progress.at("completed").size() >= deck.tests.size() + (deck.prepare ? 1 : 0);
}

// The probes of one run folder gathered from the others of the same deck, and its tables recomputed.
void merge_probes(const fs::path& into, const std::vector<fs::path>& from, std::vector<std::string>& done) {
  const std::string text = run_deck_text(into);
  const Deck deck = parse_deck(text, (into / "progress.json").string());
  for (const TestDef& test : deck.tests) refuse_links_out(into, test.name);
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
        remove_partials(mine / point);
        const fs::path a = mine / point / "point.state", b = theirs / point / "point.state";
        if (!fs::exists(b)) continue;
        if (!fs::exists(a) || !same_bytes(a, b))
          throw UsageError(b.string() + ": not the state of " + a.string() + " (the jobs' tests differ: merge only "
                           "runs of the same deck and binary)");
        for (const fs::directory_entry& e : fs::directory_iterator(theirs / point)) {
          const fs::path to = mine / point / e.path().filename();
          if (!e.is_directory() || !fs::exists(e.path() / "result.json") || fs::exists(to / "result.json")) continue;
          // A probe this folder did not finish (its own run stopped, or a copy an earlier version stopped part-way):
          // moved aside whole before the finished one is copied.
          if (fs::exists(to)) replace_committed(e.path(), to);
          else copy_committed(e.path(), to);
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

namespace {

// The locks of a merge: the folder gathered into, exclusive (created when new); each share, shared (the merge only
// reads it: a share may be read-only, and other merges may read it too). A folder named twice is locked once.
std::vector<FolderLock> lock_folders(const fs::path& into, const std::vector<fs::path>& from) {
  std::vector<FolderLock> locks;
  locks.emplace_back(into);
  locks.back().claim();  // the merge writes there
  std::vector<fs::path> locked = {into};
  for (const fs::path& other : from)
    if (std::none_of(locked.begin(), locked.end(), [&](const fs::path& p) { return fs::equivalent(p, other); })) {
      locks.emplace_back(other, LockMode::shared);
      locked.push_back(other);
    }
  return locks;
}

// Seed shares gathered into an ensemble folder: every seed-<k> of one deck and of an ensemble's kind, checked before
// anything is copied; a seed folder `into` holds must be whole (not a copy stopped part-way).
void check_seed_shares(const fs::path& into, const std::vector<fs::path>& from) {
  if (fs::exists(into / "progress.json"))
    throw UsageError(describe(into, origin_of(into)) + " is a run folder, and the shares hold seeds (seed-<k>/): "
                     "gather seed shares into an ensemble folder (one holding seed-<k>/ folders, or a new one); "
                     "nothing was copied");
  std::vector<fs::path> seeds_all;
  for (const std::uint64_t seed : seeds_in(into)) {
    const fs::path dir = into / ("seed-" + std::to_string(seed));
    refuse_links_out(into, dir.filename().string());
    if (const std::string missing = missing_in_run(dir); !missing.empty())
      throw UsageError(dir.string() + " is not whole (it has no " + missing + "): a copy a merge stopped part-way, "
                       "or a run that never began; remove it (rm -r '" + dir.string() + "') and merge again; nothing "
                       "was copied");
    seeds_all.push_back(dir);
  }
  for (const fs::path& other : from) {
    const std::vector<std::uint64_t> theirs = seeds_in(other);
    if (theirs.empty())
      throw UsageError(other.string() + " holds no seed-<k>/ folder (" +
                       (fs::exists(other / "progress.json") ? "it is a " + origin_of(other).kind + " run folder"
                                                            : std::string("not a share")) +
                       "): merge seed shares only with seed shares; nothing was copied");
    for (const std::uint64_t seed : theirs) seeds_all.push_back(other / ("seed-" + std::to_string(seed)));
  }
  for (const fs::path& dir : seeds_all) run_deck_text(dir);  // each a run folder
  check_origins(seeds_all, seed_kind, "a seed of an ensemble");
}

// The seeds `into` lacks copied from the shares (each committed whole, by a rename; a seed `into` holds incomplete
// replaced by a share's complete one: a merge of a share not yet finished, merged again once it is), the probes of a
// seed both hold gathered, and ensemble.json written over every complete seed.
void merge_seeds(const fs::path& into, const std::vector<fs::path>& from, bool include_uncontrolled,
                 bool* incomplete, std::vector<std::string>& done) {
  for (const fs::path& other : from)
    for (const std::uint64_t seed : seeds_in(other)) {
      const std::string name = "seed-" + std::to_string(seed);
      const fs::path to = into / name, theirs = other / name;
      if (!fs::exists(to)) {
        copy_committed(theirs, to);
        done.push_back(into.string() + ": " + name + " copied from " + other.string());
      } else if (!fs::equivalent(to, theirs) && !run_complete(to) && run_complete(theirs)) {
        const FolderLock lock(to);  // no run of the seed alone at the same time
        replace_committed(theirs, to);
        done.push_back(into.string() + ": " + name + " (not complete) replaced by the complete one of " + other.string());
      }
    }
  std::vector<std::uint64_t> complete;
  std::vector<Json> summaries;
  for (const std::uint64_t seed : seeds_in(into)) {
    const fs::path dir = into / ("seed-" + std::to_string(seed));
    std::vector<fs::path> same_seed;
    for (const fs::path& other : from)
      if (fs::exists(other / dir.filename() / "progress.json") && !fs::equivalent(other / dir.filename(), dir))
        same_seed.push_back(other / dir.filename());
    const FolderLock lock(dir);  // its tables are written: no run of the seed alone at the same time
    merge_probes(dir, same_seed, done);
    // A seed counts when every stage of its deck is complete (progress.json's list).
    if (!run_complete(dir)) {
      done.push_back(dir.string() + ": not complete; left out of ensemble.json");
      if (incomplete) *incomplete = true;
      continue;
    }
    complete.push_back(seed);
    summaries.push_back(Json::parse(read_file(dir / "summary.json")));
  }
  if (complete.empty()) throw UsageError(into.string() + ": no complete seed-<k> folder to make an ensemble of");
  write_ensemble(into, complete, summaries, include_uncontrolled, /*quiet=*/true);
  done.push_back(into.string() + ": ensemble.json over " + std::to_string(complete.size()) + " seeds");
}

}  // namespace

std::vector<std::string> merge_runs(const fs::path& into, const std::vector<fs::path>& from, bool include_uncontrolled,
                                    bool* incomplete) {
  std::vector<std::string> done;
  bool ensemble = !seeds_in(into).empty();
  for (const fs::path& other : from) ensemble = ensemble || !seeds_in(other).empty();
  // The folder gathered into, and every share, has no other owner while the merge reads and writes them.
  if (!ensemble) run_deck_text(into);  // a probes merge gathers into a run folder: not created here
  const std::vector<FolderLock> locks = lock_folders(into, from);
  // What each folder is, checked before anything is copied: one deck (its fingerprint), and shares of one kind of
  // split (seed shares into an ensemble folder, probe shares into a run folder).
  if (ensemble) {
    remove_partials(into);  // what a merge stopped part-way left
    check_seed_shares(into, from);
    merge_seeds(into, from, include_uncontrolled, incomplete, done);
    return done;
  }
  std::vector<fs::path> runs = {into};
  runs.insert(runs.end(), from.begin(), from.end());
  for (const fs::path& dir : runs) run_deck_text(dir);
  check_origins(runs, run_kind, "a run or a probe share");
  merge_probes(into, from, done);
  for (const fs::path& other : from)
    if (!run_complete(other)) {
      done.push_back(other.string() + ": not complete (progress.json): its probes are not all there");
      if (incomplete) *incomplete = true;
    }
  return done;
}

}  // namespace celldem
