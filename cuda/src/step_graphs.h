// The engine's steps as captured CUDA Graphs: a batch of n steps is captured once and replayed
// after, per batch length and starting position buffers. A step whose move runs in the profile's
// pass leaves the new positions in another buffer (launchProfileAfterTerms; with the collision's
// hold in that pass, the previous positions in a third), so a batch may leave x and prev in other
// buffers than it found them; the batch records where. Host C++ only.
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
  // Enqueues n steps on `stream`: the captured batch for (n, view.x, view.prev, variant), captured
  // first from enqueueStep(last) (which enqueues one step and may move view.x and view.prev to
  // other buffers; last: whether it is the batch's last step) when there is none. variant: what
  // else decides the steps' kernels (the collisions' full searches: DeviceCollision::schedule).
  // view leaves as the steps leave it.
  void enqueue(int n, int variant, MeshView& view, cudaStream_t stream, const std::function<void(bool last)>& enqueueStep);

private:
  struct Batch {
    cudaGraphExec_t exec;
    float3* x;  // where the batch leaves view.x and view.prev
    float3* prev;
  };
  std::map<std::tuple<int, const float3*, const float3*, int>, Batch> batches_;
};

}  // namespace sinew::cuda
