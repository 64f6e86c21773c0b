// The structures' contours in a plane, cut on the device for the slice views (drawing_kernels.cu),
// with the buffers they reuse between calls. Host C++ only.
#pragma once

#include "device_store.h"

#include <vector>

namespace sinew::cuda {

class DeviceContour {
public:
  // Per structure of s, the segments (pairs of points) where its tessellation at positions x crosses
  // the plane dot(normal, p) = offset.
  std::vector<std::vector<Vec3>> segments(const MeshStore& s, const DeviceTopology& topology, const float3* x,
                                          const Vec3& normal, float offset, cudaStream_t stream);
  std::size_t bytes() const { return out_.bytes() + count_.bytes() + base_.bytes(); }

private:
  DeviceArray<float3> out_;
  DeviceArray<int> count_, base_;
};

}  // namespace sinew::cuda
