#include "thread_limits.h"

#include <cstdlib>
#include <string>

namespace sinew {

void limitLibraryThreads(int threads) {
  if (threads <= 0) return;
  // The app links ITK only through the image plugin: the variable, not ITK's API, reaches it.
  setenv("ITK_GLOBAL_DEFAULT_NUMBER_OF_THREADS", std::to_string(threads).c_str(), 1);
}

}  // namespace sinew
