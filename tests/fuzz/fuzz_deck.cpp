// libFuzzer target: any bytes given to the deck parser end in a Deck or a DeckError, never a crash or hang.
#include <cstddef>
#include <cstdint>
#include <string>

#include "io/deck_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)celldem::parse_deck(std::string(reinterpret_cast<const char*>(data), size), "<fuzz>");
  } catch (const celldem::DeckError&) {
  }
  return 0;
}
