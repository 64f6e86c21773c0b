#include "sinew/core/self_intersection.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace sinew {

namespace {

// Whether the segment p-q passes through triangle t (Moller-Trumbore, the segment's parameter in
// [0, 1]).
bool segmentCrossesTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d t[3]) {
  const Eigen::Vector3d d = q - p, e1 = t[1] - t[0], e2 = t[2] - t[0];
  const Eigen::Vector3d h = d.cross(e2);
  const double det = e1.dot(h);
  const double scale = e1.squaredNorm() * d.norm() * e2.norm();
  if (std::abs(det) <= 1e-12 * std::max(scale, 1e-300)) return false;  // parallel to the plane
  const double inv = 1.0 / det;
  const Eigen::Vector3d s = p - t[0];
  const double u = inv * s.dot(h);
  if (u < 0.0 || u > 1.0) return false;
  const Eigen::Vector3d qv = s.cross(e1);
  const double v = inv * d.dot(qv);
  if (v < 0.0 || u + v > 1.0) return false;
  const double along = inv * e2.dot(qv);
  return along >= 0.0 && along <= 1.0;
}

struct Triangle {
  std::array<Index, 3> vertex;  // mesh vertices; the centroid corner is -1
  Index cell;
};

}  // namespace

bool trianglesIntersect(const Eigen::Vector3d a[3], const Eigen::Vector3d b[3]) {
  for (int i = 0; i < 3; ++i) {
    if (segmentCrossesTriangle(a[i], a[(i + 1) % 3], b)) return true;
    if (segmentCrossesTriangle(b[i], b[(i + 1) % 3], a)) return true;
  }
  return false;
}

SelfIntersectionSample sampleSelfIntersections(const MeshStore& store, std::span<const Vec3> x, Index mesh,
                                               Index maxSamples) {
  const MeshRange& r = store.range(mesh);
  const auto offsets = store.cellOffsets();
  const auto vertices = store.cellVertices();
  // The fan triangles and their corners.
  std::vector<Triangle> tris;
  std::vector<Vec3> corners;
  tris.reserve(std::size_t(offsets[r.cellEnd] - offsets[r.cellBegin]));
  corners.reserve(tris.capacity() * 3);
  for (Index c = r.cellBegin; c < r.cellEnd; ++c) {
    const Index begin = offsets[c], end = offsets[c + 1];
    Vec3 centre = Vec3::Zero();
    for (Index i = begin; i < end; ++i) centre += x[vertices[i]];
    centre /= float(end - begin);
    for (Index i = begin; i < end; ++i) {
      const Index a = vertices[i], b = vertices[i + 1 == end ? begin : i + 1];
      tris.push_back({{a, b, -1}, c});
      corners.insert(corners.end(), {x[a], x[b], centre});
    }
  }
  SelfIntersectionSample out;
  const Index n = Index(tris.size());
  if (n == 0) return out;
  for (const Vec3& p : corners)
    if (!p.allFinite()) return out;  // the numerical guard's business

  // Bins: spacing twice the 99th percentile of the triangles' extents, so two crossing triangles
  // of at most half the spacing have their centroids within one bin of each other. The few larger
  // triangles (a stretched cell) are kept aside and tested against everything.
  Eigen::AlignedBox3f all;
  std::vector<Eigen::AlignedBox3f> boxes(static_cast<std::size_t>(n));
  std::vector<float> extents(static_cast<std::size_t>(n));
  for (Index t = 0; t < n; ++t) {
    Eigen::AlignedBox3f& b = boxes[std::size_t(t)];
    for (int k = 0; k < 3; ++k) b.extend(corners[std::size_t(3 * t + k)]);
    all.extend(b);
    extents[std::size_t(t)] = b.sizes().maxCoeff();
  }
  std::vector<float> sorted = extents;
  const auto p99 = sorted.begin() + std::ptrdiff_t(std::size_t(n - 1) * 99 / 100);
  std::nth_element(sorted.begin(), p99, sorted.end());
  float spacing = std::max(2.0f * *p99, 1e-6f);
  std::array<long, 3> dims{};
  for (;;) {
    for (int a = 0; a < 3; ++a) dims[a] = long(all.sizes()[a] / spacing) + 1;
    if (dims[0] * dims[1] * dims[2] <= 8L * n + 64) break;
    spacing *= 1.5f;
  }
  const auto binOf = [&](const Vec3& p, int a) {
    return std::clamp(long((p[a] - all.min()[a]) / spacing), 0L, dims[a] - 1);
  };
  const auto centroid = [&](Index t) {
    return Vec3((corners[std::size_t(3 * t)] + corners[std::size_t(3 * t + 1)] + corners[std::size_t(3 * t + 2)]) / 3.0f);
  };
  const auto oversize = [&](Index t) { return extents[std::size_t(t)] > 0.5f * spacing; };
  // Counting sort of the other triangles by the bin of their centroid.
  const std::size_t binCount = std::size_t(dims[0] * dims[1] * dims[2]);
  std::vector<Index> start(binCount + 1, 0), order, binOfTriangle(std::size_t(n), -1), large;
  for (Index t = 0; t < n; ++t) {
    if (oversize(t)) {
      large.push_back(t);
      continue;
    }
    const Vec3 c = centroid(t);
    binOfTriangle[std::size_t(t)] = Index((binOf(c, 2) * dims[1] + binOf(c, 1)) * dims[0] + binOf(c, 0));
    ++start[std::size_t(binOfTriangle[std::size_t(t)]) + 1];
  }
  for (std::size_t b = 0; b < binCount; ++b) start[b + 1] += start[b];
  order.resize(std::size_t(start[binCount]));
  {
    std::vector<Index> fill(start.begin(), start.end() - 1);
    for (Index t = 0; t < n; ++t)
      if (binOfTriangle[std::size_t(t)] >= 0) order[std::size_t(fill[std::size_t(binOfTriangle[std::size_t(t)])]++)] = t;
  }

  const auto joined = [&](const Triangle& a, const Triangle& b) {
    if (a.cell == b.cell) return true;
    for (Index u : a.vertex)
      for (Index v : b.vertex)
        if (u >= 0 && u == v) return true;
    return false;
  };
  const auto crosses = [&](Index t, Index u, const Eigen::Vector3d a[3]) {
    if (u == t || !boxes[std::size_t(t)].intersects(boxes[std::size_t(u)]) || joined(tris[std::size_t(t)], tris[std::size_t(u)]))
      return false;
    Eigen::Vector3d b[3];
    for (int q = 0; q < 3; ++q) b[q] = corners[std::size_t(3 * u + q)].cast<double>();
    return trianglesIntersect(a, b);
  };
  const Index stride = std::max<Index>(1, (n + maxSamples - 1) / std::max<Index>(1, maxSamples));
  for (Index t = 0; t < n; t += stride) {
    ++out.sampled;
    Eigen::Vector3d a[3];
    for (int k = 0; k < 3; ++k) a[k] = corners[std::size_t(3 * t + k)].cast<double>();
    bool crossed = false;
    if (oversize(t)) {  // against everything
      for (Index u = 0; u < n && !crossed; ++u) crossed = crosses(t, u, a);
    } else {
      for (Index k = 0; k < Index(large.size()) && !crossed; ++k) crossed = crosses(t, large[std::size_t(k)], a);
      const Vec3 c = centroid(t);
      const long bx = binOf(c, 0), by = binOf(c, 1), bz = binOf(c, 2);
      for (long z = std::max(0L, bz - 1); z <= std::min(dims[2] - 1, bz + 1) && !crossed; ++z)
        for (long y = std::max(0L, by - 1); y <= std::min(dims[1] - 1, by + 1) && !crossed; ++y)
          for (long xb = std::max(0L, bx - 1); xb <= std::min(dims[0] - 1, bx + 1) && !crossed; ++xb) {
            const std::size_t bin = std::size_t((z * dims[1] + y) * dims[0] + xb);
            for (Index k = start[bin]; k < start[bin + 1] && !crossed; ++k) crossed = crosses(t, order[std::size_t(k)], a);
          }
    }
    out.intersecting += crossed;
  }
  return out;
}

}  // namespace sinew
