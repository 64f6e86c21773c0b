#include "sinew/core/shape_guard.h"

#include "sinew/core/self_intersection.h"
#include "sinew/core/simplex_mesh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace sinew {

namespace {
// Six times the volume that cell c's fan (Fig. 1b: each cell fanned around its centroid) adds.
double cellVolume6(std::span<const Vec3> x, std::span<const Index> offsets, std::span<const Index> vertices, Index c) {
  const Index begin = offsets[c], end = offsets[c + 1];
  Vec3 sum = Vec3::Zero();
  for (Index i = begin; i < end; ++i) sum += x[vertices[i]];
  const Eigen::Vector3d centre = (sum / static_cast<float>(end - begin)).cast<double>();
  double v = 0.0;
  for (Index i = begin; i < end; ++i) {
    const Eigen::Vector3d a = x[vertices[i]].cast<double>();
    const Eigen::Vector3d b = x[vertices[i + 1 == end ? begin : i + 1]].cast<double>();
    v += a.dot(b.cross(centre));
  }
  return v;
}

// Sums over a structure's cells or vertices in parallel, in a fixed order (the same value on every
// run and thread count): the guard runs at every chunk in the workstation, at a million vertices too.
template <class T, class Add>
T deterministicSum(Index begin, Index end, const T& zero, Add add) {
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<Index>(begin, end, 4096), zero,
      [&](const tbb::blocked_range<Index>& range, T sum) {
        for (Index i = range.begin(); i < range.end(); ++i) add(sum, i);
        return sum;
      },
      [](T a, const T& b) {
        a += b;
        return a;
      });
}

struct CellSums {
  double volume6 = 0.0;
  Index inverted = 0, collapsed = 0;
  CellSums& operator+=(const CellSums& o) {
    volume6 += o.volume6;
    inverted += o.inverted;
    collapsed += o.collapsed;
    return *this;
  }
};
struct VertexSums {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Index outside = 0, swinging = 0;
  VertexSums& operator+=(const VertexSums& o) {
    position += o.position;
    outside += o.outside;
    swinging += o.swinging;
    return *this;
  }
};
}  // namespace

// The Fig. 1b tessellation's volume, without building the triangle mesh.
double structureVolume(MeshStore& store, Index mesh) {
  const MeshRange& r = store.range(mesh);
  const auto x = store.positions();
  const auto offsets = store.cellOffsets();
  const auto vertices = store.cellVertices();
  return deterministicSum(r.cellBegin, r.cellEnd, 0.0, [&](double& v, Index c) { v += cellVolume6(x, offsets, vertices, c); }) / 6.0;
}

Vec3 structureCentroid(MeshStore& store, Index mesh) {
  const MeshRange& r = store.range(mesh);
  const auto x = store.positions();
  const Eigen::Vector3d sum =
      deterministicSum(r.vertexBegin, r.vertexEnd, Eigen::Vector3d::Zero().eval(), [&](Eigen::Vector3d& s, Index v) { s += x[v].cast<double>(); });
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

namespace {
// How far p lies outside the image (mm): past the outer faces of its border voxels, along each of
// its axes, combined; 0 inside.
struct ImageExtent {
  explicit ImageExtent(const ImageGeometry& image)
      : image(image), toIndex(image.indexToWorldMatrix().inverse().cast<float>()), origin(image.origin.cast<float>()) {}
  float distanceOutside(const Vec3& p) const {
    const Vec3 idx = toIndex * (p - origin);
    float d2 = 0.0f;
    for (int a = 0; a < 3; ++a) {
      const float past = std::max({-0.5f - idx[a], idx[a] - (float(image.size[a]) - 0.5f), 0.0f}) * float(image.spacing[a]);
      d2 += past * past;
    }
    return std::sqrt(d2);
  }
  bool contains(const Vec3& p) const { return image.containsIndex(toIndex * (p - origin)); }
  const ImageGeometry& image;
  Eigen::Matrix3f toIndex;
  Vec3 origin;
};
}  // namespace

Index pointsOutside(std::span<const Vec3> points, const ImageGeometry& image) {
  const ImageExtent extent(image);
  return deterministicSum(Index(0), Index(points.size()), Index(0), [&](Index& n, Index v) { n += !extent.contains(points[v]); });
}

Index verticesOutside(MeshStore& store, Index mesh, const ImageGeometry& image) {
  return pointsOutside(store.mesh(store.positions(), mesh), image);
}

float farthestOutside(std::span<const Vec3> points, const ImageGeometry& image) {
  const ImageExtent extent(image);
  float farthest = 0.0f;
  for (const Vec3& p : points) farthest = std::max(farthest, extent.distanceOutside(p));
  return farthest;
}

void ShapeGuard::capture(MeshStore& store, const ImageGeometry& image) {
  volume_.clear();
  centroid_.clear();
  outsideReach_.clear();
  for (Index m = 0; m < store.meshCount(); ++m) {
    volume_.push_back(structureVolume(store, m));
    centroid_.push_back(structureCentroid(store, m));
    outsideReach_.push_back(farthestOutside(store.mesh(store.positions(), m), image));
  }
  cellArea_.clear();
  followLevel(store);
}

void ShapeGuard::followLevel(MeshStore& store) {
  if (cellArea_.size() == std::size_t(store.cellCount())) return;
  cellArea_.resize(store.cellCount());
  tbb::parallel_for(Index(0), store.cellCount(), [&](Index c) { cellArea_[c] = cellVectorArea(store, store.positions(), c); });
}

std::string ShapeGuard::check(MeshStore& store, const ImageGeometry& image, const ShapeLimits& limits,
                              const std::vector<std::string>& names, std::span<const Vec3> chunkStart) const {
  // Structures are checked at once (a million vertices in the workstation, at every chunk); the
  // first problem in structure order is reported, as if one after the other.
  const Index count = std::min<Index>(store.meshCount(), Index(volume_.size()));
  std::vector<std::string> problems(count);
  tbb::parallel_for(Index(0), count, [&](Index m) { problems[m] = checkOne(store, m, image, limits, names, chunkStart); });
  for (auto& p : problems)
    if (!p.empty()) return std::move(p);
  return {};
}

std::string ShapeGuard::checkOne(MeshStore& store, Index m, const ImageGeometry& image, const ShapeLimits& limits,
                                 const std::vector<std::string>& names, std::span<const Vec3> chunkStart) const {
  const ImageExtent extent(image);
  const float outsideLimit = outsideReach_[m] + float(limits.outsideBandMm);
  char text[256];
  const std::string name = "structure '" + (m < Index(names.size()) ? names[m] : std::to_string(m)) + "'";
  // Two passes, each in parallel: the cells (volume, turned over, collapsed), the vertices (centroid,
  // outside the image). A cell turned over points its vector area against the start's; a collapsed
  // one keeps under a hundredth of the start's area.
  const MeshRange& r = store.range(m);
  const auto x = store.positions();
  const auto offsets = store.cellOffsets();
  const auto vertices = store.cellVertices();
  const Index areaEnd = std::min<Index>(r.cellEnd, Index(cellArea_.size()));
  const CellSums cellSums = deterministicSum(r.cellBegin, r.cellEnd, CellSums{}, [&](CellSums& s, Index c) {
    s.volume6 += cellVolume6(x, offsets, vertices, c);
    if (c >= areaEnd) return;
    const Vec3 now = cellVectorArea(store, x, c);
    s.inverted += now.dot(cellArea_[c]) < 0.0f;
    s.collapsed += now.norm() < 0.01f * cellArea_[c].norm();
  });
  const bool swingCheck = !chunkStart.empty() && store.has(Attribute::PreviousPosition);
  const auto previous = swingCheck ? store.previousPositions() : std::span<Vec3>();
  if (swingCheck && (chunkStart.size() != x.size() || previous.size() != x.size()))
    throw std::invalid_argument("ShapeGuard::check: the chunk's start has another vertex count than the store");
  const VertexSums vertexSums = deterministicSum(r.vertexBegin, r.vertexEnd, VertexSums{}, [&](VertexSums& s, Index v) {
    s.position += x[v].cast<double>();
    s.outside += extent.distanceOutside(x[v]) > outsideLimit;
    if (!swingCheck) return;
    const float step = (x[v] - previous[v]).norm();
    s.swinging += step > ShapeLimits::kSwingStepMm && (x[v] - chunkStart[v]).norm() < 2.0f * step;
  });
  const double ratio = volume_[m] > 0.0 ? cellSums.volume6 / 6.0 / volume_[m] : 1.0;
  if (!(ratio >= limits.minVolumeRatio && ratio <= limits.maxVolumeRatio)) {
    const bool shrunk = !(ratio >= limits.minVolumeRatio);
    std::snprintf(text, sizeof text, "shape check: %s has %.4g times its volume at the start, %s the %s %.3g",
                  name.c_str(), ratio, shrunk ? "below" : "above", shrunk ? "minimum" : "maximum",
                  shrunk ? limits.minVolumeRatio : limits.maxVolumeRatio);
    return text;
  }
  const Vec3 centroid = (vertexSums.position / double(std::max<Index>(1, r.vertexCount()))).cast<float>();
  const double drift = (centroid - centroid_[m]).norm();
  if (!(drift <= limits.maxDriftMm)) {
    std::snprintf(text, sizeof text, "shape check: %s drifted %.3g mm from where it started (limit %.3g mm)",
                  name.c_str(), drift, limits.maxDriftMm);
    return text;
  }
  // Against how far outside the structure reached at the start: a field of view that cuts it
  // leaves it partly outside, and the vertices at the cut cross the image's border as it fits.
  const double vertexCount = double(std::max<Index>(1, r.vertexCount()));
  const double fraction = double(vertexSums.outside) / vertexCount;
  if (fraction > limits.maxOutsideFraction && vertexSums.outside >= ShapeLimits::kMinOutside) {
    if (outsideReach_[m] == 0.0f)
      std::snprintf(text, sizeof text,
                    "shape check: %s has %.3g %% of its vertices more than %.3g mm outside the image (limit %.3g %%)",
                    name.c_str(), 100.0 * fraction, limits.outsideBandMm, 100.0 * limits.maxOutsideFraction);
    else
      std::snprintf(text, sizeof text,
                    "shape check: %s has %.3g %% of its vertices more than %.3g mm outside the image, %.3g mm beyond "
                    "the %.3g mm it reached at the start (limit %.3g %%)",
                    name.c_str(), 100.0 * fraction, double(outsideLimit), limits.outsideBandMm, double(outsideReach_[m]),
                    100.0 * limits.maxOutsideFraction);
    return text;
  }
  const Index inverted = cellSums.inverted, collapsed = cellSums.collapsed;
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
  const Index swinging = vertexSums.swinging;
  if (swinging >= ShapeLimits::kMinSwinging && swinging > limits.maxSwingingFraction * double(r.vertexCount())) {
    std::snprintf(text, sizeof text,
                  "shape check: %s swings: %lld of its %lld vertices moved more than %.3g mm in the last step but "
                  "ended the chunk within two such steps of where they began it (limit %.3g %%)",
                  name.c_str(), static_cast<long long>(swinging), static_cast<long long>(r.vertexCount()),
                  double(ShapeLimits::kSwingStepMm), 100.0 * limits.maxSwingingFraction);
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
