#include "step_graphs.h"

#include "cuda_check.h"

namespace sinew::cuda {

void StepGraphs::clear() {
  for (auto& [key, batch] : batches_) cudaGraphExecDestroy(batch.exec);
  batches_.clear();
}

void StepGraphs::enqueue(int n, int variant, MeshView& view, cudaStream_t stream,
                         const std::function<void(bool last)>& enqueueStep) {
  const auto key = std::make_tuple(n, static_cast<const float3*>(view.x), static_cast<const float3*>(view.prev), variant);
  auto it = batches_.find(key);
  if (it == batches_.end()) {
    const MeshView before = view;  // capturing moves the positions as the replay will
    cudaGraph_t g = nullptr;
    SINEW_CUDA(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal));
    try {
      for (int i = 0; i < n; ++i) enqueueStep(i == n - 1);
    } catch (...) {
      // A plugin's launch failed and invalidated the capture: end it and clear the error it left
      // in this runtime, so that the stream and later engines stay usable.
      view = before;
      if (cudaStreamEndCapture(stream, &g) == cudaSuccess && g) cudaGraphDestroy(g);
      (void)cudaGetLastError();
      throw;
    }
    const MeshView after = view;
    view = before;
    SINEW_CUDA(cudaStreamEndCapture(stream, &g));
    cudaGraphExec_t exec;
    SINEW_CUDA(cudaGraphInstantiate(&exec, g, 0));
    SINEW_CUDA(cudaGraphDestroy(g));
    it = batches_.emplace(key, Batch{exec, after.x, after.prev}).first;
  }
  SINEW_CUDA(cudaGraphLaunch(it->second.exec, stream));
  view.x = it->second.x;
  view.prev = it->second.prev;
}

}  // namespace sinew::cuda
