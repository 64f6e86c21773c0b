#include "device_placed.h"

#include "device_store.h"  // uploadAs

#include <algorithm>

namespace sinew::cuda {

bool DevicePlacedPoints::upload(const SceneData& scene, cudaStream_t stream) {
  std::vector<float3> pts;
  std::vector<int> owner, kind;
  const auto& ap = scene.attractionPoints();
  const auto& cp = scene.constraintPoints();
  const auto add = [&](const Vec3& c, size_t m, int k) {
    pts.push_back(make_float3(c.x(), c.y(), c.z()));
    owner.push_back(static_cast<int>(m));
    kind.push_back(k);
  };
  for (size_t m = 0; m < std::max(ap.size(), cp.size()); ++m) {
    if (m < ap.size())
      for (const Vec3& c : ap[m]) add(c, m, kAttractPoint);
    if (m < cp.size())
      for (const ConstraintPoint& c : cp[m]) add(c.at, m, c.include ? kIncludePoint : kExcludePoint);
  }
  const void* before[2] = {points_.get(), windings_.get()};
  const bool constraints = std::any_of(kind.begin(), kind.end(), [](int k) { return k != kAttractPoint; });
  const bool changed = int(pts.size()) != count_ || constraints != constraints_;
  count_ = int(pts.size());
  constraints_ = constraints;
  points_.upload(pts, stream);
  mesh_.upload(owner, stream);
  kind_.upload(kind, stream);
  keys_.resize(pts.size());
  windings_.resize(pts.size());  // copies from pageable memory are staged before upload() returns
  return changed || points_.get() != before[0] || windings_.get() != before[1];
}

void DevicePlacedPoints::launch(const MeshView& m, ParamView p, int kRing, int kMargin, const int* meshBegin,
                                const int* meshEnd, cudaStream_t stream) const {
  launchAttraction(m, p, kRing, kMargin, points_.get(), mesh_.get(), kind_.get(), meshBegin, meshEnd, count_,
                   keys_.get(), windings_.get(), constraints_, stream);
}

void DeviceContactLinks::build(const MeshStore& store, const SceneData& scene, float distanceMm, bool withStiffness,
                               cudaStream_t stream) {
  clear();
  built_ = true;
  const ContactLinks links = findContactLinks(store, scene.contactPairs(), distanceMm);
  if (links.linked == 0) return;
  const std::vector<int> partner(links.partner.begin(), links.partner.end());
  partner_.upload(partner, stream);
  uploadAs(offset_, std::span<const Vec3>(links.offset), stream);
  if (withStiffness) {
    stiffness_.resize(partner.size());
    SINEW_CUDA(cudaMemsetAsync(stiffness_.get(), 0, stiffness_.bytes(), stream));
  }
  SINEW_CUDA(cudaStreamSynchronize(stream));  // the host vectors go out of scope
}

void DeviceContactLinks::launch(const MeshView& m, ParamView p, cudaStream_t stream) {
  if (partner_.get()) launchContactSprings(m, p, partner_.get(), offset_.get(), stiffness_.get(), stream);
}

}  // namespace sinew::cuda
