// What the deck's files share (internal to io/): deck_reader.cpp reads a deck into core/deck.hpp's structs,
// deck_prescan.cpp parses its JSON text, schema_print.cpp prints the key table.
#pragma once
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <string_view>

#include "core/deck.hpp"
#include "core/number_text.hpp"

namespace celldem::deck_json {

using Json = nlohmann::json;

// The top-level object has the empty path: its messages name "deck".
[[noreturn]] inline void fail(const std::string& path, const std::string& what) {
  throw DeckError((path.empty() ? std::string("deck") : path) + ": " + what);
}

// The path of `key` in the object at `parent` ("" for the top level), as messages name it: parent.key for a
// key of letters, digits and '_' (every key the schema knows), else parent["key"] with the key quoted as JSON
// writes it, so that an empty key or one holding '.', '[' or spaces is seen for what it is (sample[""],
// deck["a.b"]).
inline std::string key_path(const std::string& parent, std::string_view key) {
  const bool plain = !key.empty() && key.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                                           "0123456789_") == std::string_view::npos;
  if (plain) return parent.empty() ? std::string(key) : parent + "." + std::string(key);
  const std::string quoted = Json(std::string(key)).dump(-1, ' ', false, Json::error_handler_t::replace);
  return (parent.empty() ? std::string("deck") : parent) + "[" + quoted + "]";
}

// Parses JSON, refusing what the JSON library would silently accept: a key given twice in one object (the
// library keeps the last) and absurd nesting.
// (deck_prescan.cpp)
Json parse_json(const std::string& json_text);

}  // namespace celldem::deck_json
