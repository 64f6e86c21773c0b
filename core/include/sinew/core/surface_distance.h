// Distances between surfaces, for evaluation: average symmetric surface distance (ASSD) and the
// 95th percentile Hausdorff distance, point-to-surface both ways over area-weighted samples.
#pragma once

#include "sinew/core/executor.h"
#include "sinew/core/triangle_bvh_wide.h"
#include "sinew/core/triangle_mesh.h"

#include <span>
#include <vector>

namespace sinew {

inline const collision::P3* asP3(std::span<const Vec3> v) { return reinterpret_cast<const collision::P3*>(v.data()); }
inline collision::P3 asP3(const Vec3& v) { return {v.x(), v.y(), v.z()}; }
inline Vec3 asVec3(const collision::P3& p) { return {p.x, p.y, p.z}; }

// The hierarchy of triangle_bvh.h, built on the host: splits along the widest axis of the
// triangles' centroids chosen by the surface area heuristic (medians from depth 32 down, so that a
// tree stays within the search's stack), down to leaves of at most trianglebvh::kLeafTriangles.
struct TriangleBvh {
  std::vector<trianglebvh::Node> nodes;          // pre-order, root first
  std::vector<trianglebvh::P3> corners;          // three per triangle, in leaf order
  std::vector<std::array<Index, 3>> triangles;   // the mesh's point indices, in leaf order (for refit)
  // The host's searches' tree (triangle_bvh_wide.h), made on request (requireWide): the same tree
  // in nodes of four children and its leaves' triangles side by side; each child's node in `nodes`
  // (-1: an unused slot), and each node's wide node where one stands for it (every root's; -1 for
  // the others). Kept by refit and by append when both trees have it (else dropped); the device's
  // searches use the binary tree alone.
  std::vector<trianglebvh::WideNode> wide;
  std::vector<trianglebvh::WideLeaf> wideLeaves;
  std::vector<std::array<int, trianglebvh::kWideChildren>> wideSource;
  std::vector<int> wideOf;

  // Throws InputError for a mesh without triangles.
  static TriangleBvh build(const TriangleMesh& mesh);
  // Room for appending `trees` (one allocation per array instead of a growth per append).
  void reserveFor(std::span<const TriangleBvh> trees);
  // Appends `other` (its indices shifted; its point indices by pointShift); returns its root. The
  // wide tree is appended too where both have one (or this one is empty), else dropped.
  int append(const TriangleBvh& other, Index pointShift = 0);
  // The wide tree over every root, unless it is there already.
  void requireWide();
  bool hasWide() const { return !wideOf.empty(); }
  // The same mesh moved to `points`: corners and boxes again (the wide tree's too), the tree kept.
  void refit(std::span<const Vec3> points, const Executor& executor);
  trianglebvh::View view() const { return {nodes.data(), corners.data()}; }
  trianglebvh::WideView wideView() const { return {wide.data(), wideLeaves.data(), corners.data()}; }
  int wideRoot(int root) const { return wideOf[std::size_t(root)]; }  // requireWide first
};

// Exact point-to-triangle-mesh distance.
class SurfaceDistanceQuery {
public:
  explicit SurfaceDistanceQuery(const TriangleMesh& mesh) : bvh_(TriangleBvh::build(mesh)) { bvh_.requireWide(); }
  float distance(const Vec3& p) const;
  Vec3 closestPoint(const Vec3& p) const;
  // The closest point, its distance and the mesh's triangle (point indices) it lies on.
  struct Closest {
    Vec3 point;
    float distance;
    std::array<Index, 3> triangle;
  };
  Closest closest(const Vec3& p) const;
  // The same among the triangles that face `direction`'s way (normal . direction >= 0) and lie
  // within `within` of p: across a thin part, the closest point of the whole surface can be its far
  // side. `distance` is infinite when no such triangle is that near.
  Closest closestFacing(const Vec3& p, const Vec3& direction, float within) const;
  const TriangleBvh& bvh() const { return bvh_; }

private:
  TriangleBvh bvh_;
};

struct SurfaceSample {
  Vec3 point;
  float area;  // area this sample stands for
};

// Deterministic samples: every triangle split into n^2 sub-triangles with n chosen so that
// sub-triangle edges are at most `spacing` long; one sample per sub-triangle centroid.
std::vector<SurfaceSample> sampleSurface(const TriangleMesh& mesh, float spacing);

struct SurfaceDistanceStats {
  double assd = 0.0;     // area-weighted mean of both directed distances
  double hd95 = 0.0;     // 95th percentile of the pooled distances
  double meanAtoB = 0.0;
  double meanBtoA = 0.0;
};

SurfaceDistanceStats surfaceDistance(const TriangleMesh& a, const TriangleMesh& b, float spacing,
                                     const Executor& executor = Executor());

// The smallest distance d such that the distances up to d carry at least `target` of the area: what
// accumulating the areas in ascending order finds, in linear time (the elements are reordered).
// `all` must not be empty.
float weightedQuantile(std::span<WeightedDistance> all, double target);

// A fixed surface (e.g. a ground truth) compared with many others: its query structure and
// samples are built once.
class ReferenceSurface {
public:
  ReferenceSurface(TriangleMesh surface, float spacing);
  SurfaceDistanceStats compare(const TriangleMesh& other, const Executor& executor = Executor()) const;
  const TriangleMesh& surface() const { return surface_; }
  const SurfaceDistanceQuery& query() const { return query_; }
  float spacing() const { return spacing_; }
  const std::vector<SurfaceSample>& samples() const { return samples_; }  // this surface's, at spacing()
  // compare()'s summary of distances computed elsewhere (a device), in compare()'s order: first
  // from sampleSurface(other, spacing()) to this surface (toThis of them), then from samples() to
  // the other.
  static SurfaceDistanceStats summarise(std::vector<WeightedDistance> distances, std::size_t toThis);

private:
  TriangleMesh surface_;
  float spacing_;
  SurfaceDistanceQuery query_;
  std::vector<SurfaceSample> samples_;
};

}  // namespace sinew
