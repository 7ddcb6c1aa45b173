// Reading a deck: JSON text -> core/deck.hpp structs, validated against the key table (core/deck_schema.hpp).
// The only place that knows JSON decks (with io/deck_prescan.cpp, which parses their text; the key table is
// printed by io/schema_print.hpp).
#pragma once
#include <optional>
#include <string>

#include "core/deck.hpp"

namespace celldem {

// Parse and validate. Throws DeckError naming the key path on any problem (unknown or duplicate keys, wrong
// types, values out of range, inconsistent tests).
Deck parse_deck(const std::string& json_text, const std::string& source = "<deck>");
// With a tolerance (the argument, else the deck's `tolerance` key) the deck is rewritten by the time-to-answer
// rules (io/tolerance.hpp) and read again; read_deck_as_written leaves the key unapplied.
Deck read_deck(const std::string& path, std::optional<double> tolerance = std::nullopt);
Deck read_deck_as_written(const std::string& path);

}  // namespace celldem
