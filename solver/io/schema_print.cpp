#include "io/schema_print.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "core/deck_schema.hpp"
#include "io/deck_parts.hpp"

namespace celldem {

namespace {

using deck_json::Json;

std::string kind_name(KeyKind kind) {
  switch (kind) {
    case KeyKind::Object: return "object";
    case KeyKind::Number: return "number";
    case KeyKind::Integer: return "integer";
    case KeyKind::String: return "string";
    case KeyKind::Choice: return "choice";
    case KeyKind::Array: return "array";
    case KeyKind::Boolean: return "boolean";
  }
  return "";
}

std::string default_of(const KeySpec& k) {
  if (!k.default_text.empty()) return std::string(k.default_text);
  if (k.required) return "required";
  if (k.kind == KeyKind::Choice) {
    std::string s = "`";
    s += k.choices.front();
    s += '`';
    return s;
  }
  return fmt(k.fallback);
}

std::string allowed_of(const KeySpec& k) {
  if (k.kind == KeyKind::Choice) {
    std::string s;
    for (const std::string_view c : k.choices) {
      s += s.empty() ? "`" : ", `";
      s += c;
      s += '`';
    }
    return s;
  }
  if (k.kind != KeyKind::Number && k.kind != KeyKind::Integer) return "";
  const std::string lo = k.positive ? "(0" : (std::isinf(k.min) ? "(-inf" : std::string("[") + fmt(k.min));
  const std::string hi = std::isinf(k.max) ? "inf)" : fmt(k.max) + "]";
  return lo + ", " + hi;
}

// The key's sub-model choices, each sub-model once with its choices in table order (an empty choice: all of
// the sub-model's choices).
std::vector<std::pair<std::string_view, std::vector<std::string_view>>> sub_models_of(const KeySpec& k) {
  std::vector<std::pair<std::string_view, std::vector<std::string_view>>> out;
  for (const SubModelChoice& use : k.sub_models) {
    if (use.sub_model.empty()) break;
    auto it = std::find_if(out.begin(), out.end(), [&use](const auto& e) { return e.first == use.sub_model; });
    if (it == out.end()) it = out.insert(out.end(), {use.sub_model, {}});
    if (!use.choice.empty()) {
      it->second.push_back(use.choice);
    } else {
      const KeySpec& by = *keys::kSubModels[sub_model_index(use.sub_model)];
      it->second.assign(by.choices.begin(), by.choices.end());
    }
  }
  return out;
}

// "`normal: hertz`, `tangential: mindlin, mindlin_rescale`"; "`rolling`" for every choice of the sub-model.
std::string sub_models_text(const KeySpec& k) {
  std::string out;
  for (const auto& [sub_model, choices] : sub_models_of(k)) {
    out += out.empty() ? "`" : ", `";
    out += sub_model;
    if (choices.size() != keys::kSubModels[sub_model_index(sub_model)]->choices.size()) {
      out += ": ";
      for (std::size_t i = 0; i < choices.size(); ++i) (out += i ? ", " : "") += choices[i];
    }
    out += '`';
  }
  return out;
}

}  // namespace

std::string deck_schema_markdown() {
  std::string out = "| key | type | unit | default | allowed | sub-model | meaning |\n|---|---|---|---|---|---|---|\n";
  for (const KeySpec* k : keys::kAll)
    out += "| `" + std::string(k->path) + "` | " + kind_name(k->kind) + " | " + std::string(k->unit) + " | " +
           default_of(*k) + " | " + allowed_of(*k) + " | " + sub_models_text(*k) + " | " + std::string(k->meaning) +
           " |\n";
  return out;
}

std::string deck_schema_json() {
  Json out = Json::array();
  for (const KeySpec* k : keys::kAll) {
    Json e = {{"key", k->path}, {"type", kind_name(k->kind)}, {"required", k->required},
              {"unit", k->unit}, {"meaning", k->meaning}};
    if (k->kind == KeyKind::Number || k->kind == KeyKind::Integer) {
      e["min"] = std::isinf(k->min) ? Json(nullptr) : Json(k->min);
      e["max"] = std::isinf(k->max) ? Json(nullptr) : Json(k->max);
      e["exclusive_min"] = k->positive;
      if (!k->required && k->default_text.empty()) e["default"] = k->fallback;
    }
    if (k->kind == KeyKind::Choice) {
      e["choices"] = Json::array();
      for (const std::string_view c : k->choices) e["choices"].push_back(c);
      if (!k->required) e["default"] = k->choices.front();
    }
    if (!k->default_text.empty()) e["default_text"] = k->default_text;
    if (!k->sub_models[0].sub_model.empty()) {
      // The contact sub-model choices that use the key: the reader refuses it unless the deck makes one of them.
      e["sub_models"] = Json::array();
      for (const auto& [sub_model, choices] : sub_models_of(*k))
        e["sub_models"].push_back({{"sub_model", sub_model}, {"choices", choices}});
      e["required_when_used"] = k->required_when_used;
    }
    out.push_back(e);
  }
  return out.dump(1) + "\n";
}

}  // namespace celldem
