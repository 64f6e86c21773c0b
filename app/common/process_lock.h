// An flock on a file, held for the life of the object, with the holder's process id written in the
// file for the refusal message of whoever comes next. The kernel drops the lock however the process
// ends, so a killed holder never blocks the next one. Used by sinew-run (one run per output
// directory) and sinew-cohort (one run per cohort folder).
#pragma once

#include <filesystem>
#include <string>

namespace sinew {

class ProcessLock {
public:
  // Opens (creates) the file; throws InputError naming it when it cannot.
  explicit ProcessLock(std::filesystem::path file);
  ~ProcessLock();  // releases the lock (the file stays)
  ProcessLock(const ProcessLock&) = delete;
  ProcessLock& operator=(const ProcessLock&) = delete;

  // Takes the lock without waiting and writes this process's id into the file; false when another
  // process holds it, whose id holder() then reads.
  bool tryLock();
  std::string holder() const;
  // Removes the file while still holding the lock, then releases it.
  void removeAndRelease();

private:
  std::filesystem::path file_;
  int fd_ = -1;
};

}  // namespace sinew
