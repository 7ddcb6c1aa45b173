// The typed results' field tables: each record lists its fields once (key, unit, meaning and the member) in a
// `visit_fields` beside its struct, and that one list both writes the record (record_json, nlohmann's to_json) and
// documents it (`celldem schema --summary`, schema_entries). A key written is a key documented.
#pragma once
#include <array>
#include <concepts>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/number_text.hpp"

namespace celldem {

// One key of a record: its name, its unit ("1" dimensionless, "" for text, flags and containers) and its meaning.
// `keys`: the keys of a value another module writes as JSON (an object, or the elements of an array), documented here.
struct FieldDoc {
  std::string_view key;
  std::string_view unit;
  std::string_view doc;
  std::span<const FieldDoc> keys = {};
};

// A record is a struct with `static constexpr bool kRecord = true` and a free `visit_fields(const T&, visitor)` that
// calls visitor(FieldDoc, member) for each key in the order of its table.
template <class T>
concept Record = requires {
  requires T::kRecord;
};

// One documented key of summary.json: its path (tests.*.legs[].end.e1: `*` a name of the run's choosing, `[]` every
// element of an array), its JSON type, unit and meaning.
struct SchemaEntry {
  std::string path, type, unit, doc;
};

namespace fields {
template <class T>
struct IsOptional : std::false_type {};
template <class T>
struct IsOptional<std::optional<T>> : std::true_type {};
template <class T>
struct IsVector : std::false_type {};
template <class T>
struct IsVector<std::vector<T>> : std::true_type {};
template <class T>
struct IsArray : std::false_type {};
template <class T, std::size_t N>
struct IsArray<std::array<T, N>> : std::true_type {};
}  // namespace fields

// A field's value as summary.json holds it: a non-finite number null, a record an object, an empty optional null.
template <class T>
nlohmann::json field_json(const T& value);

template <Record T>
nlohmann::json record_json(const T& record) {
  nlohmann::json j = nlohmann::json::object();
  visit_fields(record, [&](const FieldDoc& f, const auto& value) {
    using V = std::remove_cvref_t<decltype(value)>;
    if constexpr (fields::IsOptional<V>::value) {  // absent, not null, when empty
      if (value) j[std::string(f.key)] = field_json(*value);
    } else {
      j[std::string(f.key)] = field_json(value);
    }
  });
  return j;
}

// A value that may be null in summary.json (a peak left out of a test that does not drive it).
template <class T>
struct Nullable {
  std::optional<T> value;
};

template <class T>
nlohmann::json field_json(const T& value) {
  if constexpr (Record<T>) {
    return record_json(value);
  } else if constexpr (std::is_same_v<T, double>) {
    return number_or_null(value);
  } else if constexpr (fields::IsVector<T>::value || fields::IsArray<T>::value) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& x : value) a.push_back(field_json(x));
    return a;
  } else if constexpr (requires { value.value; } && !std::is_same_v<T, nlohmann::json>) {  // Nullable
    return value.value ? field_json(*value.value) : nlohmann::json(nullptr);
  } else {
    return nlohmann::json(value);
  }
}

// The JSON type of a field, in words.
template <class T>
std::string field_type() {
  if constexpr (Record<T>)
    return "object";
  else if constexpr (std::is_same_v<T, double>)
    return "number|null";
  else if constexpr (std::is_same_v<T, bool>)
    return "boolean";
  else if constexpr (std::is_integral_v<T>)
    return "integer";
  else if constexpr (std::is_same_v<T, std::string>)
    return "string";
  else if constexpr (fields::IsVector<T>::value || fields::IsArray<T>::value)
    return "array";
  else if constexpr (fields::IsOptional<T>::value)
    return field_type<typename T::value_type>();
  else if constexpr (std::is_same_v<T, nlohmann::json>)
    return "object";
  else
    return field_type<decltype(T{}.value)>() + "|null";  // Nullable<U>: U or null
}

// The documented keys of another module's JSON value under `path`, its nested keys' too.
void append_doc_keys(std::vector<SchemaEntry>& out, const std::string& path, std::span<const FieldDoc> keys);

// Every key of record T under `prefix` ("tests.*"), nested records', arrays' elements' and documented JSON's too.
template <Record T>
void append_record_schema(std::vector<SchemaEntry>& out, const std::string& prefix);

namespace fields {
template <class V>
void append_value_schema(std::vector<SchemaEntry>& out, const std::string& path, const FieldDoc& f) {
  if constexpr (IsOptional<V>::value) {
    append_value_schema<typename V::value_type>(out, path, f);
  } else if constexpr (Record<V>) {
    append_record_schema<V>(out, path);
  } else if constexpr (IsVector<V>::value) {
    if constexpr (Record<typename V::value_type>) append_record_schema<typename V::value_type>(out, path + "[]");
    append_doc_keys(out, path + "[]", f.keys);
  } else if constexpr (requires(V v) { v.value; } && !std::is_same_v<V, nlohmann::json>) {
    append_value_schema<typename decltype(V{}.value)::value_type>(out, path, f);
  } else {
    append_doc_keys(out, path, f.keys);
  }
}
}  // namespace fields

template <Record T>
void append_record_schema(std::vector<SchemaEntry>& out, const std::string& prefix) {
  visit_fields(T{}, [&](const FieldDoc& f, const auto& value) {
    using V = std::remove_cvref_t<decltype(value)>;
    const std::string path = (prefix.empty() ? "" : prefix + ".") + std::string(f.key);
    std::string type = field_type<V>();
    if constexpr (fields::IsOptional<V>::value) type += " (optional)";
    out.push_back({path, type, std::string(f.unit), std::string(f.doc)});
    fields::append_value_schema<V>(out, path, f);
  });
}

}  // namespace celldem
