// The engine's steps as captured CUDA Graphs: a batch of n steps is captured once and replayed
// after, per batch length and starting position buffer. A step whose move runs in the profile's
// pass leaves the new positions in the other buffer (launchProfileAfterTerms), so a batch may swap
// x and prev; the batch records whether it does. Host C++ only.
#pragma once

#include "kernels.h"

#include <cuda_runtime.h>

#include <functional>
#include <map>
#include <tuple>

namespace sinew::cuda {

class StepGraphs {
public:
  StepGraphs() = default;
  StepGraphs(const StepGraphs&) = delete;
  StepGraphs& operator=(const StepGraphs&) = delete;
  ~StepGraphs() { clear(); }

  // Forgets every captured batch (what they baked in changed).
  void clear();
  // Enqueues n steps on `stream`: the captured batch for (n, view.x, variant), captured first from
  // enqueueStep(last) (which enqueues one step and may swap view.x and view.prev; last: whether it
  // is the batch's last step) when there is none. variant: what else decides the steps' kernels
  // (the collisions' full searches: the batch's first step's place between them). view leaves as
  // the steps leave it.
  void enqueue(int n, int variant, MeshView& view, cudaStream_t stream, const std::function<void(bool last)>& enqueueStep);

private:
  struct Batch {
    cudaGraphExec_t exec;
    bool swapsPositions;
  };
  std::map<std::tuple<int, const float3*, int>, Batch> batches_;
};

}  // namespace sinew::cuda
