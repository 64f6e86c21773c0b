// 2-simplex meshes: every vertex has exactly three neighbours. Built as the topological dual of a
// closed, manifold, consistently oriented triangle mesh: triangle t becomes simplex vertex t and
// triangle-mesh vertex c becomes cell c.
#pragma once

#include "sinew/core/triangle_mesh.h"
#include "sinew/core/types.h"

#include <array>
#include <vector>

namespace sinew {

// Connectivity only; positions live in the mesh store (or in SimplexMesh for a single mesh).
//
// Ordering conventions, relied on by the geometry code:
// - dual triangle t = (a, b, c), counter-clockwise seen from outside;
// - neighbours[t] = {across edge ab, across edge bc, across edge ca}: counter-clockwise seen from
//   outside, so (N1 - N0) x (N2 - N0) points outward;
// - vertexCells[t] = {a, b, c}; the edge to neighbour j lies between cells j and (j + 1) % 3;
// - each cell lists its vertices counter-clockwise seen from outside.
struct SimplexTopology {
  std::vector<std::array<Index, 3>> neighbours;
  std::vector<std::array<Index, 3>> vertexCells;
  std::vector<Index> cellOffsets;  // size cellCount() + 1
  std::vector<Index> cellVertices;

  Index vertexCount() const { return static_cast<Index>(neighbours.size()); }
  Index cellCount() const { return static_cast<Index>(cellOffsets.size()) - 1; }
  Index edgeCount() const { return vertexCount() * 3 / 2; }
  int eulerCharacteristic() const { return vertexCount() - edgeCount() + cellCount(); }

  // Builds the dual of a triangle mesh; throws InputError (see validateClosedManifold).
  static SimplexTopology dualOf(const TriangleMesh& mesh);
  // The dual triangles back: (a, b, c) per simplex vertex (triangle-mesh vertices = cells).
  std::vector<std::array<Index, 3>> dualTriangles() const;
};

struct SimplexMesh {
  SimplexTopology topology;
  std::vector<Vec3> positions;

  // Dual of a triangle mesh; each simplex vertex is placed at its triangle's centroid.
  static SimplexMesh dualOf(const TriangleMesh& mesh);
  // Dual of an icosphere with every vertex pushed onto the sphere: 20 * 4^level vertices.
  static SimplexMesh sphere(int level, float radius = 1.0f, const Vec3& centre = Vec3::Zero());
  static SimplexMesh fromSphereTriangles(const TriangleMesh& sphereMesh, float radius,
                                         const Vec3& centre);
};

// Cell centres: the mean of each cell's vertices.
std::vector<Vec3> cellCentres(const SimplexTopology& topology, const std::vector<Vec3>& positions);

// Tessellation of paper 000 Fig. 1b: every vertex joined to the centres of its cells. Points are
// the simplex vertices followed by the cell centres; triangles are oriented outward.
TriangleMesh tessellate(const SimplexTopology& topology, const std::vector<Vec3>& positions);

// The dual triangle mesh back: cell centres as points, one triangle per simplex vertex.
TriangleMesh dualTriangleMesh(const SimplexTopology& topology, const std::vector<Vec3>& positions);

}  // namespace sinew
