#include "sinew/core/collision_tree.h"

#include <algorithm>
#include <numeric>

namespace sinew {

using collision::Box;
using collision::Node;

namespace {
struct Builder {
  CollisionTree& tree;
  std::vector<Vec3> centre;   // per leaf group: the mean of its vertices
  std::vector<int> firstOf;   // per leaf group: its first vertex
  std::vector<int> countOf;

  int build(std::vector<int>& order, int begin, int end, int parent) {
    const int id = static_cast<int>(tree.nodes.size());
    tree.nodes.push_back({-1, -1, parent, 0, 0});
    if (end - begin == 1) {
      tree.nodes[id].first = firstOf[order[begin]];
      tree.nodes[id].count = countOf[order[begin]];
      tree.leaves.push_back(id);
      return id;
    }
    Eigen::AlignedBox3f bounds;
    for (int i = begin; i < end; ++i) bounds.extend(centre[order[i]]);
    int axis;
    bounds.sizes().maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    // Ties broken by index: the same tree on every machine.
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](int s, int t) {
      return centre[s][axis] != centre[t][axis] ? centre[s][axis] < centre[t][axis] : s < t;
    });
    const int left = build(order, begin, mid, id);
    const int right = build(order, mid, end, id);
    tree.nodes[id].left = left;
    tree.nodes[id].right = right;
    return id;
  }
};
}  // namespace

CollisionTree CollisionTree::build(MeshStore& store) {
  CollisionTree tree;
  const auto offsets = store.cellOffsets();
  const auto cellVertices = store.cellVertices();
  // Vertex v's three triangles: one per cell it belongs to, v then its successor in that cell.
  tree.tris.assign(3 * size_t(store.vertexCount()), {-1, -1, -1});
  std::vector<int> filled(store.vertexCount(), 0);
  for (Index c = 0; c < store.cellCount(); ++c)
    for (Index i = offsets[c]; i < offsets[c + 1]; ++i) {
      const Index next = i + 1 == offsets[c + 1] ? offsets[c] : i + 1;
      const Index a = cellVertices[i];
      if (filled[a] >= 3) throw InputError("collision tree: a vertex in more than three cells");
      tree.tris[3 * size_t(a) + filled[a]++] = {int(a), int(cellVertices[next]), int(c)};
    }
  const auto x = store.positions();
  for (Index m = 0; m < store.meshCount(); ++m) {
    const MeshRange& r = store.range(m);
    Builder b{tree, {}, {}, {}};
    for (Index v = r.vertexBegin; v < r.vertexEnd; v += collision::kLeafVertices) {
      const Index end = std::min<Index>(v + collision::kLeafVertices, r.vertexEnd);
      Vec3 sum = Vec3::Zero();
      for (Index i = v; i < end; ++i) sum += x[i];
      b.centre.push_back(sum / float(end - v));
      b.firstOf.push_back(int(v));
      b.countOf.push_back(int(end - v));
    }
    std::vector<int> order(b.centre.size());
    std::iota(order.begin(), order.end(), 0);
    tree.roots.push_back(b.build(order, 0, int(order.size()), -1));
  }
  tree.boxes.resize(tree.nodes.size());
  tree.refit(x, store.cellCentres(), store.executor());
  return tree;
}

void CollisionTree::refit(std::span<const Vec3> positions, std::span<const Vec3> centres, const Executor& executor) {
  const collision::BvhView v = view();
  const collision::P3* x = asP3(positions);
  const collision::P3* c = asP3(centres);
  executor.forEach(Index(leaves.size()), [&](Index l) { boxes[leaves[l]] = collision::leafBox(v, nodes[leaves[l]], x, c); });
  for (int id = int(nodes.size()) - 1; id >= 0; --id)
    if (nodes[id].left >= 0) boxes[id] = collision::merge(boxes[nodes[id].left], boxes[nodes[id].right]);
}

std::string CollisionTree::Enclosure::message(const SceneData& scene, float margin) const {
  return "collision: structure '" + scene.structureName(inner) + "' lies inside structure '" + scene.structureName(outer) +
         "' (" + std::to_string(inside) + " of its " + std::to_string(vertices) + " vertices inside it or within the " +
         std::to_string(margin).substr(0, 4) + " mm margin of its surface), which no contact response can separate; "
         "correct the initialisation of one of them";
}

std::optional<CollisionTree::Enclosure> CollisionTree::findEnclosure(MeshStore& store, float margin, float fraction) {
  refit(store.positions(), store.cellCentres(), store.executor());
  const collision::BvhView v = view();
  const collision::P3* x = asP3(store.positions());
  const collision::P3* c = asP3(store.cellCentres());
  for (Index inner = 0; inner < store.meshCount(); ++inner) {
    const MeshRange& r = store.range(inner);
    for (Index outer = 0; outer < store.meshCount(); ++outer) {
      if (outer == inner) continue;
      // Most of a structure inside another puts most of its box inside the other's box.
      const collision::Box a = boxes[roots[inner]], b = boxes[roots[outer]];
      const float overlapX = std::min(a.hi.x, b.hi.x + margin) - std::max(a.lo.x, b.lo.x - margin);
      const float overlapY = std::min(a.hi.y, b.hi.y + margin) - std::max(a.lo.y, b.lo.y - margin);
      const float overlapZ = std::min(a.hi.z, b.hi.z + margin) - std::max(a.lo.z, b.lo.z - margin);
      if (overlapX < 0.5f * (a.hi.x - a.lo.x) || overlapY < 0.5f * (a.hi.y - a.lo.y) || overlapZ < 0.5f * (a.hi.z - a.lo.z))
        continue;
      std::vector<std::uint8_t> near(r.vertexCount(), 0);
      store.executor().forEach(r.vertexCount(), [&](Index i) {
        const collision::Hit h = collision::closestPoint(v, int(outer), x[r.vertexBegin + i], x, c, 3.0e38f);
        near[i] = h.d2 < 3.0e38f && h.side < margin;
      });
      const Index inside = std::count(near.begin(), near.end(), std::uint8_t(1));
      if (inside >= fraction * r.vertexCount()) return Enclosure{inner, outer, inside, r.vertexCount()};
    }
  }
  return std::nullopt;
}

collision::BvhView CollisionTree::view() {
  return {nodes.data(), boxes.data(), tris.data(), roots.data(), int(roots.size())};
}

std::size_t CollisionTree::bytes() const {
  return nodes.size() * sizeof(Node) + boxes.size() * sizeof(Box) + tris.size() * sizeof(collision::Tri) +
         (roots.size() + leaves.size()) * sizeof(int);
}

}  // namespace sinew
