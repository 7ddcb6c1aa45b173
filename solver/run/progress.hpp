// Progress on a terminal: stage, percent, steps/s, ETA. Silent when stderr is not a terminal.
#pragma once
#include <chrono>
#include <string>

namespace celldem {

class Progress {
 public:
  Progress(std::string stage, bool enabled);
  // fraction in [0,1] or negative when unknown (then no ETA is shown).
  void update(std::int64_t step, double fraction, const std::string& extra = "");
  void finish();

 private:
  std::string stage_;
  bool enabled_;
  std::chrono::steady_clock::time_point start_, last_;
  std::int64_t first_step_ = -1;
  double first_fraction_ = -1.0;
  bool printed_ = false;
};

bool stderr_is_terminal();

}  // namespace celldem
