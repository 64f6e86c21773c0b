#include "sinew/core/model_builder.h"

#include "sinew/core/executor.h"
#include "sinew/core/self_intersection.h"
#include "sinew/core/simplex_geometry.h"
#include "sinew/core/surface_distance.h"

#include <algorithm>
#include <cmath>

namespace sinew {

namespace {
void relax(const SimplexTopology& t, std::vector<Vec3>& x, const TriangleMesh& mesh, const SurfaceDistanceQuery& surface,
           int iterations, const Executor& executor) {
  std::vector<Vec3> next(x.size());
  for (int it = 0; it < iterations; ++it) {
    // Tangential smoothing only, then back onto the surface: moving along the normal could carry
    // a vertex across a thin part of the structure and fold the mesh. For the same reason, where
    // the closest point of the surface lies on a triangle turned against the vertex's normal (more
    // than 120 degrees: the far side of a thin fold, not a step of the label's staircase), the
    // point is the closest among the triangles facing the vertex's way, if one is within a spacing
    // of it (farther, it can lie on another part of the surface). The finer levels of thin, folded
    // regions crossed themselves on up to 2.2 % of their triangles (docs/accuracy.md).
    executor.forEach(t.vertexCount(), [&](Index v) {
      const auto& n = t.neighbours[v];
      const NeighbourFrame f = neighbourFrame(x[n[0]], x[n[1]], x[n[2]]);
      const Vec3 delta = (x[n[0]] + x[n[1]] + x[n[2]]) / 3.0f - x[v];
      const Vec3 moved = x[v] + 0.5f * (delta - delta.dot(f.normal) * f.normal);
      const SurfaceDistanceQuery::Closest all = surface.closest(moved);
      next[v] = all.point;
      if (!f.valid()) return;
      const Vec3 &a = mesh.points[all.triangle[0]], &b = mesh.points[all.triangle[1]], &c = mesh.points[all.triangle[2]];
      const Vec3 normal = (b - a).cross(c - a);
      if (!(normal.dot(f.normal) < -0.5f * normal.norm())) return;
      const float spacing = ((x[n[0]] - x[v]).norm() + (x[n[1]] - x[v]).norm() + (x[n[2]] - x[v]).norm()) / 3.0f;
      const SurfaceDistanceQuery::Closest facing = surface.closestFacing(moved, f.normal, all.distance + spacing);
      if (std::isfinite(facing.distance)) next[v] = facing.point;
    });
    x.swap(next);
  }
}

// Relaxing puts every vertex on the label surface, and where a fold is thinner than the spacing a
// triangle between two of them can still cut through the fold's other side: the finest levels of
// 58 of the 116 AAL regions crossed themselves (up to 63 triangles), and the shape prior carried
// the crossings into the results (docs/accuracy.md). So the vertices of crossing triangles and
// their neighbours are smoothed toward their neighbours' centroid, off the surface, until nothing
// crosses; the set grows by a ring each round in which something still does.
void untangle(const SimplexTopology& t, std::vector<Vec3>& x) {
  constexpr int kRounds = 12, kSmoothingSteps = 2;
  std::vector<char> moving(x.size(), 0);
  std::vector<Vec3> next;
  for (int round = 0; round < kRounds; ++round) {
    const std::vector<Index> crossing = crossingVertices(t, x);
    if (crossing.empty()) return;
    std::vector<char> grown = moving;
    for (Index v : crossing) grown[std::size_t(v)] = 1;
    for (Index v = 0; v < t.vertexCount(); ++v)
      if (moving[std::size_t(v)])
        for (Index n : t.neighbours[v]) grown[std::size_t(n)] = 1;
    for (Index v : crossing)
      for (Index n : t.neighbours[v]) grown[std::size_t(n)] = 1;
    moving.swap(grown);
    for (int step = 0; step < kSmoothingSteps; ++step) {
      next = x;
      for (Index v = 0; v < t.vertexCount(); ++v) {
        if (!moving[std::size_t(v)]) continue;
        const auto& n = t.neighbours[v];
        next[v] = 0.5f * x[v] + (x[n[0]] + x[n[1]] + x[n[2]]) / 6.0f;
      }
      x.swap(next);
    }
  }
}

}  // namespace

BuiltModel buildModel(const TriangleMesh& coarse, const TriangleMesh& surface, int levelCount,
                      const Executor& executor, int relaxIterations) {
  BuiltModel m;
  const SimplexMesh dual = SimplexMesh::dualOf(coarse);
  m.levels = LevelHierarchy::build(dual.topology, levelCount);
  const SurfaceDistanceQuery query(surface);
  std::vector<Vec3> x = dual.positions;
  for (int l = 0; l < levelCount; ++l) {
    if (l > 0) x = m.levels.prolongations[l - 1].apply(x);
    relax(m.levels.levels[l], x, surface, query, relaxIterations, executor);
    untangle(m.levels.levels[l], x);
    m.positions.push_back(x);
  }
  return m;
}

BuiltModel buildModelFromLabel(const Registry& registry, const LabelVolume& labels, const std::filesystem::path& file,
                               int label, const std::string& name, double coarseSpacingMm, int levelCount,
                               const Executor& executor, const LabelExtent* extent) {
  TriangleMesh coarse, surface;
  const auto& builder = registry.labelSurfaceBuilder();
  try {
    surface = builder.labelSurface(labels, label, {20, 0, extent});
    coarse = builder.labelSurface(labels, label, {20, trianglesForSpacing(surface, coarseSpacingMm), extent});
    validateClosedManifold(coarse);
    // Decimation leaves vertices of valence 8-12, cells of as many vertices that sag between their
    // neighbours (triangle_mesh.h); on 93 scenes of 12 sets, 0.0035 mm less ASSD (docs/collisions.md).
    lowerHighValences(coarse);
  } catch (const InputError& e) {
    throw InputError(file.string() + ": structure '" + name + "': " + e.what());
  }
  BuiltModel built = buildModel(coarse, surface, levelCount, executor);
  // The label's voxels against what the surface (its largest connected part) encloses.
  const double voxels = extent ? double(extent->count)
                               : double(std::count(labels.voxels().begin(), labels.voxels().end(), label));
  const double labelVolume = voxels * std::abs(labels.geometry().indexToWorldMatrix().determinant());
  if (labelVolume > 0.0) built.labelShareEnclosed = std::abs(surface.volume()) / labelVolume;
  return built;
}

std::string BuiltModel::partNote(const std::string& name, int label, const std::string& side) const {
  if (!(labelShareEnclosed < kWholeLabel)) return {};
  const std::string what = side.empty() ? "the label" : "the side";
  return "structure '" + name + "': " + (side.empty() ? "" : "the " + side + " side of ") + "label " + std::to_string(label) +
         " is in parts apart from each other; its model is the largest, " +
         std::to_string(int(std::lround(100.0 * labelShareEnclosed))) + " % of " + what + "'s volume, while a ground truth of " +
         what + " is all of it" +
         (side.empty() ? " (where its parts lie on both sides, --split-parts of sinew-make-scene or sinew-build-model makes "
                         "each side a structure of its own)"
                       : "");
}

BuiltModel buildModelFromMesh(const TriangleMesh& mesh, const std::filesystem::path& file, int levelCount,
                              const Executor& executor) {
  try {
    validateClosedManifold(mesh);
  } catch (const InputError& e) {
    throw InputError(file.string() + ": " + e.what());
  }
  return buildModel(mesh, mesh, levelCount, executor);
}

int trianglesForSpacing(const TriangleMesh& surface, double spacingMm) {
  // One simplex vertex per dual triangle, at its centroid. Centroids of equilateral triangles of
  // side a are a / sqrt(3) apart, so spacing s needs triangles of side s sqrt(3), area 3 sqrt(3)/4 s^2.
  const double perTriangle = 3.0 * std::sqrt(3.0) / 4.0 * spacingMm * spacingMm;
  return std::max(20, static_cast<int>(std::lround(surface.area() / perTriangle)));
}

}  // namespace sinew
