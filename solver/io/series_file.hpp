// Reading a series file back: celldem's own series.csv, or any CSV whose header names some of its columns
// (another code's run of a translated deck), so that `celldem summarize` applies run/summary's definitions to
// it. A column the file lacks, an empty field and "nan" read as NaN; s11/s33 stands in for a missing ratio13
// (translated scripts write the stresses only). Columns celldem does not know are ignored.
#pragma once
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "measure/series.hpp"

namespace celldem {

struct SeriesFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The rows of a series file; SeriesFileError naming the file (and line) when it cannot be read, has no rows,
// lacks a column every summary needs (e1, ev, Z and either ratio13 or s11 and s33), or holds a field that is
// not a number.
std::vector<SeriesRow> read_series_file(const std::filesystem::path& path);

}  // namespace celldem
