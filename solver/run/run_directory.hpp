// A run directory and its lifecycle: a fresh run refuses to overwrite results (or, with --force, removes
// every output of the earlier run first); a resumed run reloads what the interrupted one recorded.
// progress.json holds the deck, the completed stages and each stage's elapsed time; summary.json the
// results. Tests may run side by side, so every change to either goes through this class, under its lock.
#pragma once
#include <filesystem>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "run/errors.hpp"
#include "run/run_options.hpp"

namespace celldem {

inline constexpr const char* kCheckpointName = "checkpoint.state";  // in the stage's folder
inline constexpr const char* kPreparedName = "prepared.state";
// The deck a run with --tolerance ran: rewritten by the time-to-answer rules, runnable as written.
inline constexpr const char* kResolvedDeckName = "resolved_deck.json";
inline constexpr const char* kProgressName = "progress.json";
inline constexpr const char* kSummaryName = "summary.json";
// The run folder's owner: an advisory lock (flock) on this file, with the holder's pid in it for the message.
inline constexpr const char* kLockName = "run.lock";

// Who may use a run folder beside whom: one writer alone, or any number of readers (a merge reading its shares).
enum class LockMode { exclusive, shared };

// One owner per run folder at a time: run, --resume, --force and merge hold an exclusive flock on the folder itself
// (DIR, opened as a folder) and on DIR/run.lock for as long as they write there; a merge holds shared locks on the
// shares it only reads (which may then be read-only). Locking the folder itself makes the lock hold when run.lock is
// deleted or replaced under a live run; run.lock is kept for the tools that wait on it (tools/celldem/binary.py), is
// never followed when it is a symbolic link (refused), and is verified after locking to be the file at its path. A
// second process is refused (UsageError naming the holder's pid, as the kernel tells it: /proc/locks, else the pid
// the holder wrote into run.lock once it went on to write: a refused command changes no file); the kernel drops the locks of a process that dies, so the
// file a killed run leaves behind is taken over. An exclusive lock creates DIR; a shared one requires it.
class FolderLock {
 public:
  FolderLock() = default;
  explicit FolderLock(const std::filesystem::path& dir, LockMode mode = LockMode::exclusive);
  ~FolderLock();
  FolderLock(FolderLock&& other) noexcept : dir_fd_(other.dir_fd_), fd_(other.fd_) { other.dir_fd_ = other.fd_ = -1; }
  FolderLock& operator=(FolderLock&& other) noexcept;
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  // Writes this process's pid into the lock file: once the holder goes on to write in the folder (a command refused
  // for another reason leaves the folder's files as they were).
  void claim();

 private:
  void release();
  int dir_fd_ = -1;  // the folder's own lock (-1 where the file system cannot lock a folder)
  int fd_ = -1;      // run.lock's
};

// Refuses (UsageError naming the path and where it leads) a symbolic link at `dir`/`name` or anywhere under it whose
// target lies outside `dir`: a run writes nothing through a link into another folder (another run's series).
void refuse_links_out(const std::filesystem::path& dir, const std::string& name);

// The deck's fingerprint: a hash (FNV-1a 64, hex) of its canonical text (progress.json's "deck") without the sample's
// seed, so that the seeds of one ensemble share it and runs of decks that differ in anything else do not.
std::string deck_fingerprint(const std::string& canonical_deck);

// Creates `dir` (a run folder given as --out), or UsageError in plain words when it cannot be one (a file, a path
// under a file, a folder that cannot be written).
void create_run_folder(const std::filesystem::path& dir);

class RunDirectory {
 public:
  RunDirectory(const Deck& deck, const RunOptions& options);

  const std::filesystem::path& path() const { return dir_; }
  std::filesystem::path stage_dir(const std::string& stage) const { return dir_ / stage; }
  std::filesystem::path checkpoint(const std::string& stage) const { return dir_ / stage / kCheckpointName; }
  std::filesystem::path prepared_state() const { return dir_ / kPreparedName; }

  bool completed(const std::string& stage) const;
  // A stage of a resumed run that has a checkpoint continues from it (its record: StageOutput).
  bool resumes(const std::string& stage) const;

  // Order matters for a kill at any moment: the summary first, then the stage marked complete (with the hashes of
  // its files and summary entry, which --resume checks), then its checkpoint removed. Killed before the stage is
  // marked, a resume re-runs the stage's tail from the checkpoint; killed after, the resume removes the stray one.
  void mark_done(const std::string& stage);

  // Prints a warning and records it in the summary, once: a resumed run reloads the summary it had written.
  void add_warning(const std::string& warning);
  // Changes the summary under the lock.
  void update_summary(const std::function<void(nlohmann::json&)>& change);
  nlohmann::json summary() const;
  void write_summary();

 private:
  void write_progress();
  // The files a finished stage leaves (its series and final state) and its entry in the summary.
  std::vector<std::filesystem::path> finished_files(const std::string& stage) const;
  const nlohmann::json& summary_entry(const std::string& stage) const;
  // UsageError naming the file when a finished stage's files or summary entry are not those it recorded.
  void check_finished(const std::string& stage) const;
  void remove_checkpoint(const std::string& stage);  // its checkpoint state, where it is

  std::filesystem::path dir_;
  FolderLock lock_;  // before anything in the folder is read or removed
  mutable std::mutex mutex_;
  nlohmann::json progress_;
  nlohmann::json summary_;
  bool resume_;
};

}  // namespace celldem
