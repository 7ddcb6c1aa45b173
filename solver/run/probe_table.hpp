// The probes' tables, always made from their folders (run/probes.hpp): so a share of them (--probes K-L) and a merge
// give the same.
#pragma once
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/deck.hpp"

namespace celldem {

// probes.csv, stiffness.json and summary.json's "probes" of a test from its probe folders under `run_dir` (each
// point's point.json and point.state, each probe's result.json and series.csv): those this run made and those a
// merge brought from other jobs. A probe no folder holds is counted as `missing` at its point.
nlohmann::json tabulate_probes(const std::filesystem::path& run_dir, const Deck& deck, const TestDef& test);

}  // namespace celldem
