#include "sinew/core/shape_guard.h"

#include "sinew/core/simplex_mesh.h"

#include <cstdio>

namespace sinew {

double structureVolume(MeshStore& store, Index mesh) {
  const MeshRange& r = store.range(mesh);
  const auto x = store.positions();
  return tessellate(store.topologyOf(mesh), std::vector<Vec3>(x.begin() + r.vertexBegin, x.begin() + r.vertexEnd)).volume();
}

Vec3 structureCentroid(MeshStore& store, Index mesh) {
  const MeshRange& r = store.range(mesh);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) sum += store.positions()[v].cast<double>();
  return (sum / double(std::max<Index>(1, r.vertexCount()))).cast<float>();
}

void ShapeGuard::capture(MeshStore& store) {
  volume_.clear();
  centroid_.clear();
  for (Index m = 0; m < store.meshCount(); ++m) {
    volume_.push_back(structureVolume(store, m));
    centroid_.push_back(structureCentroid(store, m));
  }
}

std::string ShapeGuard::check(MeshStore& store, const ImageGeometry& image, const ShapeLimits& limits,
                              const std::vector<std::string>& names) const {
  const Eigen::Matrix3f toIndex = image.indexToWorldMatrix().inverse().cast<float>();
  const Vec3 origin = image.origin.cast<float>();
  const auto inside = [&](const Vec3& p) {
    const Vec3 idx = toIndex * (p - origin);
    for (int a = 0; a < 3; ++a)
      if (!(idx[a] >= -0.5f && idx[a] <= image.size[a] - 0.5f)) return false;
    return true;
  };
  char text[256];
  for (Index m = 0; m < store.meshCount() && m < Index(volume_.size()); ++m) {
    const std::string name = "structure '" + (m < Index(names.size()) ? names[m] : std::to_string(m)) + "'";
    const double ratio = volume_[m] > 0.0 ? structureVolume(store, m) / volume_[m] : 1.0;
    if (!(ratio >= limits.minVolumeRatio && ratio <= limits.maxVolumeRatio)) {
      const bool shrunk = !(ratio >= limits.minVolumeRatio);
      std::snprintf(text, sizeof text, "shape check: %s has %.4g times its volume at the start, %s the %s %.3g",
                    name.c_str(), ratio, shrunk ? "below" : "above", shrunk ? "minimum" : "maximum",
                    shrunk ? limits.minVolumeRatio : limits.maxVolumeRatio);
      return text;
    }
    const double drift = (structureCentroid(store, m) - centroid_[m]).norm();
    if (!(drift <= limits.maxDriftMm)) {
      std::snprintf(text, sizeof text, "shape check: %s drifted %.3g mm from where it started (limit %.3g mm)",
                    name.c_str(), drift, limits.maxDriftMm);
      return text;
    }
    const MeshRange& r = store.range(m);
    Index outside = 0;
    for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) outside += !inside(store.positions()[v]);
    const double fraction = double(outside) / double(std::max<Index>(1, r.vertexCount()));
    if (fraction > limits.maxOutsideFraction) {
      std::snprintf(text, sizeof text, "shape check: %s has %.3g %% of its vertices outside the image (limit %.3g %%)",
                    name.c_str(), 100.0 * fraction, 100.0 * limits.maxOutsideFraction);
      return text;
    }
  }
  return {};
}

}  // namespace sinew
