#include "io/series_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <string>
#include <string_view>

#include "io/files.hpp"

namespace celldem {

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  for (std::string f; std::getline(ss, f, ',');) fields.push_back(f);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

// A field as a number: empty and "nan" are NaN; anything else must parse whole.
bool parse_field(const std::string& field, double& value) {
  if (field.empty()) {
    value = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  char* end = nullptr;
  value = std::strtod(field.c_str(), &end);
  return end != field.c_str() && *end == '\0';
}

}  // namespace

std::vector<SeriesRow> read_series_file(const std::filesystem::path& path) {
  std::string text;
  try {
    text = read_file(path);
  } catch (const IoError& e) {
    throw SeriesFileError(e.what());
  }
  std::stringstream in(text);
  std::string line;
  if (!std::getline(in, line)) throw SeriesFileError(path.string() + ": empty file (no header)");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  const std::vector<std::string> header = split(line);

  auto has = [&](std::string_view name) { return std::find(header.begin(), header.end(), name) != header.end(); };
  for (const char* needed : {"e1", "ev", "Z"})
    if (!has(needed)) throw SeriesFileError(path.string() + ": no column \"" + needed + "\" in the header");
  const bool has_ratio = has("ratio13");
  if (!has_ratio && !(has("s11") && has("s33")))
    throw SeriesFileError(path.string() + ": no column \"ratio13\", nor \"s11\" and \"s33\" to make it");
  std::vector<const SeriesColumn*> columns;  // per field of a line: its column, or null if celldem has none
  for (const std::string& name : header) columns.push_back(find_series_column(name));

  SeriesRow missing;  // every column the file lacks reads NaN
  for (const SeriesColumn& c : series_columns()) missing.*c.field = std::numeric_limits<double>::quiet_NaN();

  std::vector<SeriesRow> rows;
  for (std::size_t number = 2; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const std::vector<std::string> fields = split(line);
    const std::string where = path.string() + ":" + std::to_string(number);
    if (fields.size() != header.size())
      throw SeriesFileError(where + ": " + std::to_string(fields.size()) + " fields under a header of " +
                            std::to_string(header.size()) + " (a row cut short?)");
    SeriesRow row = missing;
    for (std::size_t k = 0; k < fields.size(); ++k) {
      double value = 0.0;
      if (!parse_field(fields[k], value))
        throw SeriesFileError(where + ": column \"" + header[k] + "\": \"" + fields[k] + "\" is not a number");
      if (columns[k]) row.*columns[k]->field = value;
    }
    if (!has_ratio) row.ratio13 = row.s33 != 0.0 ? row.s11 / row.s33 : std::numeric_limits<double>::quiet_NaN();
    rows.push_back(row);
  }
  if (rows.empty()) throw SeriesFileError(path.string() + ": a header and no rows");
  return rows;
}

}  // namespace celldem
