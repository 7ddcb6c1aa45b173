// Reading a deck: JSON text -> core/deck.hpp structs, validated against the key table (core/deck_schema.hpp).
// The only place that knows JSON decks (with io/deck_prescan.cpp, which parses their text; the key table is
// printed by io/schema_print.hpp).
#pragma once
#include <string>

#include "core/deck.hpp"

namespace celldem {

// Parse and validate. Throws DeckError naming the key path on any problem (unknown or duplicate keys, wrong
// types, values out of range, inconsistent tests).
Deck parse_deck(const std::string& json_text, const std::string& source = "<deck>");
Deck read_deck(const std::string& path);

}  // namespace celldem
