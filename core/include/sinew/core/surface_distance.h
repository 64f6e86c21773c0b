// Distances between surfaces, for evaluation: average symmetric surface distance (ASSD) and the
// 95th percentile Hausdorff distance, point-to-surface both ways over area-weighted samples.
#pragma once

#include "sinew/core/executor.h"
#include "sinew/core/triangle_mesh.h"

#include <memory>

namespace sinew {

// Exact point-to-triangle-mesh distance with an axis-aligned bounding-box tree.
class SurfaceDistanceQuery {
public:
  explicit SurfaceDistanceQuery(const TriangleMesh& mesh);
  ~SurfaceDistanceQuery();
  SurfaceDistanceQuery(SurfaceDistanceQuery&&) noexcept;
  float distance(const Vec3& p) const;
  Vec3 closestPoint(const Vec3& p) const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
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

// A fixed surface (e.g. a ground truth) compared with many others: its query structure and
// samples are built once.
class ReferenceSurface {
public:
  ReferenceSurface(TriangleMesh surface, float spacing);
  SurfaceDistanceStats compare(const TriangleMesh& other, const Executor& executor = Executor()) const;
  const TriangleMesh& surface() const { return surface_; }

private:
  TriangleMesh surface_;
  float spacing_;
  SurfaceDistanceQuery query_;
  std::vector<SurfaceSample> samples_;
};

}  // namespace sinew
