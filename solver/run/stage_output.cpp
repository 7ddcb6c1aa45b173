#include "run/stage_output.hpp"

#include <cmath>
#include <csignal>
#include <sstream>

#include "io/state_file.hpp"

namespace celldem {
namespace fs = std::filesystem;

StageOutput::StageOutput(RunDirectory& run, const Deck& deck, const RunOptions& options, const Model& model,
                         std::string stage, std::int64_t output_interval, bool loading_test)
    : run_(run), deck_(deck), options_(options), model_(model), stage_(std::move(stage)), dir_(run.stage_dir(stage_)),
      output_interval_(output_interval), monitor_(stage_, loading_test), progress_(stage_, options.progress, options.progress_interval),
      start_(std::chrono::steady_clock::now()) {}

void StageOutput::open(const State& state, bool resumed) {
  fs::create_directories(dir_);
  const fs::path path = dir_ / "series.csv";
  write_file_atomic(dir_ / "series.columns.json", series_columns_json());
  if (resumed) {
    elapsed_before_ = run_.elapsed_of(stage_);
    for (const auto& e : run_.memory_of(stage_).value("control_errors", nlohmann::json::array()))
      control_errors_.push_back(control_errors_from_json(e));
  }
  if (resumed && fs::exists(path)) {
    std::istringstream in(read_file(path));
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
    write_file_atomic(path, kept);
    series_ = AppendFile(path, /*truncate=*/false);
  } else {
    series_ = AppendFile(path, /*truncate=*/true);
    series_.append(series_header());
  }
  if (!resumed) write_row(state);
}

bool StageOutput::after_step(const State& state, double fraction, const std::string& status) {
  const std::int64_t s = state.control.stage_steps;
  if (!std::isfinite(state.normal_stress.sum()) || !std::isfinite(state.cell.h.sum()))  // cheap, every step
    throw RunError("non-finite stress or cell in stage '" + stage_ + "' at step " + std::to_string(s) +
                   " (time step too large or loading too fast?); the last checkpoint holds the last good state");
  if (s % output_interval_ == 0) write_row(state);
  progress_.update(s, fraction, status);
  if (stop_requested()) {
    checkpoint(state);
    progress_.finish();
    throw Interrupted("stopped by a signal in stage '" + stage_ + "' at step " + std::to_string(s) +
                      "; a checkpoint was written. Continue with: celldem run " + deck_.source + " --out " +
                      options_.out_dir + " --resume");
  }
  if (s % deck_.checkpoint_interval == 0) {
    checkpoint(state);
    return true;
  }
  return false;
}

void StageOutput::finish(const State& state) {
  if (rows_.empty() || rows_.back().step != static_cast<double>(state.control.stage_steps)) write_row(state);
  // The centred dilatancy index needs every row: now the series is rewritten whole with it (atomically:
  // the file holds the rows with or without DI, never a mix).
  fill_dilatancy(rows_);
  std::string text = series_header();
  for (SeriesRow& row : rows_) {
    row = as_printed(row);
    text += format_series_row(row);
  }
  series_ = AppendFile();
  write_file_atomic(dir_ / "series.csv", text);
  progress_.finish();
}

double StageOutput::elapsed() const {
  return elapsed_before_ + std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void StageOutput::write_row(const State& state) {
  monitor_.check(model_, state);
  const SeriesRow row = measure_series_row(model_, state);
  check_row_finite(row, stage_, state.control.stage_steps);
  series_.append(format_series_row(row));
  rows_.push_back(as_printed(row));
}

void StageOutput::checkpoint(const State& state) {
  write_state(run_.checkpoint(stage_).string(), state, "stage:" + stage_);
  nlohmann::json errors = nlohmann::json::array();
  for (const ControlErrors& e : control_errors_) errors.push_back(to_json(e));
  run_.record_checkpoint(stage_, elapsed(), {{"control_errors", errors}});
}

}  // namespace celldem
