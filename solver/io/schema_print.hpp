// Printing the deck's key table (core/deck_schema.hpp): `celldem schema`, the key table of docs/deck.md and,
// as JSON, the Python tools.
#pragma once
#include <string>

namespace celldem {

// The key table as a Markdown table (the README's deck section) or as a JSON array.
std::string deck_schema_markdown();
std::string deck_schema_json();

}  // namespace celldem
