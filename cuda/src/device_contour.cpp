#include "device_contour.h"

#include <algorithm>

namespace sinew::cuda {

std::vector<std::vector<Vec3>> DeviceContour::segments(const MeshStore& s, const DeviceTopology& topology, const float3* x,
                                                       const Vec3& normal, float offset, cudaStream_t stream) {
  const Index meshes = s.meshCount();
  // A plane crosses each triangle at most once: each structure's triangle count bounds its segments.
  std::vector<int> base(meshes + 1, 0);
  for (Index m = 0; m < meshes; ++m) base[m] = int(s.cellOffsets()[s.range(m).cellBegin]);
  base[meshes] = int(s.cellOffsets()[s.cellCount()]);
  base_.upload(base, stream);
  if (out_.size() < 2 * std::size_t(base[meshes])) out_.resize(2 * std::size_t(base[meshes]));
  count_.resize(meshes);
  SINEW_CUDA(cudaMemsetAsync(count_.get(), 0, meshes * sizeof(int), stream));
  launchContour(int(s.cellCount()), x, topology.cellOffsets.get(), topology.cellVertices.get(), topology.meshOf.get(),
                make_float3(normal.x(), normal.y(), normal.z()), offset, base_.get(), out_.get(), count_.get(), stream);
  std::vector<int> counts(meshes);
  count_.download(counts.data(), meshes, stream);
  SINEW_CUDA(cudaStreamSynchronize(stream));
  std::vector<std::vector<Vec3>> out(meshes);
  for (Index m = 0; m < meshes; ++m) {
    const int count = std::min(counts[m], base[m + 1] - base[m]);
    out[m].resize(2 * std::size_t(count));
    if (count > 0)
      SINEW_CUDA(cudaMemcpyAsync(out[m].data(), out_.get() + 2 * std::size_t(base[m]),
                                 2 * std::size_t(count) * sizeof(float3), cudaMemcpyDeviceToHost, stream));
  }
  SINEW_CUDA(cudaStreamSynchronize(stream));
  return out;
}

}  // namespace sinew::cuda
