// Parallel loops over index ranges on a fixed number of threads (TBB task arena). Work split never
// changes what a loop computes as long as each index writes only its own outputs, which is how
// every kernel in the engine is written: results are identical for 1 and N threads.
#pragma once

#include "sinew/core/types.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <memory>

namespace sinew {

class Executor {
public:
  // threads <= 0: all hardware threads.
  explicit Executor(int threads = 0)
      : arena_(std::make_unique<tbb::task_arena>(threads > 0 ? threads : tbb::info::default_concurrency())) {}

  int threads() const { return arena_->max_concurrency(); }

  // body(begin, end) over [0, n) in blocks of at least `grain` indices.
  template <class Body>
  void forRange(Index n, Body&& body, Index grain = 256) const {
    if (n <= 0) return;
    if (n <= grain || threads() == 1) {
      body(Index{0}, n);
      return;
    }
    arena_->execute([&] {
      tbb::parallel_for(tbb::blocked_range<Index>(0, n, grain),
                        [&](const tbb::blocked_range<Index>& r) { body(r.begin(), r.end()); });
    });
  }

  // body(i) for every i in [0, n).
  template <class Body>
  void forEach(Index n, Body&& body, Index grain = 256) const {
    forRange(
        n, [&](Index b, Index e) {
          for (Index i = b; i < e; ++i) body(i);
        },
        grain);
  }

  // a() and b(), side by side where there are threads for it (recursive splits: each half's work
  // writes only its own outputs).
  template <class A, class B>
  void invoke(A&& a, B&& b) const {
    if (threads() == 1) {
      a();
      b();
      return;
    }
    arena_->execute([&] { tbb::parallel_invoke(a, b); });
  }

  // Reduction over [begin, end): combine must be associative and commutative for the result to be
  // independent of the split (make it so with deterministic tie-breaks).
  template <class T, class Accumulate, class Combine>
  T reduce(Index begin, Index end, T identity, Accumulate&& accumulate, Combine&& combine,
           Index grain = 1024) const {
    if (end - begin <= grain || threads() == 1) return accumulate(begin, end, identity);
    T result = identity;
    arena_->execute([&] {
      result = tbb::parallel_reduce(
          tbb::blocked_range<Index>(begin, end, grain), identity,
          [&](const tbb::blocked_range<Index>& r, T acc) { return accumulate(r.begin(), r.end(), acc); },
          combine);
    });
    return result;
  }

private:
  std::unique_ptr<tbb::task_arena> arena_;
};

// One thread, for work that has no executor of its own (a store without one, model building).
inline const Executor& serialExecutor() {
  static const Executor serial(1);
  return serial;
}

}  // namespace sinew
