#include "output_lock.h"

#include "sinew/core/types.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <string>
#include <sys/file.h>
#include <unistd.h>

namespace sinew {

namespace fs = std::filesystem;

OutputLock::OutputLock(const fs::path& dir) : dir_(dir), file_(dir / ".sinew.lock") {
  std::error_code ec;
  created_ = fs::create_directories(dir_, ec);
  if (ec) throw InputError(dir_.string() + ": cannot create the output directory: " + ec.message());
  fd_ = ::open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    const std::string why = std::strerror(errno);
    release();
    throw InputError(dir_.string() + ": cannot lock the output directory: " + why);
  }
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    char pid[32] = {0};
    const ssize_t n = ::pread(fd_, pid, sizeof pid - 1, 0);
    const std::string holder = n > 0 ? " (process " + std::string(pid, size_t(n)) + ")" : "";
    ::close(fd_);
    fd_ = -1;  // the lock file is the other run's: leave it
    throw InputError(dir_.string() + ": another sinew-run" + holder +
                     " is writing its outputs here; wait for it or choose another directory with -o");
  }
  const std::string pid = std::to_string(::getpid());
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != ssize_t(pid.size())) {
    // Only a courtesy for the message above; the lock itself holds.
  }
  // No other run holds the directory, so staging folders in it are leftovers of killed runs.
  for (const auto& entry : fs::directory_iterator(dir_, ec))
    if (entry.path().filename().string().rfind(".sinew-staging-", 0) == 0) {
      fs::remove_all(entry.path(), ec);
      if (!ec) ++staleRemoved_;
    }
}

OutputLock::~OutputLock() { release(); }

void OutputLock::release() {
  std::error_code ec;
  if (fd_ >= 0) {
    fs::remove(file_, ec);  // while still holding it
    ::close(fd_);
    fd_ = -1;
  }
  if (created_ && fs::is_empty(dir_, ec)) fs::remove(dir_, ec);
}

}  // namespace sinew
