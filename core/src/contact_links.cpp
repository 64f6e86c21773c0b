#include "sinew/core/contact_links.h"

#include <Eigen/Geometry>

#include <cmath>
#include <limits>
#include <unordered_map>

namespace sinew {

namespace {
// A uniform grid of one structure's reference vertices, cells the link distance wide, so that a
// query looks at 27 cells.
class VertexGrid {
public:
  VertexGrid(std::span<const Vec3> x, Index begin, Index end, float cell) : x_(x), cell_(cell) {
    for (Index v = begin; v < end; ++v) cells_[key(cellOf(x[v]))].push_back(v);
  }
  // The nearest vertex within `limit` and its squared distance, or -1.
  std::pair<Index, float> nearest(const Vec3& p, float limit) const {
    const std::array<long, 3> c = cellOf(p);
    Index best = -1;
    float bestD2 = limit * limit;
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          const auto it = cells_.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == cells_.end()) continue;
          for (Index v : it->second) {
            const float d2 = (x_[v] - p).squaredNorm();
            if (d2 < bestD2 || (d2 == bestD2 && best >= 0 && v < best)) best = v, bestD2 = d2;
          }
        }
    return {best, bestD2};
  }

private:
  std::array<long, 3> cellOf(const Vec3& p) const {
    return {long(std::floor(p.x() / cell_)), long(std::floor(p.y() / cell_)), long(std::floor(p.z() / cell_))};
  }
  static long long key(const std::array<long, 3>& c) {
    return ((long long)(c[0] & 0x1fffff) << 42) | ((long long)(c[1] & 0x1fffff) << 21) | (long long)(c[2] & 0x1fffff);
  }
  std::span<const Vec3> x_;
  float cell_;
  std::unordered_map<long long, std::vector<Index>> cells_;
};
}  // namespace

ContactLinks findContactLinks(const MeshStore& store, std::span<const std::array<Index, 2>> pairs, float distanceMm) {
  ContactLinks links;
  links.partner.assign(store.vertexCount(), -1);
  links.offset.assign(store.vertexCount(), Vec3::Zero());
  if (pairs.empty() || !(distanceMm > 0.0f)) return links;
  const std::span<const Vec3> ref = store.referencePositions();
  std::vector<float> bestD2(store.vertexCount(), std::numeric_limits<float>::max());
  std::unordered_map<Index, VertexGrid> grids;
  const auto gridOf = [&](Index m) -> const VertexGrid& {
    auto it = grids.find(m);
    if (it == grids.end())
      it = grids.emplace(m, VertexGrid(ref, store.range(m).vertexBegin, store.range(m).vertexEnd, distanceMm)).first;
    return it->second;
  };
  // Each structure's reference box grown by the distance: a vertex outside its partner's has no
  // partner there, so pairs far apart (every pair of a scene declared, most of them across the
  // brain) cost a box test instead of a grid and a query per vertex.
  std::vector<Eigen::AlignedBox3f> reach(store.meshCount());
  for (Index m = 0; m < store.meshCount(); ++m) {
    for (Index v = store.range(m).vertexBegin; v < store.range(m).vertexEnd; ++v) reach[m].extend(ref[v]);
    const float grow = distanceMm * 1.001f + 1e-3f;  // a little more, against rounding at the edge
    if (!reach[m].isEmpty()) reach[m].min().array() -= grow, reach[m].max().array() += grow;
  }
  for (const auto& pair : pairs)
    for (int side = 0; side < 2; ++side) {
      const Index own = pair[side], other = pair[1 - side];
      if (!reach[own].intersects(reach[other])) continue;
      const VertexGrid& grid = gridOf(other);
      for (Index v = store.range(own).vertexBegin; v < store.range(own).vertexEnd; ++v) {
        if (!reach[other].contains(ref[v])) continue;
        const auto [j, d2] = grid.nearest(ref[v], distanceMm);
        if (j < 0 || d2 >= bestD2[v]) continue;
        bestD2[v] = d2;
        links.partner[v] = j;
        links.offset[v] = ref[v] - ref[j];
      }
    }
  for (Index p : links.partner) links.linked += p >= 0;
  return links;
}

}  // namespace sinew
