// summary.json's keys, each with its JSON type, unit and meaning (`celldem schema --summary`, docs/outputs.md): the
// typed records' field tables (run/summary.hpp) and the documented keys of what other modules write as JSON (the
// settings, --tolerance's record, a preparation's start, the probes, the rate check).
#pragma once
#include <string>
#include <vector>

#include "run/summary_fields.hpp"

namespace celldem {

// Every key path of summary.json (`*` a name of the run's choosing: a test, a probe point, a compared quantity;
// `[]` every element of an array), parents before their keys.
std::vector<SchemaEntry> summary_schema();

// Whether `path` (a key path of a written summary.json, its array indices written `[]`) is listed by `schema`: `*`
// in a listed path stands for any one key.
bool summary_schema_lists(const std::vector<SchemaEntry>& schema, const std::string& path);

}  // namespace celldem
