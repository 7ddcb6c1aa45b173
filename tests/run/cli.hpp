// Running the celldem binary from a test: a clean folder per test under the build tree, the exit code and
// what the binary printed.
#pragma once
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <vector>
#include <string>

#include "helpers.hpp"
#include "measure/series.hpp"

namespace celldem::testing {

namespace fs = std::filesystem;

inline const char* kBinary = CELLDEM_BINARY;

// A clean folder for one test under the build tree's e2e folder.
inline fs::path test_dir(const std::string& name) {
  const fs::path dir = fs::path(CELLDEM_E2E_DIR) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

struct Result {
  int code = -1;
  std::string out, err;
};

// Runs the binary with the given arguments (already quoted), capturing stdout and stderr in files.
inline Result celldem(const fs::path& dir, const std::string& args) {
  const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string cmd = std::string("'") + kBinary + "' " + args + " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(cmd.c_str());
  Result r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = testing::read_bytes(out);
  r.err = testing::read_bytes(err);
  return r;
}

inline const std::string kTtc = R"([{"name": "ttc", "friction": 0.5,
    "axes": {"x1": {"strain_increment": 4e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
    "end": {"axis": "x1", "strain": 0.004}, "output_interval": 100}])";

inline std::string run_args(const fs::path& deck, const fs::path& out, const std::string& extra = "") {
  return "run '" + deck.string() + "' --out '" + out.string() + "' --threads 1 " + extra;
}

// A series.csv as rows of named values.
inline std::vector<SeriesRow> read_series(const fs::path& path) {
  std::istringstream in(testing::read_bytes(path));
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream ss(line);
  for (std::string c; std::getline(ss, c, ',');) header.push_back(c);
  std::vector<SeriesRow> rows;
  while (std::getline(in, line)) rows.push_back(parse_series_row(header, line).value());
  return rows;
}

}  // namespace celldem::testing
