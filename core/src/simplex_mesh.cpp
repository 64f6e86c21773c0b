#include "sinew/core/simplex_mesh.h"

#include "directed_edges.h"

#include <algorithm>

namespace sinew {

SimplexTopology SimplexTopology::dualOf(const TriangleMesh& mesh) {
  const DirectedEdges directed = closedManifoldEdges(mesh);
  const Index nTri = static_cast<Index>(mesh.triangles.size());
  const Index nPoints = static_cast<Index>(mesh.points.size());

  SimplexTopology topo;
  topo.neighbours.resize(nTri);
  topo.vertexCells.resize(nTri);
  for (Index t = 0; t < nTri; ++t) {
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      // The triangle across edge (tri[k], tri[k+1]) holds it reversed.
      topo.neighbours[t][k] = directed.find(tri[(k + 1) % 3], tri[k]);
      topo.vertexCells[t][k] = tri[k];
    }
  }

  // Cells: the fan of triangles around each triangle-mesh vertex, counter-clockwise from outside.
  std::vector<Index> firstTriangle(nPoints, -1);
  std::vector<Index> valence(nPoints, 0);
  for (Index t = 0; t < nTri; ++t)
    for (Index v : mesh.triangles[t]) {
      if (firstTriangle[v] < 0) firstTriangle[v] = t;
      ++valence[v];
    }
  topo.cellOffsets.resize(nPoints + 1);
  topo.cellOffsets[0] = 0;
  for (Index v = 0; v < nPoints; ++v) topo.cellOffsets[v + 1] = topo.cellOffsets[v] + valence[v];
  topo.cellVertices.resize(topo.cellOffsets[nPoints]);
  for (Index v = 0; v < nPoints; ++v) {
    Index t = firstTriangle[v];
    for (Index i = topo.cellOffsets[v]; i < topo.cellOffsets[v + 1]; ++i) {
      topo.cellVertices[i] = t;
      const auto& tri = mesh.triangles[t];
      const int k = static_cast<int>(std::find(tri.begin(), tri.end(), v) - tri.begin());
      // In (v, x, y) the next triangle counter-clockwise around v holds the directed edge (v, y).
      t = directed.find(v, tri[(k + 2) % 3]);
    }
  }
  return topo;
}

std::vector<std::array<Index, 3>> SimplexTopology::dualTriangles() const { return vertexCells; }

SimplexMesh SimplexMesh::dualOf(const TriangleMesh& mesh) {
  SimplexMesh out;
  out.topology = SimplexTopology::dualOf(mesh);
  out.positions.resize(mesh.triangles.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    out.positions[t] = (mesh.points[tri[0]] + mesh.points[tri[1]] + mesh.points[tri[2]]) / 3.0f;
  }
  return out;
}

SimplexMesh SimplexMesh::fromSphereTriangles(const TriangleMesh& sphereMesh, float radius,
                                             const Vec3& centre) {
  SimplexMesh out = dualOf(sphereMesh);
  for (Vec3& p : out.positions) p = centre + radius * (p - centre).normalized();
  return out;
}

SimplexMesh SimplexMesh::sphere(int level, float radius, const Vec3& centre) {
  return fromSphereTriangles(icosphere(level, radius, centre), radius, centre);
}

std::vector<Vec3> cellCentres(const SimplexTopology& topology, const std::vector<Vec3>& positions) {
  std::vector<Vec3> centres(topology.cellCount());
  for (Index c = 0; c < topology.cellCount(); ++c) {
    Vec3 sum = Vec3::Zero();
    for (Index i = topology.cellOffsets[c]; i < topology.cellOffsets[c + 1]; ++i)
      sum += positions[topology.cellVertices[i]];
    centres[c] = sum / static_cast<float>(topology.cellOffsets[c + 1] - topology.cellOffsets[c]);
  }
  return centres;
}

TriangleMesh tessellate(const SimplexTopology& topology, const std::vector<Vec3>& positions) {
  TriangleMesh out;
  out.points = positions;
  const std::vector<Vec3> centres = cellCentres(topology, positions);
  out.points.insert(out.points.end(), centres.begin(), centres.end());
  out.triangles.reserve(topology.cellVertices.size());
  const Index base = topology.vertexCount();
  for (Index c = 0; c < topology.cellCount(); ++c) {
    const Index begin = topology.cellOffsets[c], end = topology.cellOffsets[c + 1];
    for (Index i = begin; i < end; ++i) {
      const Index next = (i + 1 == end) ? begin : i + 1;
      out.triangles.push_back({topology.cellVertices[i], topology.cellVertices[next], base + c});
    }
  }
  return out;
}

TriangleMesh dualTriangleMesh(const SimplexTopology& topology, const std::vector<Vec3>& positions) {
  TriangleMesh out;
  out.points = cellCentres(topology, positions);
  out.triangles = topology.dualTriangles();
  return out;
}

}  // namespace sinew
