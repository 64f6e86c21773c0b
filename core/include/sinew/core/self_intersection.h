// Self-intersections of one structure's surface, for the shape guard (shape_guard.h): the surface
// is the Fig. 1b tessellation (each cell fanned around its centroid, as the volume and the written
// meshes use), and a sample of its triangles is tested against every triangle of the structure
// that shares no vertex and no cell with it. The samples are binned on a uniform grid over their
// bounding box, and one parallel pass over the structure's cells tests each cell's fan against the
// samples in the bins its box meets: linear in the cell count, with no grid of every cell built.
#pragma once

#include "sinew/core/mesh_store.h"
#include "sinew/core/simplex_mesh.h"

#include <span>
#include <vector>

namespace sinew {

struct SelfIntersectionSample {
  Index sampled = 0;       // triangles tested
  Index intersecting = 0;  // of them, those that cross a triangle they are not joined to
  double fraction() const { return sampled ? double(intersecting) / double(sampled) : 0.0; }
};

// At most maxSamples triangles, evenly spread over the structure's (deterministic).
SelfIntersectionSample sampleSelfIntersections(const MeshStore& store, std::span<const Vec3> positions, Index mesh,
                                               Index maxSamples = 512);

// Every triangle of the tessellation tested: the simplex vertices of those that cross a triangle
// they are not joined to (a fan triangle's two simplex vertices), sorted, each once. For model
// building, where there is one mesh and no store.
std::vector<Index> crossingVertices(const SimplexTopology& topology, std::span<const Vec3> positions);

// Whether two triangles cross (an edge of one passes through the other); coplanar overlaps are
// not counted.
bool trianglesIntersect(const Eigen::Vector3d a[3], const Eigen::Vector3d b[3]);

}  // namespace sinew
