#include "sinew/core/triangle_mesh.h"

#include <algorithm>
#include <map>
#include <sstream>
#include <unordered_map>

namespace sinew {

namespace {

std::uint64_t edgeKey(Index a, Index b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) |
         static_cast<std::uint32_t>(b);
}

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

void validateClosedManifold(const TriangleMesh& mesh) {
  const Index nPoints = static_cast<Index>(mesh.points.size());
  if (mesh.triangles.empty()) throw InputError("mesh has no triangles");
  // Directed edge -> triangle using it; detects inconsistent orientation and non-manifold edges.
  std::unordered_map<std::uint64_t, Index> directed;
  directed.reserve(mesh.triangles.size() * 3);
  std::vector<int> valence(nPoints, 0);
  for (Index t = 0; t < static_cast<Index>(mesh.triangles.size()); ++t) {
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      if (tri[k] < 0 || tri[k] >= nPoints) {
        std::ostringstream m;
        m << "triangle " << t << " refers to vertex " << tri[k] << " but the mesh has " << nPoints
          << " vertices";
        throw InputError(m.str());
      }
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) {
      std::ostringstream m;
      m << "triangle " << t << " is degenerate (repeats vertex)";
      throw InputError(m.str());
    }
    for (int k = 0; k < 3; ++k) {
      const Index a = tri[k], b = tri[(k + 1) % 3];
      ++valence[a];
      auto [it, inserted] = directed.emplace(edgeKey(a, b), t);
      if (!inserted) {
        std::ostringstream m;
        const bool reversePresent = directed.count(edgeKey(b, a)) > 0;
        m << "edge (" << a << ", " << b << ") is used in the same direction by triangles "
          << it->second << " and " << t
          << (reversePresent ? ": the edge is shared by more than two triangles (non-manifold)"
                             : ": the triangles are inconsistently oriented");
        throw InputError(m.str());
      }
    }
  }
  for (Index t = 0; t < static_cast<Index>(mesh.triangles.size()); ++t) {
    for (int k = 0; k < 3; ++k) {
      const Index a = mesh.triangles[t][k], b = mesh.triangles[t][(k + 1) % 3];
      if (!directed.count(edgeKey(b, a))) {
        std::ostringstream m;
        m << "edge (" << a << ", " << b << ") of triangle " << t
          << " has no opposite triangle: the mesh is open";
        throw InputError(m.str());
      }
    }
  }
  for (Index v = 0; v < nPoints; ++v) {
    if (valence[v] == 0) {
      std::ostringstream m;
      m << "vertex " << v << " is not used by any triangle";
      throw InputError(m.str());
    }
  }
  // Each vertex's triangles must form one fan: walk it and compare with the valence.
  for (Index t0 = 0; t0 < static_cast<Index>(mesh.triangles.size()); ++t0) {
    for (int k0 = 0; k0 < 3; ++k0) {
      const Index v = mesh.triangles[t0][k0];
      if (valence[v] < 0) continue;  // already walked
      int steps = 0;
      Index t = t0;
      int k = k0;
      do {
        // In (v, x, y) the next triangle around v holds the directed edge (v, y).
        const Index y = mesh.triangles[t][(k + 2) % 3];
        t = directed.at(edgeKey(v, y));
        k = static_cast<int>(std::find(mesh.triangles[t].begin(), mesh.triangles[t].end(), v) -
                             mesh.triangles[t].begin());
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
