#include "run/run_directory.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "io/files.hpp"
#include "io/tolerance.hpp"

namespace celldem {
namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

Json read_json(const fs::path& path) {
  const std::string text = read_file(path);
  try {
    return Json::parse(text);
  } catch (const Json::exception& e) {
    throw RunError(path.string() + ": not valid JSON (" + e.what() + ")");
  }
}

// What a run writes into its directory: its own files and one folder per stage (a folder holding a
// series, a checkpoint or a final state), the report's figures and text.
bool is_run_output(const fs::directory_entry& entry) {
  const std::string name = entry.path().filename().string();
  if (entry.is_directory()) {
    if (name == "figures") return true;
    for (const char* f : {"series.csv", kCheckpointName, "final.state"})
      if (fs::exists(entry.path() / f)) return true;
    return false;
  }
  for (const char* f : {kSummaryName, kProgressName, kPreparedName, kResolvedDeckName, "report.md"})
    if (name == f || name == std::string(f) + ".tmp") return true;
  return false;
}

}  // namespace

std::string deck_fingerprint(const std::string& canonical_deck) {
  Json deck = Json::parse(canonical_deck);
  if (deck.contains("sample") && deck["sample"].is_object()) deck["sample"].erase("seed");
  return fnv1a_hex(deck.dump());
}

void create_run_folder(const fs::path& dir) {
  std::error_code error;
  if (fs::exists(dir, error) && !fs::is_directory(dir, error))
    throw UsageError(dir.string() + ": is not a folder (a file or a device): give --out a folder for the run's "
                     "results");
  fs::create_directories(dir, error);
  if (error) {
    const std::string why = error == std::errc::not_a_directory
                                ? "a part of the path is a file, not a folder"
                                : error.message();
    throw UsageError(dir.string() + ": cannot create the run folder (" + why + ")");
  }
}

FolderLock::FolderLock(const fs::path& dir) {
  create_run_folder(dir);
  const fs::path path = dir / kLockName;
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw UsageError(dir.string() + ": cannot write in the run folder (" + std::strerror(errno) + ")");
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    char pid[32] = {};
    const ssize_t n = ::pread(fd_, pid, sizeof pid - 1, 0);
    std::string holder = n > 0 ? std::string(pid, static_cast<std::size_t>(n)) : std::string();
    while (!holder.empty() && (holder.back() == '\n' || holder.back() == ' ')) holder.pop_back();
    ::close(fd_);
    fd_ = -1;
    if (error != EWOULDBLOCK) throw UsageError(path.string() + ": cannot lock (" + std::strerror(error) + ")");
    throw UsageError(dir.string() + " is in use by another celldem process (pid " +
                     (holder.empty() ? std::string("unknown") : holder) + ", holding " + path.string() +
                     "): wait for it to end, or stop it (a stopped run continues with --resume)");
  }
}

void FolderLock::claim() {
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (fd_ < 0 || ::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    // The pid is only for the message of a process refused: the lock holds without it.
  }
}

FolderLock::~FolderLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock
}

FolderLock& FolderLock::operator=(FolderLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

RunDirectory::RunDirectory(const Deck& deck, const RunOptions& options)
    : dir_(options.out_dir), resume_(options.resume) {
  // --resume of a folder that is not there is refused without creating it.
  if (options.resume && !fs::exists(dir_ / kProgressName))
    throw UsageError(dir_.string() + " holds no interrupted run to resume (no " + kProgressName + ")");
  lock_ = FolderLock(dir_);
  if (options.resume) {
    if (!fs::exists(dir_ / kProgressName))
      throw UsageError(dir_.string() + " holds no interrupted run to resume (no " + kProgressName + ")");
    progress_ = read_json(dir_ / kProgressName);
    // A run at another tolerance (or none) ran another deck: say which, before the deck's text differs.
    const Json started = progress_.value("tolerance", Json());
    const Json asked = deck.tolerance ? Json(*deck.tolerance) : Json();
    if (started != asked) {
      const auto name = [](const Json& t) {
        if (t.is_null()) return std::string("without --tolerance");
        std::ostringstream s;
        s << "with --tolerance " << t.get<double>();
        return s.str();
      };
      throw UsageError("--resume: the run was started " + name(started) + " and is resumed " + name(asked) +
                       ": resume it as it was started (or start it again with --force)");
    }
    if (progress_.value("deck", std::string()) != deck.canonical)
      throw UsageError("--resume: the deck differs from the one this run was started with");
    summary_ = fs::exists(dir_ / kSummaryName) ? read_json(dir_ / kSummaryName) : Json::object();
    for (const Json& stage : progress_["completed"]) check_finished(stage.get<std::string>());
    lock_.claim();
    return;
  }
  if (fs::exists(dir_)) {
    std::vector<fs::path> outputs;
    for (const fs::directory_entry& entry : fs::directory_iterator(dir_))
      if (is_run_output(entry)) outputs.push_back(entry.path());
    if (!outputs.empty()) {
      if (!options.force)
        throw UsageError(dir_.string() + " already holds results; use --force to overwrite them or --resume to "
                       "continue an interrupted run");
      for (const fs::path& p : outputs) fs::remove_all(p);  // only the new run's outputs will be there
    }
  }
  lock_.claim();
  fs::create_directories(dir_);
  const bool share = options.probes.first != ProbeSelection{}.first || options.probes.last != ProbeSelection{}.last;
  const std::string kind = !options.kind.empty() ? options.kind : share ? "probe share" : "single";
  progress_ = {{"deck", deck.canonical}, {"fingerprint", deck_fingerprint(deck.canonical)}, {"kind", kind},
               {"completed", Json::array()}, {"finished", Json::object()}};
  if (deck.tolerance) {
    progress_["tolerance"] = *deck.tolerance;
    write_file_atomic(dir_ / kResolvedDeckName, resolved_deck_json(deck));
  }
  summary_ = Json::object();
  write_progress();
}

bool RunDirectory::completed(const std::string& stage) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& s : progress_["completed"])
    if (s == stage) return true;
  return false;
}

bool RunDirectory::resumes(const std::string& stage) const { return resume_ && fs::exists(checkpoint(stage)); }

std::vector<fs::path> RunDirectory::finished_files(const std::string& stage) const {
  if (stage == "prepare") return {stage_dir(stage) / "series.csv", prepared_state()};
  return {stage_dir(stage) / "series.csv", stage_dir(stage) / "final.state"};
}

const Json& RunDirectory::summary_entry(const std::string& stage) const {
  static const Json none;
  if (stage == "prepare") return summary_.contains("prepared") ? summary_["prepared"] : none;
  return summary_.contains("tests") && summary_["tests"].contains(stage) ? summary_["tests"][stage] : none;
}

void RunDirectory::mark_done(const std::string& stage) {
  const std::lock_guard<std::mutex> lock(mutex_);
  write_file_atomic(dir_ / kSummaryName, summary_.dump(2));
  // What --resume will trust of the finished stage: its files' and its summary entry's hashes.
  Json proof = {{"summary.json", fnv1a_hex(summary_entry(stage).dump())}};
  for (const fs::path& file : finished_files(stage))
    proof[fs::relative(file, dir_).string()] = fnv1a_hex(read_file(file));
  progress_["finished"][stage] = proof;
  progress_["completed"].push_back(stage);
  write_progress();
  fs::remove(checkpoint(stage));
}

void RunDirectory::check_finished(const std::string& stage) const {
  const auto refuse = [&](const fs::path& file, const std::string& what) {
    throw UsageError("--resume: " + file.string() + " " + what + " since stage '" + stage +
                     "' finished; a resumed run builds only on what its stages wrote: restore the file, or run again "
                     "with --force");
  };
  const Json proof = progress_.contains("finished") ? progress_["finished"].value(stage, Json()) : Json();
  if (!proof.is_object())
    refuse(dir_ / kProgressName, "records no proof of its files (a run of an older celldem?) ");
  for (const fs::path& file : finished_files(stage)) {
    const std::string name = fs::relative(file, dir_).string();
    if (!fs::exists(file)) refuse(file, "was removed");
    if (proof.value(name, std::string()) != fnv1a_hex(read_file(file))) refuse(file, "was changed");
  }
  const Json& entry = summary_entry(stage);
  if (entry.is_null()) refuse(dir_ / kSummaryName, "lost the stage's results");
  if (proof.value("summary.json", std::string()) != fnv1a_hex(entry.dump())) refuse(dir_ / kSummaryName, "was changed");
}

void RunDirectory::add_warning(const std::string& warning) {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::fprintf(stderr, "celldem: warning: %s\n", warning.c_str());
  for (const auto& known : summary_["warnings"])
    if (known == warning) return;
  summary_["warnings"].push_back(warning);
}

void RunDirectory::update_summary(const std::function<void(Json&)>& change) {
  const std::lock_guard<std::mutex> lock(mutex_);
  change(summary_);
}

Json RunDirectory::summary() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return summary_;
}

void RunDirectory::write_summary() {
  const std::lock_guard<std::mutex> lock(mutex_);
  write_file_atomic(dir_ / kSummaryName, summary_.dump(2));
}

void RunDirectory::write_progress() { write_file_atomic(dir_ / kProgressName, progress_.dump(2)); }

}  // namespace celldem
