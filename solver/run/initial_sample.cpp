#include "run/initial_sample.hpp"

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/number_text.hpp"
#include "io/files.hpp"
#include "io/lammps_data.hpp"
#include "io/state_file.hpp"

namespace celldem {

std::string initial_state_path(const Deck& deck) {
  return (std::filesystem::path(deck.source).parent_path() / deck.initial_state.value()).string();
}

State load_initial_state(const Deck& deck) { return load_initial_sample(deck).state; }

std::string state_physics(const Deck& deck) {
  const ContactDef& c = deck.contact;
  nlohmann::json p = {{"sample.density", deck.sample.density},
                      {"contact.normal", std::string(name_of(c.normal, kNormalModelNames))},
                      {"contact.tangential", std::string(name_of(c.tangential, kTangentialModelNames))},
                      {"contact.rolling", std::string(name_of(c.rolling, kRollingModelNames))},
                      {"contact.twisting", std::string(name_of(c.twisting, kTwistingModelNames))}};
  // The elastic parameters the deck's sub-model choices use (the key table's rule, key_used).
  for (const ContactParameter& parameter : kContactParameters)
    if (parameter.elastic && key_used(*parameter.key, c.selection()))
      p[std::string(parameter.key->path)] = c.*parameter.field;
  return p.dump();
}

InitialSample load_initial_sample(const Deck& deck) {
  const std::string path = initial_state_path(deck);
  InitialSample sample;
  if (read_file(path).rfind("CELLDEMS", 0) == 0) {
    sample.state = read_state(path, nullptr, &sample.physics);
    sample.state_file = true;
    return sample;
  }
  LammpsData data;
  try {
    data = read_lammps_data(path);
  } catch (const LammpsDataError& e) {
    throw DeckError(std::string("initial_state: neither a celldem state file nor a readable LAMMPS data file: ") +
                    e.what());
  }
  if (!data.common_density)
    throw DeckError("initial_state: " + path + " gives its atoms different densities; celldem has one (sample.density)");
  if (std::abs(*data.common_density - deck.sample.density) > 1e-12 * deck.sample.density)
    throw DeckError("sample.density: the deck says " + fmt(deck.sample.density) + " kg/m^3, initial_state " + path +
                    " says " + fmt(*data.common_density));
  sample.state = std::move(data.state);
  sample.atom_ids = std::move(data.ids);
  return sample;
}

}  // namespace celldem
