// What the deck's files share (internal to io/): deck_reader.cpp reads a deck into core/deck.hpp's structs,
// deck_prescan.cpp parses its JSON text, schema_print.cpp prints the key table.
#pragma once
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "core/deck.hpp"

namespace celldem::deck_json {

using Json = nlohmann::json;

// A number as the messages and the printed key table write it.
inline std::string fmt(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

// The top-level object has the empty path: its messages name "deck".
[[noreturn]] inline void fail(const std::string& path, const std::string& what) {
  throw DeckError((path.empty() ? std::string("deck") : path) + ": " + what);
}

// Parses JSON, refusing what the JSON library would silently accept: a key given twice in one object (the
// library keeps the last) and absurd nesting.
// (deck_prescan.cpp)
Json parse_json(const std::string& json_text);

}  // namespace celldem::deck_json
