#include "step_graphs.h"

#include "cuda_check.h"

namespace sinew::cuda {

void StepGraphs::clear() {
  for (auto& [key, batch] : batches_) cudaGraphExecDestroy(batch.exec);
  batches_.clear();
}

void StepGraphs::enqueue(int n, int variant, MeshView& view, cudaStream_t stream,
                         const std::function<void(bool last)>& enqueueStep) {
  const auto key = std::make_tuple(n, static_cast<const float3*>(view.x), variant);
  auto it = batches_.find(key);
  if (it == batches_.end()) {
    const MeshView before = view;  // capturing swaps the positions as the replay will
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
    const bool swaps = view.x != before.x;
    view = before;
    SINEW_CUDA(cudaStreamEndCapture(stream, &g));
    cudaGraphExec_t exec;
    SINEW_CUDA(cudaGraphInstantiate(&exec, g, 0));
    SINEW_CUDA(cudaGraphDestroy(g));
    it = batches_.emplace(key, Batch{exec, swaps}).first;
  }
  SINEW_CUDA(cudaGraphLaunch(it->second.exec, stream));
  if (it->second.swapsPositions) std::swap(view.x, view.prev);
}

}  // namespace sinew::cuda
