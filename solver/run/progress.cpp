#include "run/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <mutex>

namespace celldem {
namespace {
// Stages running side by side share the terminal line: it shows the latest status of each.
std::mutex g_line_mutex;
std::map<std::string, std::string> g_line_parts;

void show(const std::string& stage, const std::string& part) {
  const std::lock_guard<std::mutex> lock(g_line_mutex);
  g_line_parts[stage] = part;
  std::string line = "\r";
  for (const auto& [name, text] : g_line_parts) line += (line.size() > 1 ? "  |  " : "") + text;
  std::fputs((line + "\x1b[K").c_str(), stderr);
}

void forget(const std::string& stage) {
  const std::lock_guard<std::mutex> lock(g_line_mutex);
  g_line_parts.erase(stage);
}
}  // namespace

bool stderr_is_terminal() { return isatty(fileno(stderr)) != 0; }

Progress::Progress(std::string stage, ProgressMode mode, double log_interval_seconds)
    : stage_(std::move(stage)),
      mode_(mode),
      interval_(mode == ProgressMode::Log ? log_interval_seconds : 0.5),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

void Progress::update(std::int64_t step, double fraction, const std::string& extra) {
  if (mode_ == ProgressMode::Off) return;
  const auto now = std::chrono::steady_clock::now();
  if (first_step_ < 0) first_step_ = step, first_fraction_ = fraction;
  if (now - last_ < interval_) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double rate = elapsed > 0 ? (step - first_step_) / elapsed : 0.0;
  char line[256];
  if (fraction > first_fraction_ && first_fraction_ >= 0.0 && rate > 0) {
    // Extrapolate from this segment only: a resumed run started part-way.
    const double eta = elapsed * (1.0 - fraction) / (fraction - first_fraction_);
    std::snprintf(line, sizeof line, "[%s] %5.1f%%  step %lld  %.0f steps/s  ETA %dm%02ds  %s",
                  stage_.c_str(), 100.0 * fraction, static_cast<long long>(step), rate,
                  static_cast<int>(eta) / 60, static_cast<int>(eta) % 60, extra.c_str());
  } else {
    std::snprintf(line, sizeof line, "[%s] step %lld  %.0f steps/s  %s", stage_.c_str(),
                  static_cast<long long>(step), rate, extra.c_str());
  }
  if (mode_ == ProgressMode::Log) {
    std::fprintf(stderr, "%s\n", line);
    std::fflush(stderr);
    return;
  }
  show(stage_, line);
  printed_ = true;
}

void Progress::finish() {
  forget(stage_);
  if (mode_ == ProgressMode::Terminal && printed_) std::fputs("\n", stderr);
  printed_ = false;
}

}  // namespace celldem
