// One sinew-run at a time per output directory. The lock is an flock on DIR/.sinew.lock: the
// kernel releases it when the process ends in any way, so a killed run never blocks the next one,
// while a second run writing to the same directory at the same time is refused. Holding it, a run
// also removes the staging folders that killed runs left behind.
#pragma once

#include "process_lock.h"

#include <filesystem>
#include <optional>

namespace sinew {

class OutputLock {
public:
  // Creates the directory if needed. Throws InputError naming the directory (and the process
  // holding it) when another run holds it, or when it cannot be created or locked.
  explicit OutputLock(const std::filesystem::path& dir);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  // How many stale staging folders the constructor removed.
  int staleRemoved() const { return staleRemoved_; }

private:
  void release();
  std::filesystem::path dir_;
  std::optional<ProcessLock> lock_;
  bool created_ = false;
  int staleRemoved_ = 0;
};

}  // namespace sinew
