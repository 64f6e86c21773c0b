#include "sinew/core/self_intersection.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <functional>
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

}  // namespace

namespace {
// Whether the three points lie strictly on one side of the plane through t (Moller's early-out: then
// no edge of theirs reaches t).
bool oneSide(const Eigen::Vector3d t[3], const Eigen::Vector3d p[3]) {
  const Eigen::Vector3d n = (t[1] - t[0]).cross(t[2] - t[0]);
  const double d0 = n.dot(p[0] - t[0]), d1 = n.dot(p[1] - t[0]), d2 = n.dot(p[2] - t[0]);
  return (d0 > 0.0 && d1 > 0.0 && d2 > 0.0) || (d0 < 0.0 && d1 < 0.0 && d2 < 0.0);
}
}  // namespace

bool trianglesIntersect(const Eigen::Vector3d a[3], const Eigen::Vector3d b[3]) {
  if (oneSide(a, b) || oneSide(b, a)) return false;
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
  SelfIntersectionSample out;
  const Index cells = r.cellEnd - r.cellBegin;
  if (cells <= 0) return out;
  // Per cell: its centroid (the fan's apex), its box (the fan lies in its corners' hull) and extent.
  std::vector<Vec3> centre(static_cast<std::size_t>(cells));
  std::vector<Eigen::AlignedBox3f> box(static_cast<std::size_t>(cells));
  std::vector<float> extent(static_cast<std::size_t>(cells));
  std::atomic<bool> finite{true};
  tbb::parallel_for(tbb::blocked_range<Index>(0, cells, 2048), [&](const tbb::blocked_range<Index>& range) {
    for (Index c = range.begin(); c < range.end(); ++c) {
      const Index begin = offsets[r.cellBegin + c], end = offsets[r.cellBegin + c + 1];
      Vec3 sum = Vec3::Zero();
      Eigen::AlignedBox3f& b = box[std::size_t(c)];
      for (Index i = begin; i < end; ++i) {
        const Vec3& p = x[vertices[i]];
        if (!p.allFinite()) finite = false;
        sum += p;
        b.extend(p);
      }
      centre[std::size_t(c)] = sum / float(end - begin);
      extent[std::size_t(c)] = b.sizes().maxCoeff();
    }
  });
  if (!finite) return out;  // the numerical guard's business
  Eigen::AlignedBox3f all;
  for (const Eigen::AlignedBox3f& b : box) all.extend(b);

  // Cells binned by centroid on a grid of twice the 99th percentile of their extents: two cells of
  // at most half the spacing whose boxes meet have centroids within one bin of each other. The few
  // larger cells (stretched) are kept aside and tested against every query.
  std::vector<float> sorted = extent;
  const auto p99 = sorted.begin() + std::ptrdiff_t(std::size_t(cells - 1) * 99 / 100);
  std::nth_element(sorted.begin(), p99, sorted.end());
  float spacing = std::max(2.0f * *p99, 1e-6f);
  std::array<long, 3> dims{};
  for (;;) {
    for (int a = 0; a < 3; ++a) dims[a] = long(all.sizes()[a] / spacing) + 1;
    if (dims[0] * dims[1] * dims[2] <= 8L * cells + 64) break;
    spacing *= 1.5f;
  }
  const auto binOf = [&](const Vec3& p, int a) { return std::clamp(long((p[a] - all.min()[a]) / spacing), 0L, dims[a] - 1); };
  const std::size_t binCount = std::size_t(dims[0] * dims[1] * dims[2]);
  std::vector<Index> start(binCount + 1, 0), binOfCell(static_cast<std::size_t>(cells), -1), large;
  for (Index c = 0; c < cells; ++c) {
    if (extent[std::size_t(c)] > 0.5f * spacing) {
      large.push_back(c);
      continue;
    }
    const Vec3& p = centre[std::size_t(c)];
    binOfCell[std::size_t(c)] = Index((binOf(p, 2) * dims[1] + binOf(p, 1)) * dims[0] + binOf(p, 0));
    ++start[std::size_t(binOfCell[std::size_t(c)]) + 1];
  }
  for (std::size_t b = 0; b < binCount; ++b) start[b + 1] += start[b];
  std::vector<Index> order(static_cast<std::size_t>(start[binCount]));
  {
    std::vector<Index> fill(start.begin(), start.end() - 1);
    for (Index c = 0; c < cells; ++c)
      if (binOfCell[std::size_t(c)] >= 0) order[std::size_t(fill[std::size_t(binOfCell[std::size_t(c)])]++)] = c;
  }

  // The sampled triangle (corners a, its cell's vertices u, v) against cell d's fan: each of d's
  // triangles that shares no vertex with it.
  const auto crossesCell = [&](Index d, const Eigen::Vector3d a[3], Index u, Index v, const Eigen::AlignedBox3f& tbox) {
    if (!box[std::size_t(d)].intersects(tbox)) return false;
    const Index begin = offsets[r.cellBegin + d], end = offsets[r.cellBegin + d + 1];
    Eigen::Vector3d b[3];
    b[2] = centre[std::size_t(d)].cast<double>();
    for (Index i = begin; i < end; ++i) {
      const Index p = vertices[i], q = vertices[i + 1 == end ? begin : i + 1];
      if (p == u || p == v || q == u || q == v) continue;
      b[0] = x[p].cast<double>();
      b[1] = x[q].cast<double>();
      if (trianglesIntersect(a, b)) return true;
    }
    return false;
  };

  const Index triangles = offsets[r.cellEnd] - offsets[r.cellBegin];
  const Index stride = std::max<Index>(1, (triangles + maxSamples - 1) / std::max<Index>(1, maxSamples));
  const Index samples = (triangles + stride - 1) / stride;
  const auto firstCorner = offsets.begin() + r.cellBegin, lastCorner = offsets.begin() + r.cellEnd + 1;
  // Whether sampled triangle t (the t-th corner of the structure's cells, with the next corner and
  // its cell's centroid) crosses a cell it is not joined to.
  const auto sampleCrosses = [&](Index t) {
    const Index i = offsets[r.cellBegin] + t;
    const Index c = Index(std::upper_bound(firstCorner, lastCorner, i) - firstCorner) - 1;  // its cell
    const Index begin = offsets[r.cellBegin + c], end = offsets[r.cellBegin + c + 1];
    const Index u = vertices[i], v = vertices[i + 1 == end ? begin : i + 1];
    const Eigen::Vector3d a[3] = {x[u].cast<double>(), x[v].cast<double>(), centre[std::size_t(c)].cast<double>()};
    Eigen::AlignedBox3f tbox;
    for (const Eigen::Vector3d& p : a) tbox.extend(p.cast<float>());
    bool crossed = false;
    const auto test = [&](Index d) { crossed = crossed || (d != c && crossesCell(d, a, u, v, tbox)); };
    if (extent[std::size_t(c)] > 0.5f * spacing) {  // a large cell: against every cell
      for (Index d = 0; d < cells && !crossed; ++d) test(d);
      return crossed;
    }
    for (std::size_t k = 0; k < large.size() && !crossed; ++k) test(large[k]);
    const Vec3& p = centre[std::size_t(c)];
    const long bx = binOf(p, 0), by = binOf(p, 1), bz = binOf(p, 2);
    for (long z = std::max(0L, bz - 1); z <= std::min(dims[2] - 1, bz + 1) && !crossed; ++z)
      for (long y = std::max(0L, by - 1); y <= std::min(dims[1] - 1, by + 1) && !crossed; ++y)
        for (long xb = std::max(0L, bx - 1); xb <= std::min(dims[0] - 1, bx + 1) && !crossed; ++xb) {
          const std::size_t bin = std::size_t((z * dims[1] + y) * dims[0] + xb);
          for (Index k = start[bin]; k < start[bin + 1] && !crossed; ++k) test(order[std::size_t(k)]);
        }
    return crossed;
  };
  out.sampled = samples;
  out.intersecting = tbb::parallel_reduce(
      tbb::blocked_range<Index>(0, samples, 16), Index(0),
      [&](const tbb::blocked_range<Index>& range, Index count) {
        for (Index k = range.begin(); k < range.end(); ++k) count += sampleCrosses(k * stride);
        return count;
      },
      std::plus<Index>());
  return out;
}

}  // namespace sinew
