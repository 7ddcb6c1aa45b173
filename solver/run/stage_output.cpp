#include "run/stage_output.hpp"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "io/state_file.hpp"
#include "run/preflight.hpp"

namespace celldem {
namespace fs = std::filesystem;

namespace {
constexpr std::uint64_t kFnvOffset = 14695981039346656037ull;
std::uint64_t fnv1a(std::string_view bytes, std::uint64_t hash = kFnvOffset) {
  for (const char c : bytes) hash = (hash ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  return hash;
}
std::string hex(std::uint64_t v) {
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}
// What a series' first `rows` rows (and header) are: their bytes' count and checksum, the last row's step.
nlohmann::json series_proof(std::string_view text, std::size_t rows, double last_step, std::int64_t step) {
  std::size_t end = 0;
  for (std::size_t k = 0; k <= rows && end != std::string_view::npos; ++k) {
    end = text.find('\n', end);
    if (end != std::string_view::npos) ++end;
  }
  if (end == std::string_view::npos) end = text.size();
  return {{"step", step}, {"rows", rows}, {"last_step", last_step}, {"bytes", end}, {"fnv1a64", hex(fnv1a(text.substr(0, end)))}};
}

// The likely cause a loading test that must stay quasi-static is stopped with; empty: not checked.
std::string quasi_static_cause(const Deck& deck, const std::string& stage, bool loading_test) {
  if (!loading_test) return "";
  for (const TestDef& t : deck.tests)
    if (t.name == stage && !t.dynamic) return not_quasi_static_cause(deck, t);
  return "";
}
}  // namespace

StageOutput::StageOutput(RunDirectory& run, const Deck& deck, const RunOptions& options, const Model& model,
                         std::string stage, std::int64_t output_interval, bool loading_test, bool branch,
                         std::vector<StageObserver*> observers)
    : run_(run), deck_(deck), options_(options), model_(model), stage_(std::move(stage)), dir_(run.stage_dir(stage_)),
      output_interval_(output_interval), monitor_(stage_, loading_test, quasi_static_cause(deck, stage_, loading_test)),
      progress_(stage_, options.progress, options.progress_interval), start_(std::chrono::steady_clock::now()),
      branch_(branch), observers_(std::move(observers)) {}

namespace {
// The energy budget's totals in a checkpoint's record (doubles as JSON numbers: they read back to the bit).
nlohmann::json energy_to_json(const EnergyLedger& e) {
  std::vector<double> moment(e.last_moment.data(), e.last_moment.data() + 9);
  return {{"open", e.open},
          {"last_moment", moment},
          {"start_energy", e.start_energy},
          {"boundary_work", e.boundary_work},
          {"friction", e.friction},
          {"rotational_friction", e.rotational_friction},
          {"contact_damping", e.contact_damping},
          {"damping_translation", e.damping_translation},
          {"damping_rotation", e.damping_rotation}};
}

EnergyLedger energy_from_json(const nlohmann::json& j) {
  EnergyLedger e;
  e.open = j.at("open").get<bool>();
  const std::vector<double> moment = j.at("last_moment").get<std::vector<double>>();
  if (moment.size() != 9) throw std::runtime_error("last_moment: 9 numbers expected");
  for (int k = 0; k < 9; ++k) e.last_moment.data()[k] = moment[static_cast<std::size_t>(k)];
  e.start_energy = j.at("start_energy").get<double>();
  e.boundary_work = j.at("boundary_work").get<double>();
  e.friction = j.at("friction").get<double>();
  e.rotational_friction = j.at("rotational_friction").get<double>();
  e.contact_damping = j.at("contact_damping").get<double>();
  e.damping_translation = j.at("damping_translation").get<double>();
  e.damping_rotation = j.at("damping_rotation").get<double>();
  return e;
}
}  // namespace

void StageOutput::open(State& state, bool resumed) {
  fs::create_directories(dir_);
  const fs::path path = dir_ / "series.csv";
  write_file_atomic(dir_ / "series.columns.json", series_columns_json());
  if (resumed) {
    const nlohmann::json record = read_checkpoint_record();
    elapsed_before_ = record.at("elapsed_s").get<double>();
    for (const auto& e : record.at("control_errors")) control_errors_.push_back(control_errors_from_json(e));
    for (const auto& w : record.at("warnings")) warn(w.get<std::string>());
    const nlohmann::json memory = record.value("observers", nlohmann::json::object());  // (none before it existed)
    for (StageObserver* o : observers_) o->restore(memory);
    if (model_.energy_budget) {
      if (!record.contains("energy"))
        throw UsageError(run_.checkpoint(stage_).string() +
                         ": the checkpoint has no energy budget (the run was started "
                         "without energy_budget); run again with --force");
      try {
        state.energy = energy_from_json(record.at("energy"));
      } catch (const std::exception& e) {
        throw UsageError(run_.checkpoint(stage_).string() + ": the checkpoint's energy budget is not readable (" +
                         e.what() + "); run again with --force");
      }
    }
    std::istringstream in(proven_series(state, record.at("series_proofs")));
    std::string line;
    std::vector<std::string> header;
    if (!std::getline(in, line) || in.eof()) throw RunError(path.string() + ": no header");
    std::string kept = line + "\n";
    {
      std::stringstream ss(line);
      for (std::string c; std::getline(ss, c, ',');) header.push_back(c);
    }
    while (std::getline(in, line)) {
      if (in.eof()) break;  // no newline: the row was cut short
      const std::optional<SeriesRow> row = parse_series_row(header, line);
      if (!row || row->step > static_cast<double>(state.control.stage_steps)) break;
      rows_.push_back(*row);
      kept += line + "\n";
    }
    // `kept` is a prefix the checkpoint's record proves, so the record still holds once the series is cut to it.
    last_proof_ = series_proof(kept, rows_.size(), rows_.empty() ? 0.0 : rows_.back().step, state.control.stage_steps);
    write_file_atomic(path, kept);
    series_ = AppendFile(path, /*truncate=*/false);
    series_bytes_ = kept.size();
    series_hash_ = fnv1a(kept);
  } else {
    series_ = AppendFile(path, /*truncate=*/true);
    series_bytes_ = 0;
    series_hash_ = kFnvOffset;
    append_series(series_header());
  }
  if (resumed) {
    for (StageObserver* o : observers_) o->on_resume(state, rows_);
  } else {
    write_row(state);
    for (StageObserver* o : observers_) o->on_start(state);
  }
}

void StageOutput::record_step(const State& state, double fraction, const std::string& status,
                              const ContactMeasures* contacts) {
  const std::int64_t s = state.control.stage_steps;
  if (!std::isfinite(state.stress.sum()) || !std::isfinite(state.cell.h.sum()))  // cheap, every step
    throw RunError("non-finite stress or cell in stage '" + stage_ + "' at step " + std::to_string(s) +
                   " (time step too large or loading too fast?); the last checkpoint holds the last good state");
  if (row_due(state)) write_row(state, contacts);
  for (StageObserver* o : observers_) o->on_step(state);
  progress_.update(s, fraction, status);
  if (stop_requested() && branch_) {  // a rate check or a probe is run again whole, with the tail of its test
    progress_.finish();
    throw Interrupted("stopped by a signal in the branch '" + stage_ + "' at step " + std::to_string(s) +
                      "; the test's last checkpoint is kept. Continue with: " + continue_command() + " (the test goes on from that checkpoint; its rate check runs again whole, its "
                      "probes from the points' kept states)");
  }
}

bool StageOutput::checkpoint_step(const State& state, bool leg_ends) {
  const std::int64_t s = state.control.stage_steps;
  if (branch_) return false;
  if (stop_requested() && !leg_ends) {
    checkpoint(state);
    progress_.finish();
    throw Interrupted("stopped by a signal in stage '" + stage_ + "' at step " + std::to_string(s) +
                      "; a checkpoint was written. Continue with: " + continue_command());
  }
  const bool due = s % deck_.checkpoint_interval == 0;
  if (due && !leg_ends) checkpoint(state);
  return due;
}

std::string StageOutput::continue_command() const {
  if (!options_.continue_command.empty()) return options_.continue_command;
  return "celldem run " + deck_.source + " --out " + options_.out_dir + " --resume";
}

void StageOutput::end_leg(const State& state) {
  if (rows_.empty() || rows_.back().step != static_cast<double>(state.control.stage_steps)) write_row(state);
}

bool StageOutput::leg_ends_stage(const State& state) {
  bool ends = false;
  for (StageObserver* o : observers_) ends = o->on_leg_end(state) || ends;
  return ends;
}

void StageOutput::finish(const State& state) {
  end_leg(state);
  for (StageObserver* o : observers_) o->on_finish(state, rows_);
  // The centred dilatancy index needs every row: now the series is rewritten whole with it (atomically:
  // the file holds the rows with or without DI, never a mix).
  fill_dilatancy(rows_);
  std::string text = series_header();
  for (SeriesRow& row : rows_) {
    row = as_printed(row);
    text += format_series_row(row);
  }
  series_ = AppendFile();
  // Killed from here until the stage is marked done, a resume goes on from the last checkpoint in this series:
  // its record is made to prove the prefix as written before and as rewritten now (the state rewritten as read).
  const fs::path checkpoint_path = run_.checkpoint(stage_);
  if (!last_proof_.is_null() && fs::exists(checkpoint_path)) {
    const nlohmann::json& p = last_proof_;
    std::string label, physics, text_record;
    const State at_checkpoint = read_state(checkpoint_path.string(), &label, &physics, &text_record);
    nlohmann::json record = nlohmann::json::parse(text_record);
    record["series_proofs"] = nlohmann::json::array(
        {p, series_proof(text, p["rows"].get<std::size_t>(), p["last_step"].get<double>(), p["step"].get<std::int64_t>())});
    write_state(checkpoint_path.string(), at_checkpoint, label, physics, record.dump());
  }
  write_file_atomic(dir_ / "series.csv", text);
  progress_.finish();
}

double StageOutput::elapsed() const {
  return elapsed_before_ + std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void StageOutput::write_row(const State& state, const ContactMeasures* measured) {
  // Once: the checks and the row read it (and the equilibrium check of the same step, which measured it).
  const ContactMeasures contacts = measured ? *measured : measure_contacts(model_, state);
  monitor_.check(model_, state, contacts);
  const SeriesRow row = series_row(model_, state, contacts);
  check_row_finite(row, stage_, state.control.stage_steps);
  append_series(format_series_row(row));
  rows_.push_back(as_printed(row));
  for (StageObserver* o : observers_) o->on_row(state, rows_.back());
}

nlohmann::json StageOutput::read_checkpoint_record() const {
  const fs::path path = run_.checkpoint(stage_);
  std::string text;
  try {
    (void)read_state(path.string(), nullptr, nullptr, &text);
    if (text.empty())
      throw UsageError(path.string() + ": a checkpoint without its record (written by an older celldem, whose checkpoints "
                       "were several files): --resume cannot prove the series and controls it continues; run again with --force");
    nlohmann::json record = nlohmann::json::parse(text);
    for (const char* key : {"elapsed_s", "control_errors", "warnings", "series_proofs"})
      if (!record.contains(key)) throw UsageError(path.string() + ": the checkpoint's record lacks '" + key + "'");
    return record;
  } catch (const StateFileError& e) {
    throw UsageError(std::string(e.what()) + "; run again with --force");
  } catch (const nlohmann::json::exception& e) {
    throw UsageError(path.string() + ": the checkpoint's record is not readable (" + e.what() + "); run again with --force");
  }
}

void StageOutput::append_series(const std::string& text) {
  series_.append(text);
  series_bytes_ += text.size();
  series_hash_ = fnv1a(text, series_hash_);
}

std::string StageOutput::proven_series(const State& state, const nlohmann::json& proofs) const {
  const fs::path path = dir_ / "series.csv";
  const std::int64_t step = state.control.stage_steps;
  const auto refuse = [&](const std::string& what) {
    throw UsageError(path.string() + ": " + what + ": --resume continues only the rows its checkpoint (step " +
                     std::to_string(step) + ", " + run_.checkpoint(stage_).string() +
                     ") recorded; start the run again with --force");
  };
  if (!fs::exists(path)) refuse("the file is missing");
  const std::string text = read_file(path);
  std::string what = "holds other bytes than the checkpoint recorded (an edited, deleted, repeated or renamed row or "
                     "header)";
  for (const nlohmann::json& p : proofs) {
    const std::size_t bytes = p.at("bytes").get<std::size_t>();
    if (text.size() < bytes) {
      what = "holds " + std::to_string(text.size()) + " bytes, fewer than the " + std::to_string(bytes) +
             " (header and " + std::to_string(p.at("rows").get<std::size_t>()) + " rows to step " +
             std::to_string(p.at("last_step").get<double>()) + ") the checkpoint recorded: rows were deleted";
      continue;
    }
    if (hex(fnv1a(std::string_view(text).substr(0, bytes))) == p.at("fnv1a64").get<std::string>())
      return text.substr(0, bytes);  // rows after it (written after the checkpoint) are cut
  }
  refuse(what);
  return "";
}

void StageOutput::checkpoint(const State& state) {
  // (before the state: what an observer keeps, e.g. the peak contacts, is never older than its checkpoint)
  for (StageObserver* o : observers_) o->on_checkpoint(state);
  // The state and all a resume needs besides it, in one file written by one rename (io/state_file, format 8): the
  // series' proof, the controls' errors (the control verdict's memory), this stage's warnings, its elapsed time and
  // what each observer remembers (StageObserver::save).
  last_proof_ = {{"step", state.control.stage_steps}, {"rows", rows_.size()},
                 {"last_step", rows_.empty() ? 0.0 : rows_.back().step}, {"bytes", series_bytes_},
                 {"fnv1a64", hex(series_hash_)}};
  nlohmann::json errors = nlohmann::json::array();
  for (const ControlErrors& e : control_errors_) errors.push_back(to_json(e));
  nlohmann::json memory = nlohmann::json::object();
  for (const StageObserver* o : observers_) o->save(memory);
  nlohmann::json record = {{"elapsed_s", elapsed()},
                           {"control_errors", errors},
                           {"warnings", warnings_},
                           {"series_proofs", nlohmann::json::array({last_proof_})},
                           {"observers", memory}};
  if (model_.energy_budget) record["energy"] = energy_to_json(state.energy);
  write_state(run_.checkpoint(stage_).string(), state, "stage:" + stage_, state_physics(deck_), record.dump());
}

void StageOutput::warn(const std::string& warning) {
  if (std::find(warnings_.begin(), warnings_.end(), warning) == warnings_.end()) warnings_.push_back(warning);
  run_.add_warning(warning);
}

}  // namespace celldem
