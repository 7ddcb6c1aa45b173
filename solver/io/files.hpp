// Output files whose every write is checked. A failed write (a full disk, a lost mount) throws IoError
// naming the file and the system's reason; nothing partial is left where a reader would take it for data.
#pragma once
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace celldem {

struct IoError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Writes the whole file under a temporary name beside it, then renames it over `path`: readers see the old
// file or the new one, whole. On failure the temporary is removed and the old file is left as it was. A link at
// `path` is replaced, never written through (the temporary is created anew, O_EXCL).
void write_file_atomic(const std::filesystem::path& path, std::string_view bytes);

// Reads a whole file; IoError if it cannot be read.
std::string read_file(const std::filesystem::path& path);

// A text file written by appending whole records (series rows). Each record goes to the file in one
// write; if it cannot be written whole, the file is cut back to its previous length, so it never ends in a
// partial record. A link at the path is refused (IoError naming it), not written through.
class AppendFile {
 public:
  AppendFile() = default;
  AppendFile(const std::filesystem::path& path, bool truncate);
  ~AppendFile();
  AppendFile(AppendFile&& other) noexcept;
  AppendFile& operator=(AppendFile&& other) noexcept;
  AppendFile(const AppendFile&) = delete;
  AppendFile& operator=(const AppendFile&) = delete;

  void append(std::string_view record);
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
  long long size_ = 0;
};

// The FNV-1a 64 hash of `bytes` as 16 hex digits: what a run records of a file it will trust again on --resume.
std::string fnv1a_hex(std::string_view bytes);

// Copies the folder `from` to `to` (which must not exist): folders and regular files, each file's every write checked
// and synced (a full disk is named as such, with the file), entries named in `skip` (at any depth) left out. Writes
// through no link: `to` and every file are created anew (O_EXCL, O_NOFOLLOW); a link or a device in `from` is
// refused (IoError naming it). On failure what was made of `to` is left for the caller to remove.
void copy_tree(const std::filesystem::path& from, const std::filesystem::path& to,
               const std::vector<std::string>& skip = {});

// The relative path of the first file or folder in which the trees `a` and `b` differ (present in one only, a
// folder in one and a file in the other, other bytes), or "" when they hold the same; `skip` as for copy_tree.
std::string tree_difference(const std::filesystem::path& a, const std::filesystem::path& b,
                            const std::vector<std::string>& skip = {});

// Syncs a folder's entries (a rename or a new file in it) to the disk; IoError on failure.
void sync_folder(const std::filesystem::path& dir);

// "<path>: <what>: <strerror(errno)>"
[[noreturn]] void throw_io_error(const std::filesystem::path& path, const std::string& what, int error_number);

}  // namespace celldem
