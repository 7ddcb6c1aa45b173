// Progress of a running stage: percent, steps/s and ETA. On a terminal, one line rewritten in place twice a
// second (stages side by side share it); in a log file (a cluster job), a plain line every `interval`
// seconds, so that a log shows how far a run got and how fast it goes.
#pragma once
#include <chrono>
#include <cstdint>
#include <string>

namespace celldem {

enum class ProgressMode { Off, Terminal, Log };

class Progress {
 public:
  Progress(std::string stage, ProgressMode mode, double log_interval_seconds = 30.0);
  // fraction in [0,1] or negative when unknown (then no ETA is shown).
  void update(std::int64_t step, double fraction, const std::string& extra = "");
  void finish();

 private:
  std::string stage_;
  ProgressMode mode_;
  std::chrono::duration<double> interval_;
  std::chrono::steady_clock::time_point start_, last_;
  std::int64_t first_step_ = -1;
  double first_fraction_ = -1.0;
  bool printed_ = false;
};

bool stderr_is_terminal();

}  // namespace celldem
