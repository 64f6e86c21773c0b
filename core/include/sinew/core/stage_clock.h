// The stages of a run as laps of one clock: each lap gives the time since the previous lap to a
// named stage, so the stages tile the run and add up to its total however the scheduler interrupts
// the work between them. A stage lapped again (work that resumes after a nested stage) adds to its
// first entry, which keeps its place in the order.
#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace sinew {

class StageClock {
public:
  using Clock = std::chrono::steady_clock;
  explicit StageClock(Clock::time_point start = Clock::now()) : start_(start), last_(start) {}

  // The time since the previous lap (or the start), given to `name`. Returns it.
  double lap(const std::string& name) {
    const double seconds = sinceLastLap();
    add(name, seconds);
    return seconds;
  }
  // The time since the previous lap, split: `secondSeconds` of it (clamped to it) to `second`, the
  // rest to `first` (a loop and the sampling inside it, timed apart).
  void split(const std::string& first, const std::string& second, double secondSeconds) {
    const double seconds = sinceLastLap();
    const double part = secondSeconds < 0.0 ? 0.0 : secondSeconds > seconds ? seconds : secondSeconds;
    add(first, seconds - part);
    add(second, part);
  }
  // Every stage in the order of its first lap.
  const std::vector<std::pair<std::string, double>>& stages() const { return stages_; }
  // The start to the last lap: the stages' sum.
  double total() const { return std::chrono::duration<double>(last_ - start_).count(); }

private:
  // The time since the previous lap, which now ends.
  double sinceLastLap() {
    const Clock::time_point now = Clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return seconds;
  }
  void add(const std::string& name, double seconds) {
    for (auto& [stage, s] : stages_)
      if (stage == name) {
        s += seconds;
        return;
      }
    stages_.emplace_back(name, seconds);
  }
  Clock::time_point start_, last_;
  std::vector<std::pair<std::string, double>> stages_;
};

}  // namespace sinew
