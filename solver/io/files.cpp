#include "io/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>

namespace celldem {
namespace fs = std::filesystem;

void throw_io_error(const fs::path& path, const std::string& what, int error_number) {
  throw IoError(path.string() + ": " + what + ": " + std::strerror(error_number));
}

namespace {

// Writes all of `bytes` at the file's current offset; returns 0 or the errno of the failure.
int write_all(int fd, std::string_view bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    if (n == 0) return EIO;
    done += static_cast<std::size_t>(n);
  }
  return 0;
}

// Opens `path` for writing with `flags` (O_NOFOLLOW added): a link there is named as such, not written through.
int open_for_writing(const fs::path& path, int flags, const char* what) {
  const int fd = ::open(path.c_str(), flags | O_WRONLY | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd >= 0) return fd;
  const int error = errno;
  struct stat st {};
  if (error == ELOOP && ::lstat(path.c_str(), &st) == 0 && S_ISLNK(st.st_mode))
    throw IoError(path.string() + ": " + what + ": it is a symbolic link, and celldem writes through no link "
                  "(remove it)");
  throw_io_error(path, what, error);
}

// Writes `bytes` whole to a new file at `path` (no file or link there), synced; IoError naming it on failure.
void write_new_file(const fs::path& path, std::string_view bytes) {
  const int fd = open_for_writing(path, O_CREAT | O_EXCL, "cannot create");
  int error = write_all(fd, bytes);
  // fsync: a full disk may only show when the data reach it (delayed allocation).
  if (!error && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && !error) error = errno;
  if (error) throw_io_error(path, "cannot write", error);
}

bool skipped(const fs::path& p, const std::vector<std::string>& skip) {
  return std::find(skip.begin(), skip.end(), p.filename().string()) != skip.end();
}

// The entries of a folder, sorted by name.
std::vector<fs::directory_entry> entries_of(const fs::path& dir) {
  std::vector<fs::directory_entry> out;
  std::error_code error;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) out.push_back(*it);
  if (error) throw_io_error(dir, "cannot list", error.value());
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.path() < b.path(); });
  return out;
}

}  // namespace

void copy_tree(const fs::path& from, const fs::path& to, const std::vector<std::string>& skip) {
  if (::mkdir(to.c_str(), 0755) != 0) throw_io_error(to, "cannot create the folder", errno);
  for (const fs::directory_entry& e : entries_of(from)) {
    if (skipped(e.path(), skip)) continue;
    const fs::path target = to / e.path().filename();
    const fs::file_status st = e.symlink_status();
    if (fs::is_directory(st))
      copy_tree(e.path(), target, skip);
    else if (fs::is_regular_file(st))
      write_new_file(target, read_file(e.path()));
    else
      throw IoError(e.path().string() + ": not copied: " +
                    (fs::is_symlink(st) ? "a symbolic link" : "neither a file nor a folder") +
                    " (a run folder holds only files and folders)");
  }
  sync_folder(to);
}

std::string tree_difference(const fs::path& a, const fs::path& b, const std::vector<std::string>& skip) {
  std::vector<fs::directory_entry> ea = entries_of(a), eb = entries_of(b);
  const auto drop = [&](std::vector<fs::directory_entry>& v) {
    v.erase(std::remove_if(v.begin(), v.end(), [&](const auto& e) { return skipped(e.path(), skip); }), v.end());
  };
  drop(ea);
  drop(eb);
  for (std::size_t i = 0; i < std::max(ea.size(), eb.size()); ++i) {
    if (i >= ea.size() || i >= eb.size() || ea[i].path().filename() != eb[i].path().filename())
      return (i < ea.size() ? ea[i] : eb[i]).path().filename().string();
    const fs::path name = ea[i].path().filename();
    const bool da = fs::is_directory(ea[i].symlink_status()), db = fs::is_directory(eb[i].symlink_status());
    if (da != db) return name.string();
    if (da) {
      if (const std::string d = tree_difference(ea[i].path(), eb[i].path(), skip); !d.empty())
        return (name / d).string();
    } else if (read_file(ea[i].path()) != read_file(eb[i].path())) {
      return name.string();
    }
  }
  return "";
}

void sync_folder(const fs::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) throw_io_error(dir, "cannot open the folder", errno);
  int error = ::fsync(fd) != 0 ? errno : 0;
  // Some file systems cannot sync a folder (EINVAL): their renames are as durable as they get.
  if (error == EINVAL) error = 0;
  ::close(fd);
  if (error) throw_io_error(dir, "cannot sync the folder", error);
}

void write_file_atomic(const fs::path& path, std::string_view bytes) {
  const fs::path tmp = path.string() + ".tmp";
  // A temporary a killed process left (or a link put there) is removed, never written through.
  if (::unlink(tmp.c_str()) != 0 && errno != ENOENT) throw_io_error(tmp, "cannot remove", errno);
  const int fd = open_for_writing(tmp, O_CREAT | O_EXCL, "cannot create");
  int error = write_all(fd, bytes);
  // fsync: a full disk may only show when the data reach it (delayed allocation).
  if (!error && ::fsync(fd) != 0) error = errno;
  if (::close(fd) != 0 && !error) error = errno;
  if (error) {
    ::unlink(tmp.c_str());
    throw_io_error(path, "cannot write", error);
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    throw_io_error(path, "cannot replace", e);
  }
}

std::string read_file(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw_io_error(path, "cannot read", errno);
  std::string out;
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      ::close(fd);
      throw_io_error(path, "cannot read", e);
    }
    if (n == 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return out;
}

AppendFile::AppendFile(const fs::path& path, bool truncate) : path_(path) {
  fd_ = open_for_writing(path, O_CREAT | (truncate ? O_TRUNC : O_APPEND), "cannot open for writing");
  const off_t end = ::lseek(fd_, 0, SEEK_END);
  if (end < 0) throw_io_error(path, "cannot seek", errno);
  size_ = end;
}

AppendFile::~AppendFile() {
  if (fd_ >= 0) ::close(fd_);
}

AppendFile::AppendFile(AppendFile&& other) noexcept
    : path_(std::move(other.path_)), fd_(other.fd_), size_(other.size_) {
  other.fd_ = -1;
}

AppendFile& AppendFile::operator=(AppendFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    path_ = std::move(other.path_);
    fd_ = other.fd_;
    size_ = other.size_;
    other.fd_ = -1;
  }
  return *this;
}

void AppendFile::append(std::string_view record) {
  if (const int error = write_all(fd_, record)) {
    // Cut back a partly written record, so the file ends with the last whole one.
    if (::ftruncate(fd_, size_) == 0) ::lseek(fd_, size_, SEEK_SET);
    throw_io_error(path_, "cannot write", error);
  }
  size_ += static_cast<long long>(record.size());
}

std::string fnv1a_hex(std::string_view bytes) {
  std::uint64_t hash = 14695981039346656037ull;
  for (const char c : bytes) hash = (hash ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(hash));
  return buf;
}

}  // namespace celldem
