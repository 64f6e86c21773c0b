#include "sinew/core/triangle_mesh.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace sinew {

namespace {

using Edge = std::pair<Index, Index>;  // (smaller, larger)

Edge undirected(Index a, Index b) { return a < b ? Edge{a, b} : Edge{b, a}; }

Vec3 normalOf(const TriangleMesh& m, Index a, Index b, Index c) {
  return (m.points[b] - m.points[a]).cross(m.points[c] - m.points[a]);
}

// Whether p and q are within the angle whose cosine is cosLimit (false when either is zero).
bool within(const Vec3& p, const Vec3& q, float cosLimit) {
  const float norms = p.norm() * q.norm();
  return norms > 0.0f && p.dot(q) >= cosLimit * norms;
}

int deviation(int valence) { return (valence - 6) * (valence - 6); }

}  // namespace

int lowerHighValences(TriangleMesh& mesh, int highValence, int minValence, float maxFoldDegrees, int maxPasses) {
  const float cosLimit = std::cos(maxFoldDegrees * 3.14159265f / 180.0f);
  std::vector<int> valence(mesh.points.size(), 0);
  // Each undirected edge's two triangles; the first holds it as (smaller, larger).
  std::map<Edge, std::array<Index, 2>> sides;
  for (Index t = 0; t < Index(mesh.triangles.size()); ++t)
    for (int k = 0; k < 3; ++k) {
      const Index a = mesh.triangles[t][k], b = mesh.triangles[t][(k + 1) % 3];
      if (a < b) ++valence[a], ++valence[b];
      sides[undirected(a, b)][a < b ? 0 : 1] = t;
    }
  const auto opposite = [&](Index t, Index a, Index b) {
    for (Index v : mesh.triangles[t])
      if (v != a && v != b) return v;
    return Index(-1);
  };
  const auto moveSide = [&](Index a, Index b, Index from, Index to) {
    auto& s = sides.at(undirected(a, b));
    (s[0] == from ? s[0] : s[1]) = to;
  };
  int flips = 0;
  for (int pass = 0; pass < maxPasses; ++pass) {
    const int flipsBefore = flips;
    for (Index t = 0; t < Index(mesh.triangles.size()); ++t)
      for (int k = 0; k < 3; ++k) {
        const Index a = mesh.triangles[t][k], b = mesh.triangles[t][(k + 1) % 3];
        if (a > b) continue;  // each edge once: from the triangle holding it as (smaller, larger)
        if (std::max(valence[a], valence[b]) < highValence) continue;
        const auto [t0, t1] = sides.at({a, b});  // (a, b, c) and (b, a, d), each in its own order
        const Index c = opposite(t0, a, b), d = opposite(t1, a, b);
        if (c == d || sides.count(undirected(c, d))) continue;
        if (std::min(valence[a], valence[b]) - 1 < minValence || std::max(valence[c], valence[d]) + 1 >= highValence)
          continue;
        const int before = deviation(valence[a]) + deviation(valence[b]) + deviation(valence[c]) + deviation(valence[d]);
        const int after = deviation(valence[a] - 1) + deviation(valence[b] - 1) + deviation(valence[c] + 1) +
                          deviation(valence[d] + 1);
        if (after >= before) continue;
        // Only where the two triangles are nearly coplanar, and the two new ones too: across a
        // crease a flip would cut the corner off the shape (or fold it).
        const Vec3 n0 = normalOf(mesh, a, b, c), n1 = normalOf(mesh, b, a, d);
        const Vec3 m0 = normalOf(mesh, a, d, c), m1 = normalOf(mesh, d, b, c);
        if (!within(n0, n1, cosLimit) || !within(m0, m1, cosLimit) || !within(m0, n0 + n1, cosLimit) ||
            !within(m1, n0 + n1, cosLimit))
          continue;
        // The quad a -> d -> b -> c: t0 becomes (a, d, c) and t1 (d, b, c), both oriented as before.
        mesh.triangles[t0] = {a, d, c};
        mesh.triangles[t1] = {d, b, c};
        sides.erase({a, b});
        moveSide(b, c, t0, t1);
        moveSide(a, d, t1, t0);
        sides[undirected(c, d)] = d < c ? std::array<Index, 2>{t0, t1} : std::array<Index, 2>{t1, t0};
        --valence[a], --valence[b], ++valence[c], ++valence[d];
        ++flips;
        break;  // triangle t has changed; its other edges wait for the next pass
      }
    if (flips == flipsBefore) break;
  }
  return flips;
}

}  // namespace sinew
