// What lives in device memory for the forces between structures and the user's points, beside the
// collision hierarchies (device_collision.h): the placed points of the attraction_points force
// (attraction, include, exclude) and the deforming contacts' links. Host C++ only.
#pragma once

#include "cuda_check.h"
#include "kernels.h"
#include "sinew/core/contact_links.h"
#include "sinew/core/scene_data.h"

namespace sinew::cuda {

// Every structure's placed points in the CPU force's order (per structure its attraction points,
// then its include / exclude points), with the scratch the kernels need.
class DevicePlacedPoints {
public:
  // Uploads the scene's points; true when a captured graph no longer matches (count, buffers, or
  // whether any include / exclude point exists changed).
  bool upload(const SceneData& scene, cudaStream_t stream);
  void launch(const MeshView& m, ParamView p, int kRing, int kMargin, const int* meshBegin, const int* meshEnd,
              cudaStream_t stream) const;

private:
  DeviceArray<float3> points_;
  DeviceArray<int> mesh_, kind_;
  DeviceArray<unsigned long long> keys_;
  DeviceArray<float> windings_;
  int count_ = 0;
  bool constraints_ = false;  // any include / exclude point among them
};

// The deforming contacts' links of the current level (core/contact_links.h) and, for implicit
// Euler, each vertex's spring stiffness. Nothing is allocated without linked vertices.
class DeviceContactLinks {
public:
  void build(const MeshStore& store, const SceneData& scene, float distanceMm, bool withStiffness, cudaStream_t stream);
  void clear() { *this = DeviceContactLinks{}; }
  bool built() const { return built_; }
  void launch(const MeshView& m, ParamView p, cudaStream_t stream);
  const float* stiffness() const { return stiffness_.get(); }
  std::size_t bytes() const { return partner_.bytes() + offset_.bytes() + stiffness_.bytes(); }

private:
  DeviceArray<int> partner_;
  DeviceArray<float3> offset_;
  DeviceArray<float> stiffness_;
  bool built_ = false;
};

}  // namespace sinew::cuda
