#include "run/summary_schema.hpp"

#include "core/deck.hpp"
#include "run/summary.hpp"

namespace celldem {
namespace {

using F = FieldDoc;

// settings (run_settings).
constexpr F kContactLaw[] = {
    {"normal", "", "the normal law (contact.normal)"},
    {"tangential", "", "the tangential law (contact.tangential)"},
    {"rolling", "", "the rolling resistance (contact.rolling)"},
    {"twisting", "", "the twisting resistance (contact.twisting)"},
    {"reference_normal_stiffness", "N/m",
     "the normal stiffness of a contact of two mean spheres (kn, or Hertz's at "
     "the reference overlap)"},
    {"reference_tangential_stiffness", "N/m", "the tangential stiffness likewise"},
    {"*", "deck's unit",
     "every other number the law's choices use, by its deck key (contact.<key>, `celldem schema`)"}};
constexpr F kStepRange[] = {{"low", "particle-steps", "the fewest"},
                            {"high", "particle-steps", "the most (null: an end with no bound)"}};
constexpr F kToleranceEquilibrium[] = {{"min_steps", "steps", "the resolved equilibrium's min_steps"},
                                       {"min_steps_written", "steps", "the deck's"},
                                       {"check_interval", "steps", "the resolved check_interval"},
                                       {"check_interval_written", "steps", "the deck's"}};
constexpr F kToleranceLeg[] = {
    {"strain_driven", "", "whether a strain drives the leg"},
    {"driving_increment", "1", "the resolved strain per step of its fastest driven component"},
    {"driving_increment_written", "1", "the deck's"},
    {"strain_rate", "1/s", "the resolved strain rate"},
    {"strain_rate_written", "1/s", "the deck's"},
    {"inertial_number", "1",
     "a test leg's actual inertial number the resolved rate gives, predicted (the imposed x its path's ratio)"},
    {"inertial_number_written", "1", "the deck's"},
    {"imposed_inertial_number", "1",
     "the inertial number of the resolved imposed rates alone (core/plan inertial_strain_rate)"},
    {"imposed_inertial_number_written", "1", "the deck's"},
    {"path", "",
     "a test leg's path: strain-driven, a measured path of the rules (rate_bias.actual_to_imposed) or unmeasured"},
    {"actual_to_imposed", "1", "the ratio that predicts its actual inertial number from the imposed"},
    {"actual_to_imposed_basis", "", "where that ratio comes from"},
    {"adaptive_ceiling", "1", "an adaptive leg's ceiling on the actual inertial number, at most the one T allows"},
    {"adaptive_ceiling_written", "1", "the deck's"},
    {"confining_stress", "Pa", "the stress the inertial number is taken at"}};
constexpr F kToleranceStage[] = {
    {"stage", "", "prepare or the test's name"},
    {"time_step", "s", "the resolved time step"},
    {"time_step_written", "s", "the deck's"},
    {"time_step_fraction", "1", "the resolved time step over the stability limit"},
    {"time_step_fraction_written", "1", "the deck's"},
    {"output_interval", "steps", "the resolved output interval"},
    {"output_interval_written", "steps", "the deck's"},
    {"fast_strain_increment", "1", "the preparation's resolved fast compression per step"},
    {"fast_strain_increment_written", "1", "the deck's"},
    {"servo_max_strain_increment", "1", "the resolved servo cap"},
    {"servo_max_strain_increment_written", "1", "the deck's"},
    {"equilibrium", "", "the resolved equilibrium check", kToleranceEquilibrium},
    {"legs", "", "per leg", kToleranceLeg},
    {"particle_steps", "", "the predicted cost at the resolved settings (summary.json tolerance only)", kStepRange},
    {"particle_steps_written", "", "the same as written", kStepRange},
    {"ratio_low", "1", "written over resolved, the fewest particle-steps each"},
    {"network_time_step_estimate", "s", "the contact network's limit, estimated before a packing exists"},
    {"network_cap", "s", "the largest time step allowed: 0.9 of that estimate"},
    {"network_capped", "", "the rules' time step was above the cap and was lowered to it"},
    {"time_step_rules", "s", "the rules' time step before the cap"}};
constexpr F kCalibration[] = {{"model", "", "how a tolerance at this sample's size maps onto the rules' calibration"},
                              {"particles", "particles", "this deck's spheres"},
                              {"calibration_particles", "particles", "the rules' scene's"},
                              {"tolerance", "noise floors", "the tolerance asked"},
                              {"tolerance_at_calibration", "noise floors", "the same at the calibration's size"},
                              {"table_tolerance", "noise floors", "the level the rules' table is read at (clamped)"}};
constexpr F kRules[] = {{"time_step_fraction", "1", "the rules' time step over the stability limit"},
                        {"prepare_time_step_fraction", "1", "the same for the preparation"},
                        {"inertial_number", "1", "the rules' largest inertial number of a loading leg"},
                        {"fast_strain_increment_scale", "1", "the factor on the fast compression"},
                        {"damping_scale", "1", "the factor on the damping"}};
constexpr F kDampingPair[] = {{"translational", "1", "the resolved translational damping"},
                              {"rotational", "1", "the resolved rotational damping"}};
constexpr F kTotal[] = {{"particle_steps", "", "the run's predicted cost, resolved", kStepRange},
                        {"particle_steps_written", "", "the same as written", kStepRange},
                        {"ratio_low", "1", "written over resolved"}};
// The rate --tolerance chose from the rate bias laws (io/tolerance.cpp rate_json).
constexpr F kRateLaw[] = {
    {"quantity", "", "the quantity the law covers (test and summary key)"},
    {"bias_floors", "noise floors", "its bias at the chosen inertial number, in this deck's floors"},
    {"bias_floors_upper", "noise floors", "the same at the law's one-sided upper bound"},
    {"order", "1", "the law's order p in b(I) = C I^p"},
    {"floor_at_calibration", "quantity's", "the quantity's floor in the laws' scene"}};
constexpr F kRateWritten[] = {{"stage", "", "the test"},
                              {"inertial_number", "1", "a written leg's actual inertial number, predicted"},
                              {"slowed", "", "the leg was slowed to the chosen inertial number"},
                              {"rate_factor", "1", "the chosen rate over the written"},
                              {"distance_floors", "", "per law, the written leg's distance from I -> 0"},
                              {"distance_floors.*", "noise floors", "central and upper bound"}};
constexpr F kToleranceRate[] = {{"inertial_number", "1", "the inertial number the strain-driven legs run at"},
                                {"limiting", "", "the law that set it"},
                                {"inertial_number_definition", "", "which inertial number the laws use"},
                                {"promise", "", "what the tolerance promises, in words"},
                                {"laws", "", "per rate bias law", kRateLaw},
                                {"written", "", "per written strain-driven leg", kRateWritten}};

// What --tolerance did (io/tolerance): summary.json's tolerance (with the cost) and settings.resolved.
constexpr F kTolerance[] = {
    {"tolerance", "noise floors", "the tolerance asked (--tolerance or the deck's)"},
    {"as_written", "", "true when the rules promise no faster setting: the deck ran as written"},
    {"reason", "", "why it ran as written"},
    {"calibration", "", "the rules' calibration", kCalibration},
    {"rules", "", "the rules' settings interpolated at the tolerance", kRules},
    {"stability_limit", "s", "the time step's stability limit the fractions are of"},
    {"damping", "", "the resolved damping", kDampingPair},
    {"stages", "", "per stage, what the rules resolved", kToleranceStage},
    {"total", "", "the whole run's predicted cost (summary.json tolerance only)", kTotal},
    {"rate", "", "the rate chosen from the distance to I -> 0", kToleranceRate}};
constexpr F kSettings[] = {
    {"deck", "", "the deck file"},
    {"particles", "particles", "the sample's spheres"},
    {"diameters_m", "m", "the sample's diameter classes"},
    {"mean_diameter_m", "m", "their mean"},
    {"density", "kg/m3", "the particle density"},
    {"seed", "", "the sample's seed"},
    {"time_step", "s", "the deck's time step"},
    {"kn", "N/m", "the deck's normal stiffness"},
    {"kt", "N/m", "the deck's tangential stiffness"},
    {"contact_law", "", "the contact law the run used", kContactLaw},
    {"tangential_rotation", "", "how stored tangential springs follow the contact's rotation"},
    {"moment_arm", "", "the moment arm of the tangential force"},
    {"kinematics", "", "the cell's kinematics"},
    {"damping_translational", "1", "the translational damping"},
    {"damping_rotational", "1", "the rotational damping"},
    {"servo_gain", "1", "the servo's proportional gain"},
    {"servo_integral_gain", "1", "its integral gain"},
    {"servo_max_strain_increment", "1", "the deck's servo cap (null: each leg's follows its rate, legs[].servo_cap)"},
    {"threads", "", "the threads the run used"},
    {"stage_time_steps", "", "the stages with their own time step", {}},
    {"stage_time_steps.*", "s", "a stage's time step"},
    {"tolerance", "noise floors", "the tolerance a rewritten deck was resolved for"},
    {"resolved", "", "what --tolerance resolved (as summary.json tolerance, without the cost)", kTolerance}};

// grading (grading_json).
constexpr F kGrading[] = {{"by", "", "the grading's basis (mass or number)"},
                          {"sizes_m", "m", "the sieve sizes"},
                          {"asked_percent", "%", "the percent passing each size, asked"},
                          {"realised_percent", "%", "the percent passing each size, realised by the sample"},
                          {"largest_deviation_percent", "percentage points", "the largest difference"},
                          {"spheres", "particles", "the sample's spheres"}};

// prepared.network_time_step and tests.*.network_time_step (run/time_step_check.cpp: the judgement and the watch's
// record).
constexpr F kNetworkJudgement[] = {
    {"time_step", "s", "the stage's time step"},
    {"limit", "s", "the contact network's leapfrog limit 2/omega_max"},
    {"limit_over_unit", "1", "the limit in sqrt(m_min/kn)"},
    {"pair_limit", "s", "the one-pair formula's limit, for comparison"},
    {"time_step_over_limit", "1", "the time step over the network limit"},
    {"verdict", "", "ok, warn or refuse"},
    {"warn_above", "1", "the fraction of the limit above which the run warns"},
    {"refuse_above", "1", "the fraction above which a stage is refused"},
    {"contacts", "pairs", "the contacts in the network judged"},
    {"tangential_springs", "", "whether sticking tangential springs counted (the stage has friction)"},
    {"iterations", "", "the Lanczos iterations"},
    {"wall_s", "s", "the time the judgement took"}};
constexpr F kNetworkTimeStep[] = {
    {"at_start", "", "the judgement of the state the stage started from", kNetworkJudgement},
    {"largest_time_step_over_limit", "1", "the largest ratio of any check in the stage"},
    {"largest_at_step", "steps", "the stage step of that check"},
    {"checks", "", "the checks made (start, every check_interval steps, the end)"},
    {"check_interval", "steps", "the steps between checks (checkpoint_interval)"},
    {"wall_s", "s", "the checks' time in all"}};

// tests.*.energy (run/energy_report.cpp; docs/energy.md): a span's budget, the test's and each leg's.
#define CELLDEM_ENERGY_SPAN                                                                                           \
  {"boundary_work", "J", "the work the cell did on the sample, the integral of V sigma:d(epsilon)"},                 \
      {"stored_change", "J", "the change of the energy stored in the springs"},                                     \
      {"kinetic_change", "J", "the change of the fluctuating kinetic energy (translation and rotation)"},           \
      {"friction", "J", "dissipated by sliding at the Coulomb cap"},                                                \
      {"rotational_friction", "J", "dissipated at the rolling and twisting caps"},                                  \
      {"body_damping", "J", "dissipated by the body damping"},                                                      \
      {"contact_damping", "J", "dissipated by the contact dashpots"},                                               \
      {"dissipated", "J", "all dissipation"},                                                                       \
      {"damping_share", "1", "damping's share of the dissipation (null when nothing was dissipated)"},              \
      {"closure", "J", "boundary work - (stored change + kinetic change + dissipated)"},                            \
      {"closure_relative", "1", "the closure over the boundary work (null when no work was done)"}
constexpr F kEnergyLeg[] = {CELLDEM_ENERGY_SPAN, {"leg", "", "the leg's index in the load program"}};
constexpr F kEnergy[] = {CELLDEM_ENERGY_SPAN,
                         {"legs", "", "the same per leg of the load program", kEnergyLeg},
                         {"worst_closure_relative", "1", "the largest relative closure error of any row"},
                         {"worst_closure_step", "steps", "its stage step"},
                         {"worst_closure_leg", "", "its leg"},
                         {"closure_bound", "1", "the relative closure error above which the test is flagged"},
                         {"damping_share_bound", "1", "the damping share above which the test is damping-dominated"},
                         {"closure_within_bound", "", "the worst closure error is within its bound"},
                         {"damping_dominated", "", "damping took more than its bound of the dissipation"}};
#undef CELLDEM_ENERGY_SPAN

// prepared.started_from (runner.cpp started_from).
constexpr F kOverlaps[] = {{"touching_pairs", "pairs", "pairs that overlap"},
                           {"deep_pairs", "pairs",
                            "pairs overlapping by more than the note's fraction of the smaller "
                            "radius"},
                           {"worst", "1", "the deepest overlap over the smaller radius"},
                           {"worst_pair", "", "its two atom ids"}};
constexpr F kRelax[] = {{"max_overlap", "1", "prepare.relax_overlaps: the overlap it dilates to"},
                        {"dilation", "1", "the factor the positions and the cell were scaled by"},
                        {"overlaps_after", "", "the overlaps after it", kOverlaps}};
constexpr F kStartedFrom[] = {{"initial_state", "", "the file the preparation started from"},
                              {"solid_fraction", "1", "its solid fraction as the preparation starts"},
                              {"overlaps", "", "its overlaps", kOverlaps},
                              {"relax_overlaps", "", "their relaxation", kRelax},
                              {"skipped", "", "the fast leg left out, and why"}};

// A test's probes (run/probe_table.cpp, docs/probes.md).
constexpr F kProbeRules[] = {{"rest_fraction", "1", "the rest's creep limit"},
                             {"rest_max_steps", "steps", "the rest's longest"},
                             {"drift_limit", "1", "the drift a point may have"},
                             {"asymmetry_limit", "1", "the asymmetry an elastic tensor may have"},
                             {"elastic_factor", "1", "the stress probes' elastic check's factor"}};
constexpr F kProbeDrift[] = {{"ratio", "1", "the drift over the smallest response"},
                             {"reference", "", "what it was measured against"},
                             {"smallest_response", "Pa or 1", "the smallest probe's response"},
                             {"unit", "", "their unit"}};
constexpr F kProbeRest[] = {{"controlled", "", "the rest's controls held"},
                            {"folder", "", "its folder"},
                            {"gave_up", "", "it stopped at its longest without coming to rest"},
                            {"goal", "1", "its creep goal"},
                            {"last_window_creep", "1", "the creep over its last window"},
                            {"probed_from", "", "the state the probes started from"},
                            {"reached", "", "it came to rest"},
                            {"steps", "steps", "its steps"},
                            {"window_steps", "steps", "its creep window"}};
constexpr F kAgreement[] = {{"meaning", "", "what the agreement says"},
                            {"median_factor", "1", "the median elastic-check factor"},
                            {"probes", "", "the probes compared"},
                            {"turned", "", "the probes whose response turned"},
                            {"within_limit", "", "whether every factor is within the limit"},
                            {"worst_factor", "1", "the worst factor"},
                            {"worst_probe", "", "the probe with it"}};
constexpr F kElasticCheck[] = {{"agreement", "", "the elastic check's verdict", kAgreement},
                               {"elastic", "Pa", "the elastic tensor (Voigt)"},
                               {"elastic_asymmetry", "1", "its asymmetry"},
                               {"elastic_min_eigenvalue", "Pa", "its smallest eigenvalue"},
                               {"reference_drift_stress", "Pa", "the drift the check is against"},
                               {"tangent", "Pa", "the tangent tensor"},
                               {"target_strain", "1", "the probes' strain"},
                               {"whole", "", "whether the check covers every direction"}};
constexpr F kPlastic[] = {{"fit_explains", "1", "the share of the plastic response the fit explains"},
                          {"flow_concentration", "1", "how concentrated the flow direction is"},
                          {"flow_direction_deg", "deg", "the plastic flow's direction in the probe plane"},
                          {"loading_normal_deg", "deg", "the loading surface's normal"},
                          {"magnitude", "Pa", "the probes' magnitude"},
                          {"meaning", "", "what the fit says"},
                          {"non_associativity_deg", "deg", "the angle between flow and normal"},
                          {"plastic_per_magnitude", "1", "the plastic strain per unit magnitude"}};
constexpr F kProbePoint[] = {{"status", "", "ran, not run, or failed"},
                             {"reason", "", "why not run or failed"},
                             {"step", "steps", "the test's step at the point"},
                             {"e1", "1", "e1 there"},
                             {"state", "", "the point's state file"},
                             {"folder", "", "its folder"},
                             {"controlled", "", "the probes' controls held"},
                             {"probes", "", "the probes run"},
                             {"failed", "", "the probes that failed"},
                             {"checks_failed", "", "the checks the point failed"},
                             {"checks_reason", "", "why"},
                             {"drift", "", "the rest's drift against the response", kProbeDrift},
                             {"rest", "", "the rest before the probes", kProbeRest},
                             {"elastic_asymmetry", "1", "the elastic tensor's asymmetry"},
                             {"elastic_min_eigenvalue", "Pa", "its smallest eigenvalue"},
                             {"elastic_vs_network", "1", "the elastic tensor against the contact network's"},
                             {"elastic_check", "", "the stress probes' elastic check", kElasticCheck},
                             {"plastic", "", "the stress probes' plastic response", kPlastic},
                             {"plastic_withheld", "", "why the plastic response is withheld"},
                             {"linearity", "", "the strain probes' linearity over their magnitudes"},
                             {"linearity_withheld", "", "why it is withheld"},
                             {"magnitudes", "", "the probes' magnitudes at this point"},
                             {"magnitude_from", "", "what the magnitudes scale"}};
constexpr F kProbes[] = {{"kind", "", "strain or stress probes"},
                         {"steps", "steps", "each probe's steps"},
                         {"hold_steps", "steps", "each probe's hold"},
                         {"target_strain", "1", "the strain probes' strain"},
                         {"rules", "", "the set's rules", kProbeRules},
                         {"magnitudes", "", "per point, the stress probes' magnitudes"},
                         {"magnitude_factors", "1", "the deck's magnitude factors"},
                         {"plane", "", "the stress probes' plane"},
                         {"points", "", "per point"},
                         {"points.*", "", "a point (peak, e1 values, named points)", kProbePoint},
                         {"table", "", "probes.csv"},
                         {"stiffness", "", "stiffness.json"}};

// A test's rate check by a ladder of rates (run/verify_rate.cpp RateCheckResult::to_json, docs/outputs.md).
constexpr F kRateFloors[] = {{"ratio13", "1", "the noise floor of the peak ratios"},
                             {"ev", "1", "of the volumetric strain"},
                             {"Z", "1", "of the coordination number"},
                             {"Z_sheared", "", "Z's floor is the sheared end-of-test Z's (else the prepared sample's)"},
                             {"source", "", "where the floors came from"}};
constexpr F kRateCostRun[] = {{"run", "", "the run's name (rung-<k>, twin-<k>)"},
                              {"steps", "steps", "its steps"},
                              {"particle_steps", "particle-steps", "its particle-steps"}};
constexpr F kRateCost[] = {{"runs", "", "per run of the check", kRateCostRun},
                           {"particle_steps", "particle-steps", "all the check's runs"},
                           {"estimated_s", "s", "at the test's speed"}};
constexpr F kRateRun[] = {{"factor", "1", "its rate over the test's"},
                          {"series", "", "its series.csv"},
                          {"steps", "steps", "its steps"},
                          {"wall_s", "s", "its wall time"},
                          {"controlled", "", "its controls held"},
                          {"peak_reached", "", "its driven measure reached its peak"},
                          {"inertial_number", "1", "its inertial number"},
                          {"failed", "", "its error, when it failed"}};
constexpr F kRateChaos[] = {{"rule", "", "how one run's chaos is taken and carried through the fit"}};
constexpr F kRateFamily[] = {{"quantities", "", "the quantities judged (the family's size m)"},
                             {"rule", "", "how the family's verdict holds its error rate"}};
constexpr F kRateComparison[] = {
    {"test", "quantity's", "the test's value"},
    {"floor", "quantity's", "its noise floor"},
    {"floor_of", "", "the floor's quantity"},
    {"rungs", "quantity's", "each rung's value, in the rungs' order"},
    {"twins", "quantity's", "each twin's value"},
    {"chaos_sd", "quantity's", "one run's chaos: the sample std of the test and its twins"},
    {"chaos_dof", "", "its degrees of freedom"},
    {"chaos_sd_floors", "noise floors", "the same in floors"},
    {"quasi_static", "quantity's", "the fit's Q0, the answer at I -> 0"},
    {"order", "1", "the fitted order p of Q(r) = Q0 + C r^p"},
    {"order_interval90", "1", "its 90 % interval"},
    {"order_at_bound", "", "the fitted order sits at a bound of its search range"},
    {"error_floors", "noise floors", "the test's distance from I -> 0, C / floor"},
    {"bounds95_floors", "noise floors", "its one-sided 95 % bounds"},
    {"family_bounds_floors", "noise floors", "its bounds at 0.05 / m (Bonferroni over the family)"},
    {"linear_error_floors", "noise floors", "the first-order extrapolation from the first rung, for comparison"},
    {"verdict", "", "converged, not converged, unresolved or not compared"},
    {"reason", "", "why unresolved or not compared"}};
constexpr F kRateLargest[] = {{"quantity", "", "the quantity of the largest distance"},
                              {"error_floors", "noise floors", "its distance"}};
constexpr F kRateCheck[] = {
    {"rungs", "1", "the rungs' rates over the test's"},
    {"twins", "", "the twins run"},
    {"tolerance_floors", "noise floors", "the tolerance"},
    {"confidence", "1", "the verdict's confidence"},
    {"window_strain", "1", "the end span's strain (end_span.ev, end_span.Z)"},
    {"extrapolation", "", "how the distance is extrapolated"},
    {"chaos", "", "one run's chaos", kRateChaos},
    {"family", "", "the family of quantities judged", kRateFamily},
    {"floors", "", "the noise floors", kRateFloors},
    {"cost", "", "the check's cost", kRateCost},
    {"runs", "", "the check's runs"},
    {"runs.*", "", "a run (rung-<k>, twin-<k>)", kRateRun},
    {"comparisons", "", "per compared quantity"},
    {"comparisons.*", "", "a quantity (peak_ratio13, peak_robust.ratio13, end_span.ev, end_span.Z)", kRateComparison},
    {"largest", "", "the largest distance", kRateLargest},
    {"verdict", "", "converged, not converged, unresolved or run failed"},
    {"reason", "", "the verdict's reason"}};

// tests.*.tolerance (io/tolerance check_tolerance: --tolerance's promise against the run).
constexpr F kToleranceCheck[] = {
    {"tolerance", "noise floors", "the tolerance asked"},
    {"inertial_number_allowed", "1", "the actual inertial number the rate bias laws allow at it"},
    {"inertial_number", "1", "the mean actual inertial number of the test's strain-driven rows"},
    {"imposed_inertial_number", "1", "the same rows' mean imposed inertial number"},
    {"actual_to_imposed", "1", "their ratio, as the test ran"},
    {"distance_floors", "", "per law, the test's distance from I -> 0 at its actual inertial number"},
    {"distance_floors.*", "noise floors", "central and upper bound"},
    {"kept", "", "every law's upper bound within the tolerance (null: no strain-driven rows)"},
    {"reason", "", "why it was not checked"}};

// The run's top level (runner.cpp run_deck).
constexpr F kTop[] = {{"celldem_version", "", "the binary's version"},
                      {"deck", "", "the deck file"},
                      {"settings", "", "the physics and threads the run used", kSettings},
                      {"tolerance", "", "what --tolerance resolved and what it saves", kTolerance},
                      {"grading", "", "the sample's grading, asked and realised", kGrading},
                      {"initial_state", "", "the state the tests started from (no preparation)"},
                      {"warnings", "", "the run's warnings"}};

}  // namespace

void append_doc_keys(std::vector<SchemaEntry>& out, const std::string& path, std::span<const FieldDoc> keys) {
  for (const FieldDoc& f : keys) {
    const std::string p = path + "." + std::string(f.key);
    out.push_back({p, f.keys.empty() ? "json" : "object", std::string(f.unit), std::string(f.doc)});
    append_doc_keys(out, p, f.keys);
  }
}

std::vector<SchemaEntry> summary_schema() {
  std::vector<SchemaEntry> out;
  for (const FieldDoc& f : kTop) {
    out.push_back({std::string(f.key), f.keys.empty() ? "json" : "object", std::string(f.unit), std::string(f.doc)});
    append_doc_keys(out, std::string(f.key), f.keys);
  }
  out.push_back({"prepared", "object", "", "the prepared sample (a run with a preparation)"});
  append_record_schema<PreparationSummary>(out, "prepared");
  out.push_back({"prepared.started_from", "object", "", "a preparation from initial_state: where it started"});
  append_doc_keys(out, "prepared.started_from", kStartedFrom);
  out.push_back({"prepared.network_time_step", "object", "", "the time step against the contact network"});
  append_doc_keys(out, "prepared.network_time_step", kNetworkTimeStep);
  out.push_back({"tests", "object", "", "per test, by its name"});
  out.push_back({"tests.*", "object", "", "a loading test's summary"});
  append_record_schema<TestSummary>(out, "tests.*");
  out.push_back({"tests.*.energy", "object", "", "the test's energy budget (deck key energy_budget; docs/energy.md)"});
  append_doc_keys(out, "tests.*.energy", kEnergy);
  out.push_back({"tests.*.network_time_step", "object", "", "the time step against the contact network"});
  append_doc_keys(out, "tests.*.network_time_step", kNetworkTimeStep);
  out.push_back({"tests.*.probes", "object", "", "the test's probes (docs/probes.md)"});
  append_doc_keys(out, "tests.*.probes", kProbes);
  out.push_back({"tests.*.tolerance", "object", "", "--tolerance's promise against the test's actual inertial number"});
  append_doc_keys(out, "tests.*.tolerance", kToleranceCheck);
  out.push_back({"tests.*.verify_rate", "object", "", "the test's rate check (--verify-rate)"});
  append_doc_keys(out, "tests.*.verify_rate", kRateCheck);
  return out;
}

bool summary_schema_lists(const std::vector<SchemaEntry>& schema, const std::string& path) {
  // Array marks say nothing of the key: a.b[].c is a.b.c. `*` in a listed path matches any one key.
  const auto split = [](std::string s) {
    for (std::size_t at; (at = s.find("[]")) != std::string::npos;) s.erase(at, 2);
    std::vector<std::string> parts;
    std::size_t from = 0;
    for (std::size_t at; (at = s.find('.', from)) != std::string::npos; from = at + 1)
      parts.push_back(s.substr(from, at - from));
    parts.push_back(s.substr(from));
    return parts;
  };
  const std::vector<std::string> asked = split(path);
  for (const SchemaEntry& e : schema) {
    const std::vector<std::string> listed = split(e.path);
    bool match = listed.size() == asked.size();
    for (std::size_t k = 0; k < listed.size() && match; ++k) match = listed[k] == "*" || listed[k] == asked[k];
    if (match) return true;
  }
  return false;
}

}  // namespace celldem
