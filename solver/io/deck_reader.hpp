// Reading a deck: JSON text -> core/deck.hpp structs, validated against the key table (core/deck_schema.hpp).
// The only place that knows JSON decks.
#pragma once
#include <string>

#include "core/deck.hpp"

namespace celldem {

// Parse and validate. Throws DeckError naming the key path on any problem (unknown or duplicate keys, wrong
// types, values out of range, inconsistent tests).
Deck parse_deck(const std::string& json_text, const std::string& source = "<deck>");
Deck read_deck(const std::string& path);

// The key table as a Markdown table (the README's deck section) or as a JSON array.
std::string deck_schema_markdown();
std::string deck_schema_json();

}  // namespace celldem
