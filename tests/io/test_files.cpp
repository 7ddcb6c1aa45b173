// Checked file writes (solver/io/files.hpp): a full disk named as such, no write through a symbolic link, a folder
// copied whole and compared.
#include <gtest/gtest.h>

#include <filesystem>

#include "helpers.hpp"
#include "io/files.hpp"

namespace celldem {
namespace {

namespace fs = std::filesystem;

TEST(Files, AFullDiskIsNamedWithTheFile) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  AppendFile file("/dev/full", false);
  try {
    file.append("a row\n");
    FAIL() << "a write to /dev/full succeeded";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/full: cannot write: No space left on device"), std::string::npos)
        << e.what();
  }
}

TEST(Files, NothingIsWrittenThroughALink) {
  testing::TempDir dir;
  testing::write_bytes(dir.path() / "other.csv", "another run's rows\n");
  fs::create_symlink(dir.path() / "other.csv", dir.path() / "series.csv");
  try {
    AppendFile file(dir.path() / "series.csv", false);
    FAIL() << "a link was opened for writing";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("series.csv: cannot open for writing: it is a symbolic link"),
              std::string::npos) << e.what();
  }
  // A link at a temporary's name is removed, not written through; a link at the file's name is replaced.
  fs::create_symlink(dir.path() / "other.csv", dir.path() / "summary.json.tmp");
  write_file_atomic(dir.path() / "summary.json", "{}");
  fs::create_symlink(dir.path() / "other.csv", dir.path() / "progress.json");
  write_file_atomic(dir.path() / "progress.json", "{}");
  EXPECT_EQ(testing::read_bytes(dir.path() / "other.csv"), "another run's rows\n");
  EXPECT_FALSE(fs::is_symlink(dir.path() / "progress.json"));
  EXPECT_EQ(testing::read_bytes(dir.path() / "progress.json"), "{}");
  EXPECT_FALSE(fs::exists(dir.path() / "summary.json.tmp"));
}

TEST(Files, AFolderIsCopiedWholeAndCompared) {
  testing::TempDir dir;
  const fs::path from = dir.path() / "seed-1";
  fs::create_directories(from / "ttc" / "probes" / "p1");
  testing::write_bytes(from / "progress.json", "{\"completed\": []}");
  testing::write_bytes(from / "run.lock", "123\n");
  testing::write_bytes(from / "ttc" / "series.csv", std::string(200000, 'x'));
  testing::write_bytes(from / "ttc" / "probes" / "p1" / "result.json", "{}");
  copy_tree(from, dir.path() / "copy", {"run.lock"});
  EXPECT_EQ(tree_difference(from, dir.path() / "copy", {"run.lock"}), "");
  EXPECT_FALSE(fs::exists(dir.path() / "copy" / "run.lock"));
  EXPECT_EQ(tree_difference(from, dir.path() / "copy"), "run.lock");
  testing::write_bytes(dir.path() / "copy" / "ttc" / "probes" / "p1" / "result.json", "{ }");
  EXPECT_EQ(tree_difference(from, dir.path() / "copy", {"run.lock"}), "ttc/probes/p1/result.json");
  testing::write_bytes(dir.path() / "copy" / "ttc" / "probes" / "p1" / "result.json", "{}");
  fs::remove(dir.path() / "copy" / "ttc" / "series.csv");
  EXPECT_EQ(tree_difference(from, dir.path() / "copy", {"run.lock"}), "ttc/series.csv");
  // Onto a folder that is there: refused, naming it.
  EXPECT_THROW(copy_tree(from, dir.path() / "copy"), IoError);
  // A link in the source is not copied (nor followed).
  fs::create_symlink("/etc/passwd", from / "ttc" / "link");
  EXPECT_THROW(copy_tree(from, dir.path() / "copy2"), IoError);
}

}  // namespace
}  // namespace celldem
