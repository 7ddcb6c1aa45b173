#include "run/run_directory.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
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

namespace {

// The pid /proc/locks gives for a flock on the file `st` describes (0 when none is listed, or the kernel's list
// cannot be read): the kernel's own word on who holds it.
long kernel_holder(const struct stat& st) {
  std::ifstream locks("/proc/locks");
  std::string line;
  long by_inode = 0;
  while (std::getline(locks, line)) {
    std::istringstream in(line);
    std::string id, kind, advisory, access, where;
    long pid = 0;
    in >> id >> kind;
    if (kind == "->") continue;  // a process waiting for the lock, not holding it
    in >> advisory >> access >> pid >> where;
    unsigned major_no = 0, minor_no = 0;
    unsigned long inode = 0;
    if (kind != "FLOCK" || pid <= 0 || std::sscanf(where.c_str(), "%x:%x:%lu", &major_no, &minor_no, &inode) != 3 ||
        inode != st.st_ino)
      continue;
    if (major_no == major(st.st_dev) && minor_no == minor(st.st_dev)) return pid;
    by_inode = pid;  // (some file systems list another device number than stat gives)
  }
  return by_inode;
}

// The pid the holder wrote into its lock file, when that process is alive (0 otherwise: not yet written, or a
// process that died and left its pid there).
long written_holder(const fs::path& lock_file) {
  const int fd = ::open(lock_file.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return 0;
  char text[32] = {};
  const ssize_t n = ::pread(fd, text, sizeof text - 1, 0);
  ::close(fd);
  const long pid = n > 0 ? std::strtol(text, nullptr, 10) : 0;
  return pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM) ? pid : 0;
}

// Takes the flock `op` on `fd` (held by another: tries again for a moment, as its holder may be about to end or a
// tool only probing it) or throws UsageError naming the holder.
void take_flock(int fd, int op, const fs::path& dir, const fs::path& lock_file) {
  long holder = 0;
  for (int attempt = 0; attempt < 20; ++attempt) {
    if (::flock(fd, op | LOCK_NB) == 0) return;
    if (errno != EWOULDBLOCK)
      throw UsageError(lock_file.string() + ": cannot lock (" + std::strerror(errno) + ")");
    struct stat st {};
    if (::fstat(fd, &st) == 0) holder = kernel_holder(st);
    if (holder == 0) holder = written_holder(lock_file);
    ::usleep(10000);
  }
  throw UsageError(dir.string() + " is in use by another celldem process (pid " +
                   (holder > 0 ? std::to_string(holder) : std::string("unknown")) + ", holding " +
                   lock_file.string() + "): wait for it to end, or stop it (a stopped run continues with --resume)");
}

// Opens run.lock (created for an exclusive lock; -1 for a shared one where there is none or it cannot be read),
// refusing a link or anything but a file there.
int open_lock_file(const fs::path& path, LockMode mode) {
  const int flags = (mode == LockMode::exclusive ? O_RDWR | O_CREAT : O_RDONLY) | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK;
  const int fd = ::open(path.c_str(), flags, 0644);
  struct stat st {};
  if (fd < 0) {
    const int error = errno;
    if (::lstat(path.c_str(), &st) == 0 && S_ISLNK(st.st_mode))
      throw UsageError(path.string() + " is a symbolic link: celldem does not follow it (it would write into the "
                       "file it names); remove the link and start again");
    if (mode == LockMode::shared && (error == ENOENT || error == EACCES)) return -1;
    throw UsageError(path.parent_path().string() + ": cannot " +
                     (mode == LockMode::exclusive ? "write in" : "read") + " the run folder (" +
                     std::strerror(error) + ")");
  }
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw UsageError(path.string() + " is not a file (a folder or a device): it cannot be the run folder's lock; "
                     "remove it and start again");
  }
  return fd;
}

// Whether `fd` is the file at `path` now (not one deleted or replaced since it was opened).
bool names_file(const fs::path& path, int fd) {
  struct stat opened {}, named {};
  return ::fstat(fd, &opened) == 0 && ::lstat(path.c_str(), &named) == 0 && opened.st_dev == named.st_dev &&
         opened.st_ino == named.st_ino;
}

}  // namespace

FolderLock::FolderLock(const fs::path& dir, LockMode mode) {
  const int op = mode == LockMode::exclusive ? LOCK_EX : LOCK_SH;
  if (mode == LockMode::exclusive) create_run_folder(dir);
  else if (!fs::is_directory(dir)) throw UsageError(dir.string() + ": not a folder");
  const fs::path path = dir / kLockName;
  dir_fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd_ < 0) throw UsageError(dir.string() + ": cannot open the run folder (" + std::strerror(errno) + ")");
  try {
    if (::flock(dir_fd_, op | LOCK_NB) != 0) {
      if (errno == EWOULDBLOCK) {
        take_flock(dir_fd_, op, dir, path);
      } else {  // a file system that cannot lock a folder (NFS): run.lock alone stands for it
        ::close(dir_fd_);
        dir_fd_ = -1;
      }
    }
    // The lock on run.lock, on the file its path names once locked (a file deleted or replaced in between is
    // opened again).
    for (int attempt = 0;; ++attempt) {
      fd_ = open_lock_file(path, mode);
      if (fd_ < 0) break;
      take_flock(fd_, op, dir, path);
      if (names_file(path, fd_)) break;
      ::close(fd_);
      fd_ = -1;
      if (attempt == 20) throw UsageError(path.string() + ": replaced again and again while being locked");
    }
  } catch (...) {
    release();
    throw;
  }
}

void FolderLock::claim() {
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (fd_ < 0 || ::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    // The pid is only for the message of a process refused (the kernel's /proc/locks first): the lock holds without it.
  }
}

void FolderLock::release() {
  if (fd_ >= 0) ::close(fd_);  // releases the locks
  if (dir_fd_ >= 0) ::close(dir_fd_);
  fd_ = dir_fd_ = -1;
}

FolderLock::~FolderLock() { release(); }

FolderLock& FolderLock::operator=(FolderLock&& other) noexcept {
  if (this != &other) {
    release();
    fd_ = other.fd_;
    dir_fd_ = other.dir_fd_;
    other.fd_ = other.dir_fd_ = -1;
  }
  return *this;
}

void refuse_links_out(const fs::path& dir, const std::string& name) {
  std::error_code error;
  const fs::path root = fs::weakly_canonical(dir, error);
  const auto check = [&](const fs::path& p) {
    std::error_code e;
    if (!fs::is_symlink(fs::symlink_status(p, e))) return;
    const fs::path target = fs::weakly_canonical(p, e);
    const bool inside = std::mismatch(root.begin(), root.end(), target.begin(), target.end()).first == root.end();
    if (e || !inside)
      throw UsageError(p.string() + " is a symbolic link to " + fs::read_symlink(p, e).string() +
                       ", outside the run folder " + dir.string() + ": celldem writes nothing through it (remove the "
                       "link, or give the run another folder)");
  };
  const fs::path top = dir / name;
  check(top);
  if (fs::is_symlink(fs::symlink_status(top, error)) || !fs::is_directory(top, error)) return;
  for (fs::recursive_directory_iterator it(top, error), end; !error && it != end; it.increment(error))
    check(it->path());
}

RunDirectory::RunDirectory(const Deck& deck, const RunOptions& options)
    : dir_(options.out_dir), resume_(options.resume) {
  // --resume of a folder that is not there is refused without creating it.
  if (options.resume && !fs::exists(dir_ / kProgressName))
    throw UsageError(dir_.string() + " holds no interrupted run to resume (no " + kProgressName + ")");
  lock_ = FolderLock(dir_);
  // Nothing is written through a link out of the folder (a stage folder linked into another run).
  if (deck.prepare) refuse_links_out(dir_, "prepare");
  for (const TestDef& test : deck.tests) refuse_links_out(dir_, test.name);
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
    for (const Json& stage : progress_["completed"]) {
      if (!stage.is_string()) throw UsageError((dir_ / kProgressName).string() + ": a completed stage is not a name");
      check_finished(stage.get<std::string>());
      // Killed between marking the stage done and removing its checkpoint: the checkpoint is stale, removed.
      remove_checkpoint(stage.get<std::string>());
    }
    // Killed inside a summary or progress write: its temporary is stale (the file it would have replaced is whole,
    // the rename being the commit), removed even where the run is complete and writes nothing more.
    for (const char* name : {kSummaryName, kProgressName}) {
      const fs::path tmp = dir_ / (std::string(name) + ".tmp");
      if (::unlink(tmp.c_str()) != 0 && errno != ENOENT) throw_io_error(tmp, "cannot remove", errno);
    }
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
  remove_checkpoint(stage);
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

void RunDirectory::remove_checkpoint(const std::string& stage) {
  const fs::path p = checkpoint(stage);
  if (::unlink(p.c_str()) != 0 && errno != ENOENT) throw_io_error(p, "cannot remove", errno);
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
