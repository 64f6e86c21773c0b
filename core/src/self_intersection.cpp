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

namespace {

// The crossing test over one structure's cells [cellBegin, cellEnd) of the given cell arrays: at
// most maxSamples of its fan triangles, evenly spread, each tested against every triangle of the
// structure that shares no vertex and no cell with it. Returns the number sampled and, for each
// sample that crosses, its two simplex vertices (the cell's corner and the next corner).
struct Crossings {
  Index sampled = 0;
  std::vector<std::array<Index, 2>> crossing;
};

Crossings findCrossings(std::span<const Index> offsets, std::span<const Index> vertices, Index cellBegin,
                        Index cellEnd, std::span<const Vec3> x, Index maxSamples) {
  Crossings out;
  const Index cells = cellEnd - cellBegin;
  if (cells <= 0) return out;
  const auto centreOf = [&](Index c) {
    const Index begin = offsets[cellBegin + c], end = offsets[cellBegin + c + 1];
    Vec3 sum = Vec3::Zero();
    for (Index i = begin; i < end; ++i) sum += x[vertices[i]];
    return Vec3(sum / float(end - begin));
  };

  // The sampled triangles: the t-th corner of the structure's cells, the next corner of its cell and
  // the cell's centroid.
  struct Sample {
    Index cell, u, v;
    Eigen::Vector3d corner[3];
    Eigen::AlignedBox3f box;
  };
  const Index triangles = offsets[cellEnd] - offsets[cellBegin];
  const Index stride = std::max<Index>(1, (triangles + maxSamples - 1) / std::max<Index>(1, maxSamples));
  const Index sampleCount = (triangles + stride - 1) / stride;
  std::vector<Sample> samples(static_cast<std::size_t>(sampleCount));
  const auto firstCorner = offsets.begin() + cellBegin, lastCorner = offsets.begin() + cellEnd + 1;
  Eigen::AlignedBox3f all;
  std::vector<float> extents;
  for (Index k = 0; k < sampleCount; ++k) {
    Sample& s = samples[std::size_t(k)];
    const Index i = offsets[cellBegin] + k * stride;
    s.cell = Index(std::upper_bound(firstCorner, lastCorner, i) - firstCorner) - 1;
    const Index begin = offsets[cellBegin + s.cell], end = offsets[cellBegin + s.cell + 1];
    s.u = vertices[i];
    s.v = vertices[i + 1 == end ? begin : i + 1];
    const Vec3 corners[3] = {x[s.u], x[s.v], centreOf(s.cell)};
    for (int j = 0; j < 3; ++j) {
      s.corner[j] = corners[j].cast<double>();
      s.box.extend(corners[j]);
    }
    all.extend(s.box);
    extents.push_back(s.box.sizes().maxCoeff());
  }

  // The samples binned on a grid over their own bounding box, each in every bin its box meets; the
  // spacing twice their 99th-percentile extent, coarsened until the grid has at most 64^3 bins.
  const auto p99 = extents.begin() + std::ptrdiff_t(std::size_t(sampleCount - 1) * 99 / 100);
  std::nth_element(extents.begin(), p99, extents.end());
  float spacing = std::max(2.0f * *p99, 1e-6f);
  std::array<long, 3> dims{};
  for (;;) {
    for (int a = 0; a < 3; ++a) dims[a] = long(all.sizes()[a] / spacing) + 1;
    if (dims[0] * dims[1] * dims[2] <= 64L * 64 * 64) break;
    spacing *= 1.5f;
  }
  const auto binOf = [&](float p, int a) { return std::clamp(long((p - all.min()[a]) / spacing), 0L, dims[a] - 1); };
  const std::size_t binCount = std::size_t(dims[0] * dims[1] * dims[2]);
  const auto binIndex = [&](long bx, long by, long bz) { return std::size_t((bz * dims[1] + by) * dims[0] + bx); };
  std::vector<Index> start(binCount + 1, 0), order;
  for (int pass = 0; pass < 2; ++pass) {  // count, then fill
    std::vector<Index> fill;
    if (pass == 1) {
      for (std::size_t b = 0; b < binCount; ++b) start[b + 1] += start[b];
      order.resize(std::size_t(start[binCount]));
      fill.assign(start.begin(), start.end() - 1);
    }
    for (Index k = 0; k < sampleCount; ++k) {
      const Eigen::AlignedBox3f& b = samples[std::size_t(k)].box;
      for (long z = binOf(b.min()[2], 2); z <= binOf(b.max()[2], 2); ++z)
        for (long y = binOf(b.min()[1], 1); y <= binOf(b.max()[1], 1); ++y)
          for (long xb = binOf(b.min()[0], 0); xb <= binOf(b.max()[0], 0); ++xb) {
            const std::size_t bin = binIndex(xb, y, z);
            if (pass == 0) ++start[bin + 1];
            else order[std::size_t(fill[bin]++)] = k;
          }
    }
  }

  // One pass over the cells: each cell's fan against the samples in the bins its box meets. A pair
  // met in several bins is tested in one only: the bin of the larger of the two boxes' minima.
  std::vector<std::atomic<bool>> crossed(static_cast<std::size_t>(sampleCount));
  tbb::parallel_for(tbb::blocked_range<Index>(0, cells, 1024), [&](const tbb::blocked_range<Index>& range) {
    for (Index c = range.begin(); c < range.end(); ++c) {
      const Index begin = offsets[cellBegin + c], end = offsets[cellBegin + c + 1];
      Eigen::AlignedBox3f box;
      Vec3 sum = Vec3::Zero();
      for (Index i = begin; i < end; ++i) {
        sum += x[vertices[i]];
        box.extend(x[vertices[i]]);
      }
      if (!box.intersects(all)) continue;
      const Eigen::Vector3d apex = (sum / float(end - begin)).cast<double>();
      const Eigen::AlignedBox3f inGrid = box.intersection(all);
      for (long z = binOf(inGrid.min()[2], 2); z <= binOf(inGrid.max()[2], 2); ++z)
        for (long y = binOf(inGrid.min()[1], 1); y <= binOf(inGrid.max()[1], 1); ++y)
          for (long xb = binOf(inGrid.min()[0], 0); xb <= binOf(inGrid.max()[0], 0); ++xb) {
            const std::size_t bin = binIndex(xb, y, z);
            for (Index k = start[bin]; k < start[bin + 1]; ++k) {
              const Index t = order[std::size_t(k)];
              const Sample& s = samples[std::size_t(t)];
              if (s.cell == c || crossed[std::size_t(t)].load(std::memory_order_relaxed) || !s.box.intersects(box)) continue;
              const Vec3 lo = s.box.min().cwiseMax(box.min());
              if (binIndex(binOf(lo[0], 0), binOf(lo[1], 1), binOf(lo[2], 2)) != bin) continue;
              Eigen::Vector3d b[3];
              b[2] = apex;
              for (Index i = begin; i < end; ++i) {
                const Index p = vertices[i], q = vertices[i + 1 == end ? begin : i + 1];
                if (p == s.u || p == s.v || q == s.u || q == s.v) continue;
                b[0] = x[p].cast<double>();
                b[1] = x[q].cast<double>();
                if (trianglesIntersect(s.corner, b)) {
                  crossed[std::size_t(t)].store(true, std::memory_order_relaxed);
                  break;
                }
              }
            }
          }
    }
  });
  out.sampled = sampleCount;
  for (Index k = 0; k < sampleCount; ++k)
    if (crossed[std::size_t(k)].load(std::memory_order_relaxed))
      out.crossing.push_back({samples[std::size_t(k)].u, samples[std::size_t(k)].v});
  return out;
}

}  // namespace

SelfIntersectionSample sampleSelfIntersections(const MeshStore& store, std::span<const Vec3> x, Index mesh,
                                               Index maxSamples) {
  const MeshRange& r = store.range(mesh);
  for (Index v = r.vertexBegin; v < r.vertexEnd; ++v)
    if (!x[v].allFinite()) return {};  // the numerical guard's business
  const Crossings c = findCrossings(store.cellOffsets(), store.cellVertices(), r.cellBegin, r.cellEnd, x, maxSamples);
  return {c.sampled, Index(c.crossing.size())};
}

std::vector<Index> crossingVertices(const SimplexTopology& topology, std::span<const Vec3> x) {
  const Index triangles = Index(topology.cellVertices.size());
  const Crossings c = findCrossings(topology.cellOffsets, topology.cellVertices, 0, topology.cellCount(), x, triangles);
  std::vector<Index> out;
  for (const auto& [u, v] : c.crossing) out.insert(out.end(), {u, v});
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace sinew
