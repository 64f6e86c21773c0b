#include "sinew/core/triangle_mesh.h"

#include "directed_edges.h"

#include <algorithm>
#include <map>
#include <sstream>

namespace sinew {

namespace {

TriangleMesh projectToSphere(TriangleMesh mesh, int level, float radius, const Vec3& centre) {
  for (int i = 0; i < level; ++i) mesh = subdivideMidpoint(mesh);
  for (Vec3& p : mesh.points) p = centre + radius * p.normalized();
  return mesh;
}

}  // namespace

double TriangleMesh::volume() const {
  double v = 0.0;
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = points[t[0]].cast<double>();
    const Eigen::Vector3d b = points[t[1]].cast<double>();
    const Eigen::Vector3d c = points[t[2]].cast<double>();
    v += a.dot(b.cross(c));
  }
  return v / 6.0;
}

double TriangleMesh::area() const {
  double s = 0.0;
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = points[t[0]].cast<double>();
    const Eigen::Vector3d b = points[t[1]].cast<double>();
    const Eigen::Vector3d c = points[t[2]].cast<double>();
    s += 0.5 * (b - a).cross(c - a).norm();
  }
  return s;
}

void validateClosedManifold(const TriangleMesh& mesh) { closedManifoldEdges(mesh); }

DirectedEdges closedManifoldEdges(const TriangleMesh& mesh) {
  const Index nPoints = static_cast<Index>(mesh.points.size());
  const Index nTri = static_cast<Index>(mesh.triangles.size());
  if (mesh.triangles.empty()) throw InputError("mesh has no triangles");
  // The problems are reported as a scan of the triangles in order meets them. The first triangle
  // with an index out of range or a repeated vertex ends that scan, so only the triangles before it
  // take part in the edge checks that would have come first.
  Index bad = nTri;
  for (Index t = 0; t < nTri && bad == nTri; ++t) {
    const auto& tri = mesh.triangles[t];
    for (Index v : tri)
      if (v < 0 || v >= nPoints) bad = t;
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) bad = t;
  }
  const DirectedEdges directed(mesh.triangles, bad, nPoints);
  // A directed edge used twice: the first second use in triangle order (triangle, then corner).
  Index dupFrom = -1, dupTo = -1, dupFirst = -1, dupT = -1;
  int dupCorner = 0;
  for (Index a = 0; a < nPoints; ++a) {
    const auto row = directed.from(a);
    for (size_t i = 1; i < row.size(); ++i) {
      if (row[i].to != row[i - 1].to || (i >= 2 && row[i - 2].to == row[i].to)) continue;
      if (dupT < 0 || row[i].triangle < dupT || (row[i].triangle == dupT && row[i].corner < dupCorner)) {
        dupFrom = a, dupTo = row[i].to, dupFirst = row[i - 1].triangle, dupT = row[i].triangle, dupCorner = row[i].corner;
      }
    }
  }
  if (dupT >= 0) {
    // Whether the reverse edge had been met by then: more than two triangles share the edge.
    bool reversePresent = false;
    for (const DirectedEdge& e : directed.from(dupTo))
      if (e.to == dupFrom && (e.triangle < dupT || (e.triangle == dupT && e.corner < dupCorner))) reversePresent = true;
    std::ostringstream m;
    m << "edge (" << dupFrom << ", " << dupTo << ") is used in the same direction by triangles " << dupFirst << " and "
      << dupT
      << (reversePresent ? ": the edge is shared by more than two triangles (non-manifold)"
                         : ": the triangles are inconsistently oriented");
    throw InputError(m.str());
  }
  if (bad < nTri) {
    const auto& tri = mesh.triangles[bad];
    for (Index v : tri)
      if (v < 0 || v >= nPoints) {
        std::ostringstream m;
        m << "triangle " << bad << " refers to vertex " << v << " but the mesh has " << nPoints << " vertices";
        throw InputError(m.str());
      }
    std::ostringstream m;
    m << "triangle " << bad << " is degenerate (repeats vertex)";
    throw InputError(m.str());
  }
  for (Index t = 0; t < nTri; ++t) {
    for (int k = 0; k < 3; ++k) {
      const Index a = mesh.triangles[t][k], b = mesh.triangles[t][(k + 1) % 3];
      if (directed.find(b, a) < 0) {
        std::ostringstream m;
        m << "edge (" << a << ", " << b << ") of triangle " << t
          << " has no opposite triangle: the mesh is open";
        throw InputError(m.str());
      }
    }
  }
  std::vector<Index> valence(nPoints);
  for (Index v = 0; v < nPoints; ++v) {
    valence[v] = directed.outgoing(v);
    if (valence[v] == 0) {
      std::ostringstream m;
      m << "vertex " << v << " is not used by any triangle";
      throw InputError(m.str());
    }
  }
  // Each vertex's triangles must form one fan: walk it and compare with the valence.
  for (Index t0 = 0; t0 < nTri; ++t0) {
    for (int k0 = 0; k0 < 3; ++k0) {
      const Index v = mesh.triangles[t0][k0];
      if (valence[v] < 0) continue;  // already walked
      int steps = 0;
      Index t = t0;
      do {
        // In (v, x, y) the next triangle around v holds the directed edge (v, y).
        const auto& tri = mesh.triangles[t];
        const int k = static_cast<int>(std::find(tri.begin(), tri.end(), v) - tri.begin());
        t = directed.find(v, tri[(k + 2) % 3]);
        ++steps;
      } while (t != t0 && steps <= valence[v]);
      if (steps != valence[v]) {
        std::ostringstream m;
        m << "vertex " << v << " is non-manifold: its " << valence[v]
          << " triangles form more than one fan";
        throw InputError(m.str());
      }
      valence[v] = -1;
    }
  }
  return directed;
}

TriangleMesh subdivideMidpoint(const TriangleMesh& mesh) {
  TriangleMesh out;
  out.points = mesh.points;
  std::map<std::pair<Index, Index>, Index> midpoints;
  auto midpoint = [&](Index a, Index b) {
    const auto key = std::minmax(a, b);
    auto it = midpoints.find(key);
    if (it != midpoints.end()) return it->second;
    const Index idx = static_cast<Index>(out.points.size());
    out.points.push_back(0.5f * (mesh.points[a] + mesh.points[b]));
    midpoints.emplace(key, idx);
    return idx;
  };
  out.triangles.reserve(mesh.triangles.size() * 4);
  for (const auto& t : mesh.triangles) {
    const Index ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
    out.triangles.push_back({t[0], ab, ca});
    out.triangles.push_back({t[1], bc, ab});
    out.triangles.push_back({t[2], ca, bc});
    out.triangles.push_back({ab, bc, ca});
  }
  return out;
}

TriangleMesh icosphere(int level, float radius, const Vec3& centre) {
  const float p = (1.0f + std::sqrt(5.0f)) / 2.0f;
  TriangleMesh m;
  m.points = {{-1, p, 0}, {1, p, 0}, {-1, -p, 0}, {1, -p, 0}, {0, -1, p}, {0, 1, p},
              {0, -1, -p}, {0, 1, -p}, {p, 0, -1}, {p, 0, 1}, {-p, 0, -1}, {-p, 0, 1}};
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  return projectToSphere(std::move(m), level, radius, centre);
}

TriangleMesh octasphere(int level, float radius, const Vec3& centre) {
  TriangleMesh m;
  m.points = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return projectToSphere(std::move(m), level, radius, centre);
}

TriangleMesh tetrasphere(int level, float radius, const Vec3& centre) {
  TriangleMesh m;
  m.points = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  m.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};
  return projectToSphere(std::move(m), level, radius, centre);
}

}  // namespace sinew
