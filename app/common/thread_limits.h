// -j for the libraries that take their threads from settings of their own rather than from the
// engine's executor: ITK's filters and readers (its global default number of threads, which ITK
// reads from ITK_GLOBAL_DEFAULT_NUMBER_OF_THREADS when it is first asked for it). Without this a run
// with -j 2, one of a cohort's runs sharing a host's cores, still read its images and made its
// registration's pyramid on every core.
#pragma once

namespace sinew {

// Call before any ITK work. threads <= 0 leaves the libraries at their own defaults (every core).
void limitLibraryThreads(int threads);

}  // namespace sinew
