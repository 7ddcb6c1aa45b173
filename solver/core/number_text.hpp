#pragma once
// Numbers as messages and JSON write them, in one place: every file prints a number the same way.
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace celldem {

// As a stream writes it (six significant digits): deck messages and the printed key table.
inline std::string fmt(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

// Three significant digits: verdicts, warnings and plans, where the reader wants the size, not the digits.
inline std::string fmt3(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

// Ten significant digits: the probes' reasons, whose numbers a reader compares with the CSV.
inline std::string fmt10(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", x);
  return buf;
}

// A JSON number, or null where it is not finite (JSON has no NaN or infinity).
inline nlohmann::json number_or_null(double x) {
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

}  // namespace celldem
