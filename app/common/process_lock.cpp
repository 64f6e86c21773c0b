#include "process_lock.h"

#include "sinew/core/types.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

namespace sinew {

ProcessLock::ProcessLock(std::filesystem::path file) : file_(std::move(file)) {
  fd_ = ::open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw InputError(file_.string() + ": cannot open the lock file: " + std::strerror(errno));
}

ProcessLock::~ProcessLock() {
  if (fd_ >= 0) ::close(fd_);
}

bool ProcessLock::tryLock() {
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) return false;
  const std::string pid = std::to_string(::getpid());
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != ssize_t(pid.size())) {
    // Only a courtesy for the next one's message; the lock itself holds.
  }
  return true;
}

std::string ProcessLock::holder() const {
  char pid[32] = {0};
  const ssize_t n = ::pread(fd_, pid, sizeof pid - 1, 0);
  return n > 0 ? std::string(pid, std::size_t(n)) : std::string();
}

void ProcessLock::removeAndRelease() {
  std::error_code ec;
  std::filesystem::remove(file_, ec);
  ::close(fd_);
  fd_ = -1;
}

}  // namespace sinew
