// The error against the ground truth while a run goes on (every report sample but the first and
// the last, which SceneRunner takes from the exact evaluation of the start and the end): ASSD and
// HD95 per structure at a small fraction of the cost of the exact evaluation (surface_distance.h),
// which stays for the final result and is this method's test oracle.
//
// The distances are exact; there are fewer of them, and no hierarchy is built per sample:
// - mesh to truth: samples of each triangle of the Fig. 1b tessellation (the output surface) into
//   the truth's hierarchy (the exact evaluation's, triangle_bvh.h): at coarse levels four, the
//   centroids of its midpoint split; where the level's triangles' longest edges are on average no
//   longer than 1.25 times the truth's sampling spacing, one, the centroid (a quarter of the queries
//   at the fine levels, where the meshes have the most triangles). On the host each search starts
//   bounded by the distance to the truth triangle that was nearest to the same sample last time
//   (the meshes move little between samples), which prunes most of the walk and changes no
//   distance;
// - truth to mesh: the truth sampled at a coarser spacing than the exact evaluation's (sampleSurface),
//   the samples grouped into patches (cubes of kPatchMm, per structure); one search per patch, from
//   its centre into a hierarchy of the tessellation (built once per level, a tree per structure,
//   refitted at each sample), gives the tessellation's tangent plane there (starting, like the
//   other direction, bounded by the distance to last time's nearest triangle), and each of the
//   patch's samples is its distance to that plane (trianglebvh::planeDistance). The tessellation is
//   smooth at this scale, unlike the truth (a label surface), so this direction is the one that can
//   be approximated: on the demo the searches drop from 77,452 to 14,869 while the largest
//   difference to the exact ASSD rises from 0.0073 to 0.0087 mm (HD95 unchanged, 0.041 mm); the
//   other direction stays exact. At the levels of one sample a triangle the plane carries the
//   tessellation's curvature, fitted to the neighbouring patches' planes (applyCurvature): the
//   plane alone left HD95 0.002-0.013 mm low on average there;
// - HD95 from a histogram of 0.005 mm bins instead of a sort. Near it (kSpreadBracketMm) a mesh
//   sample of a triangle with four is not a point: the distance is taken as linear over its
//   sub-triangle, with the slope of the plane fitted to the triangle's four (least squares) and the
//   sample's own value at its centroid, and its area spread over the values that takes
//   (DistanceSpread). As points, the few samples where HD95 lies made it low at the coarsest level,
//   where the exact evaluation takes 36-64 samples a triangle: on tst_sampled_error's scene it
//   missed by up to 0.050 mm at that level; spread, 0.016 (docs/benchmarks.md, "Four samples a
//   triangle, spread").
// On the host the searches walk the trees' wide form (triangle_bvh_wide.h: the same distances). The
// CUDA backend runs the binary trees' inline queries in its kernels (ExecutionBackend::measureError).
#pragma once

#include "sinew/core/mesh_store.h"
#include "sinew/core/surface_distance.h"

#include <optional>
#include <vector>

namespace sinew {

class SampledError {
public:
  static constexpr float kBinMm = 0.005f;  // the histogram HD95 is read from
  static constexpr float kPatchMm = 1.5f;  // the edge of the cubes that group the truth's samples
  static constexpr float kSpreadBracketMm = 0.3f;  // samples spread where they reach this near HD95
  static constexpr float kCurvatureReachMm = 2.6f;  // the patches a patch's curvature is fitted to

  // One truth per structure, null where a structure has none; their hierarchies are copied, their
  // surfaces sampled at `spacing`.
  SampledError(const std::vector<const ReferenceSurface*>& truths, float spacing);

  // ASSD and HD95 of every structure with a truth, for the store's current positions.
  std::vector<std::optional<SurfaceDistanceStats>> measure(MeshStore& store);

  // For a backend measuring on its device: prepare() builds the tessellations' hierarchy, all
  // structures' in one (meshes()), when the store's topology changed (true then, and when measure()
  // had built the level's trees without it); the backend refits it, fills the samples in the layout
  // below and hands them to summarise().
  bool prepare(MeshStore& store);
  // At the levels of one sample a triangle, each truth sample's distance again from its patch's
  // tangent plane with the tessellation's curvature there (fitCurvature, fitted to the patches
  // within kCurvatureReachMm; curvedDistance): planes per patch, fromTruth as for summarise().
  void applyCurvature(std::span<const trianglebvh::TangentPlane> planes, std::span<WeightedDistance> fromTruth,
                      const Executor& executor) const;
  // Mesh to truth: samplesPerTriangle() per tessellation triangle (meshes().triangles order);
  // truth to mesh: one per truth sample (truthSamples() order). Structure by structure on `executor`.
  std::vector<std::optional<SurfaceDistanceStats>> summarise(std::span<const WeightedDistance> toTruth,
                                                             std::span<const WeightedDistance> fromTruth,
                                                             const Executor& executor) const;

  const TriangleBvh& truth() const { return truth_; }
  const std::vector<int>& truthRoots() const { return truthRoots_; }  // -1: no truth
  const std::vector<SurfaceSample>& truthSamples() const { return samples_; }
  const std::vector<Index>& truthSampleOffsets() const { return sampleOffsets_; }  // per structure, and the end
  // The patches: their centres (their samples' area-weighted mean), structures, and each truth
  // sample's patch.
  const std::vector<collision::P3>& patchCentres() const { return patchCentres_; }
  const std::vector<int>& patchStructure() const { return patchStructure_; }
  const std::vector<int>& samplePatch() const { return samplePatch_; }
  // The tessellations (after prepare()); their points are the store's vertices, then its cell centres.
  const TriangleBvh& meshes() const { return meshes_; }
  const std::vector<int>& meshRoots() const { return meshRoots_; }
  const std::vector<Index>& meshTriangleOffsets() const { return meshTriangleOffsets_; }  // per structure, and the end
  const std::vector<int>& meshTriangleStructure() const { return triangleStructure_; }  // per tessellation triangle
  int samplesPerTriangle() const { return perTriangle_; }  // 1 or kSubTriangles, for the current level

private:
  // Every structure's tessellation tree, when the store's topology changed (true then); wide: with
  // the host's search trees (TriangleBvh::requireWide), made now if the trees were there without.
  bool buildTrees(MeshStore& store, bool wide);
  void groupIntoPatches(const std::vector<SurfaceSample>& samples, int structure);

  TriangleBvh truth_;
  std::vector<int> truthRoots_;
  std::vector<SurfaceSample> samples_;
  std::vector<Index> sampleOffsets_;
  std::vector<TriangleBvh> meshTrees_;  // per structure (the host's searches)
  TriangleBvh meshes_;                  // all of them in one (the device's), made by prepare()
  std::vector<int> meshRoots_;
  std::vector<Index> meshTriangleOffsets_;
  Index builtFor_ = -1;     // the vertex count (the level) the tessellations were built for
  Index combinedFor_ = -1;  // and meshes_
  float spacing_;
  int perTriangle_ = kSubTriangles;
  std::vector<Vec3> points_;
  std::vector<WeightedDistance> toTruth_, fromTruth_;
  std::vector<collision::P3> patchCentres_;
  std::vector<int> patchStructure_, samplePatch_;
  std::vector<trianglebvh::TangentPlane> planes_;  // per patch, at the last measure()
  std::vector<int> triangleStructure_;  // the structure of each tessellation triangle
  // Per mesh-to-truth sample, the truth triangle nearest to it at the last measure() (-1: none yet):
  // the next search starts bounded by the distance to it (exact: that triangle is one of the truth's).
  std::vector<int> truthHint_;
  std::vector<int> planeHint_;  // per patch, the tessellation triangle nearest to its centre last time
  // Per patch, the same structure's patches whose centres are within kCurvatureReachMm: entries
  // neighbourOffsets_[k] to [k + 1] of neighbours_.
  std::vector<int> neighbourOffsets_, neighbours_;
};

// A patch's tangent plane with the tessellation's curvature there: its nearest point q, normal n
// (towards the patch), tangent axes e1, e2 and the shape operator [s11 s12; s12 s22] in them.
struct CurvedPlane {
  Vec3 q, n, e1, e2;
  float s11 = 0, s12 = 0, s22 = 0;
};
// Patch k's: its plane, and the operator fitted by least squares to its neighbours' normals
// (turned to agree with its own), n_j - n = S (q_j - q) along the plane; flat with fewer than two.
CurvedPlane fitCurvature(std::span<const trianglebvh::TangentPlane> planes, std::span<const collision::P3> centres, int k,
                         std::span<const int> neighbours);
// The distance from s to the surface so curved, to second order: |z + u^T S u / 2|, z the height of
// s above the plane and u its offset along it (the plane alone: |z|).
float curvedDistance(const CurvedPlane& plane, const Vec3& s);

// A sample's distance over the area it stands for, taken as linear there: its values at that
// area's three corners, ascending (a point: all three the sample's distance).
struct DistanceSpread {
  float low, middle, high;
};

// Both directions summarised as the exact evaluation does: ASSD the area-weighted mean of both;
// HD95 the 95th percentile of both by area, read from a histogram of `binMm` bins (its bin's upper
// edge). toTruthSpread (none, or one per toTruth sample): the samples whose spread reaches within
// `bracketMm` of the points' HD95 have their area spread over it in the histogram, and HD95 is
// read again.
SurfaceDistanceStats summariseBinned(std::span<const WeightedDistance> toTruth, std::span<const WeightedDistance> fromTruth,
                                     float binMm, std::span<const DistanceSpread> toTruthSpread = {},
                                     float bracketMm = SampledError::kSpreadBracketMm);

}  // namespace sinew
