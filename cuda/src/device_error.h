// The timeline's sampled error in device memory (core/sampled_error.h): the truths uploaded once,
// the tessellations' hierarchy at each level, refitted and searched at every report sample by
// error_kernels.cu. Allocated only when a run samples its error on the device. Host C++ only.
#pragma once

#include "cuda_check.h"
#include "kernels.h"
#include "sinew/core/sampled_error.h"

#include <span>

namespace sinew::cuda {

class DeviceSampledError {
public:
  // The distances for the engine's current positions (view), summarised on the host.
  std::vector<std::optional<SurfaceDistanceStats>> measure(SampledError& error, MeshStore& store, const MeshView& view,
                                                           cudaStream_t stream);
  std::size_t bytes() const;

private:
  void uploadTruth(const SampledError& error, cudaStream_t stream);
  void uploadMeshes(const SampledError& error, cudaStream_t stream);

  const SampledError* truthOf_ = nullptr;  // whose truths are on the device
  DeviceArray<trianglebvh::Node> truthNodes_, meshNodes_;
  DeviceArray<collision::P3> truthCorners_, corners_, points_, patchCentres_;
  DeviceArray<int> truthRoots_, samplePatch_, patchStructure_, parents_, leaves_, triangleStructure_, meshRoots_, visits_;
  DeviceArray<trianglebvh::TangentPlane> planes_;
  DeviceArray<int3> triangles_;
  DeviceArray<float3> samples_;
  DeviceArray<float> sampleAreas_;
  DeviceArray<WeightedDistance> toTruth_, fromTruth_;
  std::vector<WeightedDistance> hostTo_, hostFrom_;
  std::vector<trianglebvh::TangentPlane> hostPlanes_;
};

// The exact evaluation's searches (ExecutionBackend::closestDistances): the hierarchy and the points
// uploaded, the distances downloaded; nothing kept.
void closestDistancesOnDevice(const TriangleBvh& meshes, std::span<const collision::P3> points, std::span<const int> roots,
                              std::span<float> out, cudaStream_t stream);

}  // namespace sinew::cuda
