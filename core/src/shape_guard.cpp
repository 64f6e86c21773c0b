#include "sinew/core/shape_guard.h"

#include "sinew/core/self_intersection.h"
#include "sinew/core/simplex_mesh.h"

#include <tbb/parallel_for.h>

#include <cstdio>

namespace sinew {

// The Fig. 1b tessellation's volume (tessellate(), then TriangleMesh::volume(): the same triangles
// in the same order, so the same value) without building the triangle mesh: the guard runs at every
// chunk in the workstation, at a million vertices too.
double structureVolume(MeshStore& store, Index mesh) {
  const MeshRange& r = store.range(mesh);
  const auto x = store.positions();
  const auto offsets = store.cellOffsets();
  const auto vertices = store.cellVertices();
  double v = 0.0;
  for (Index c = r.cellBegin; c < r.cellEnd; ++c) {
    const Index begin = offsets[c], end = offsets[c + 1];
    Vec3 sum = Vec3::Zero();
    for (Index i = begin; i < end; ++i) sum += x[vertices[i]];
    const Eigen::Vector3d centre = (sum / static_cast<float>(end - begin)).cast<double>();
    for (Index i = begin; i < end; ++i) {
      const Eigen::Vector3d a = x[vertices[i]].cast<double>();
      const Eigen::Vector3d b = x[vertices[i + 1 == end ? begin : i + 1]].cast<double>();
      v += a.dot(b.cross(centre));
    }
  }
  return v / 6.0;
}

Vec3 structureCentroid(MeshStore& store, Index mesh) {
  const MeshRange& r = store.range(mesh);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) sum += store.positions()[v].cast<double>();
  return (sum / double(std::max<Index>(1, r.vertexCount()))).cast<float>();
}

Vec3 cellVectorArea(const MeshStore& store, std::span<const Vec3> x, Index cell) {
  const auto& offsets = store.cellOffsets();
  const auto& vertices = store.cellVertices();
  const Index begin = offsets[cell], end = offsets[cell + 1];
  // Relative to the first corner: the same vector area, without the cancellation of large coordinates.
  const Vec3 o = x[vertices[begin]];
  Vec3 sum = Vec3::Zero();
  for (Index k = begin + 1; k + 1 < end; ++k) sum += (x[vertices[k]] - o).cross(x[vertices[k + 1]] - o);
  return 0.5f * sum;
}

void ShapeGuard::capture(MeshStore& store) {
  volume_.clear();
  centroid_.clear();
  for (Index m = 0; m < store.meshCount(); ++m) {
    volume_.push_back(structureVolume(store, m));
    centroid_.push_back(structureCentroid(store, m));
  }
  cellArea_.clear();
  followLevel(store);
}

void ShapeGuard::followLevel(MeshStore& store) {
  if (cellArea_.size() == std::size_t(store.cellCount())) return;
  cellArea_.resize(store.cellCount());
  for (Index c = 0; c < store.cellCount(); ++c) cellArea_[c] = cellVectorArea(store, store.positions(), c);
}

std::string ShapeGuard::check(MeshStore& store, const ImageGeometry& image, const ShapeLimits& limits,
                              const std::vector<std::string>& names) const {
  // Structures are checked at once (a million vertices in the workstation, at every chunk); the
  // first problem in structure order is reported, as if one after the other.
  const Index count = std::min<Index>(store.meshCount(), Index(volume_.size()));
  std::vector<std::string> problems(count);
  tbb::parallel_for(Index(0), count, [&](Index m) { problems[m] = checkOne(store, m, image, limits, names); });
  for (auto& p : problems)
    if (!p.empty()) return std::move(p);
  return {};
}

std::string ShapeGuard::checkOne(MeshStore& store, Index m, const ImageGeometry& image, const ShapeLimits& limits,
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
  // A cell turned over points its vector area against the start's; a collapsed one keeps under a
  // hundredth of the start's area. Both are shares of the structure's cells.
  Index inverted = 0, collapsed = 0;
  for (Index c = r.cellBegin; c < r.cellEnd && c < Index(cellArea_.size()); ++c) {
    const Vec3 now = cellVectorArea(store, store.positions(), c);
    const float before = cellArea_[c].norm();
    inverted += now.dot(cellArea_[c]) < 0.0f;
    collapsed += now.norm() < 0.01f * before;
  }
  const double cells = double(std::max<Index>(1, r.cellEnd - r.cellBegin));
  if (inverted / cells > limits.maxInvertedFraction) {
    std::snprintf(text, sizeof text, "shape check: %s has %.3g %% of its cells turned over against the start (limit %.3g %%)",
                  name.c_str(), 100.0 * inverted / cells, 100.0 * limits.maxInvertedFraction);
    return text;
  }
  if (collapsed / cells > limits.maxCollapsedFraction) {
    std::snprintf(text, sizeof text,
                  "shape check: %s has %.3g %% of its cells collapsed below 1 %% of their area at the start (limit %.3g %%)",
                  name.c_str(), 100.0 * collapsed / cells, 100.0 * limits.maxCollapsedFraction);
    return text;
  }
  // Last: the dearest check, on a sample of the surface.
  if (limits.maxSelfIntersectingFraction < 1.0) {
    const SelfIntersectionSample si = sampleSelfIntersections(store, store.positions(), m);
    if (si.fraction() > limits.maxSelfIntersectingFraction) {
      std::snprintf(text, sizeof text,
                    "shape check: %s crosses itself: %.3g %% of %lld sampled surface triangles pass through another part "
                    "of it (limit %.3g %%)",
                    name.c_str(), 100.0 * si.fraction(), static_cast<long long>(si.sampled),
                    100.0 * limits.maxSelfIntersectingFraction);
      return text;
    }
  }
  return {};
}

}  // namespace sinew
