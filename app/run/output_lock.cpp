#include "output_lock.h"

#include "sinew/core/types.h"

#include <string>

namespace sinew {

namespace fs = std::filesystem;

OutputLock::OutputLock(const fs::path& dir) : dir_(dir) {
  std::error_code ec;
  created_ = fs::create_directories(dir_, ec);
  if (ec) throw InputError(dir_.string() + ": cannot create the output directory: " + ec.message());
  try {
    lock_.emplace(dir_ / ".sinew.lock");
  } catch (const InputError& e) {
    release();
    throw InputError(dir_.string() + ": cannot lock the output directory (" + e.what() + ")");
  }
  if (!lock_->tryLock()) {
    const std::string holder = lock_->holder();
    lock_.reset();  // the lock file is the other run's: leave it
    throw InputError(dir_.string() + ": another sinew-run" + (holder.empty() ? "" : " (process " + holder + ")") +
                     " is writing its outputs here; wait for it or choose another directory with -o");
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
  if (lock_) {
    lock_->removeAndRelease();
    lock_.reset();
  }
  if (created_ && fs::is_empty(dir_, ec)) fs::remove(dir_, ec);
}

}  // namespace sinew
