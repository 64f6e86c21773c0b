// What the views draw, read from the mesh store: each structure's surface (paper 000 Fig. 1b
// tessellation: the vertices, then the cell centres) and its contour on a slice plane. The host
// functions here read the host store; the CUDA backend has device twins that write into OpenGL
// buffers directly (see docs/architecture.md, "Drawing from the store").
#pragma once

#include "sinew/core/mesh_store.h"

#include <array>
#include <span>
#include <vector>

namespace sinew {

struct ContourSegment {
  Vec3 a, b;
};

// The plane {x : normal . x = offset}, in world millimetres.
struct SlicePlane {
  Vec3 normal = Vec3::UnitZ();
  float offset = 0.0f;
};

// Triangles of the tessellation with local indices (vertices first, then cell centres). They only
// change with the level of detail.
std::vector<std::array<Index, 3>> surfaceTriangles(const MeshStore& store, Index mesh);
Index surfacePointCount(const MeshStore& store, Index mesh);
// The tessellation's points from the host store: out.size() == surfacePointCount(store, mesh).
void hostSurfacePoints(MeshStore& store, Index mesh, std::span<Vec3> out);
// Where the tessellation crosses the plane (a vertex exactly on it counts as above).
std::vector<ContourSegment> hostContour(MeshStore& store, Index mesh, const SlicePlane& plane);

}  // namespace sinew
