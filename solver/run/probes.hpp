// Incremental response probes (tests[].probes): from the exact state at chosen points of a loading test (strains
// of axis 1, the peak, the end), small loadings in several directions, each loaded, held, unloaded and held
// again, so that the response splits into its recovered (elastic) and irrecoverable (plastic) parts.
//
// Each point first rests at its stresses (a probe from equilibrium), and each probe set also runs a reference probe
// that loads nothing: what the sample still deforms (creep under held stresses, relaxation under held strains) is
// subtracted from every probe's response at the same step (as in the stress-probe studies of Calvetti, Viggiani &
// Tamagnini 2003 and Kuhn 2006 with DEM), and reported as the reference's drift beside it.
//
// Stress probes: the three normal stresses follow a ramp from the point's stresses s to s + M d over `steps`,
// are held for `hold_steps`, ramp back to s and are held again; the cell's tilts (shear strains) are held. The
// directions d lie in the Rendulic plane, the deviatoric (pi) plane at constant p, or are listed. Strain probes:
// each of the six strains (e11, e22, e33, g12, g13, g23) in turn moves by M and back, the others held; the
// stress increments over M are a column of the tangent stiffness, the recovered ones of its elastic part.
//
// The points' states are copies of the test's State taken at its rows as it runs (ProbePoints); the test's own
// series and summary are untouched. Outputs: <test>/probes/<point>/<probe>/series.csv, <test>/probes/probes.csv
// and <test>/probes/stiffness.json (docs/outputs.md).
//
// The parts: probe_points.hpp (the points and what each probe loads), probes.cpp (the rests and the probes, run
// side by side), probe_verdict.hpp (a point judged on its evidence), probe_table.hpp (probes.csv, stiffness.json,
// summary.json's probes), probe_files.hpp (what the folders hold, read by the runs and the table).
#pragma once
#include <nlohmann/json.hpp>

#include "core/deck.hpp"
#include "run/probe_points.hpp"
#include "run/probe_table.hpp"
#include "run/probe_verdict.hpp"

namespace celldem {

class RunDirectory;
struct RunOptions;

// Runs a finished test's probes (in parallel over the test's threads, each probe on one; the results do not
// depend on the thread count) and writes probes.csv and stiffness.json. Returns summary.json's "probes" of the
// test: per point its probes, how many held their controls, and (stress probes) the response's linearity
// across magnitudes or (strain probes) the elastic stiffness's symmetry. A probe that fails is recorded (its
// error), not thrown; a stop request stops the run (probes are run again whole on --resume).
nlohmann::json run_test_probes(RunDirectory& run, const Deck& deck, const RunOptions& options, const TestDef& test,
                               const ProbePoints& points, bool peak_reached, const std::string& peak_evidence);

}  // namespace celldem
