#include "sinew/core/collision_tree.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

namespace sinew {

using collision::Box;
using collision::Node;

namespace {
// A vertex's position beside its index: the splits read and move contiguous memory instead of
// gathering positions through `order`.
struct Key {
  float p[3];
  int index;
};

// The vertices of a node with `count` of them: split on a multiple of kLeafVertices, so that every
// leaf but the last of a structure holds four.
int leftCount(int count) {
  return std::max(1, count / (2 * collision::kLeafVertices)) * collision::kLeafVertices;
}

// Median splits of one structure's vertices (in `order`, global indices) down to leaves of at most
// kLeafVertices; nodes in pre-order, so children follow their parent. The nodes depend only on the
// vertex counts, so they are laid out first (shape); the splits then sort each node's range of keys
// in place, the two halves of a large node side by side.
struct Builder {
  CollisionTree& tree;
  std::vector<Key>& keys;
  const Executor& executor;

  int shape(int begin, int end, int parent) {
    const int id = static_cast<int>(tree.nodes.size());
    tree.nodes.push_back({-1, -1, parent, begin, end - begin});
    if (end - begin <= collision::kLeafVertices) {
      tree.leaves.push_back(id);
      return id;
    }
    const int mid = begin + leftCount(end - begin);
    const int left = shape(begin, mid, id);
    const int right = shape(mid, end, id);
    tree.nodes[id].left = left;
    tree.nodes[id].right = right;
    return id;
  }

  void split(int id) const {
    const collision::Node& n = tree.nodes[id];
    if (n.left < 0) return;
    const auto begin = keys.begin() + n.first, end = begin + n.count;
    Eigen::AlignedBox3f bounds;
    for (auto k = begin; k != end; ++k) bounds.extend(Eigen::Vector3f(k->p[0], k->p[1], k->p[2]));
    int axis;
    bounds.sizes().maxCoeff(&axis);
    // Ties broken by index: the same tree on every machine.
    std::nth_element(begin, begin + leftCount(n.count), end, [axis](const Key& s, const Key& t) {
      return s.p[axis] != t.p[axis] ? s.p[axis] < t.p[axis] : s.index < t.index;
    });
    const auto left = [&] { split(n.left); };
    const auto right = [&] { split(n.right); };
    if (n.count >= kSideBySide) executor.invoke(left, right);
    else left(), right();
  }
  static constexpr int kSideBySide = 8192;
};
}  // namespace

CollisionTree CollisionTree::build(MeshStore& store) {
  CollisionTree tree;
  const auto offsets = store.cellOffsets();
  const auto cellVertices = store.cellVertices();
  // Vertex v's three triangles: one per cell it belongs to (in the order of the cells' indices),
  // v then its successor in that cell; cell by cell, each vertex's place from its own cells.
  const auto vertexCells = store.vertexCells();
  tree.tris.assign(3 * size_t(store.vertexCount()), {-1, -1, -1});
  store.executor().forEach(store.cellCount(), [&](Index c) {
    for (Index i = offsets[c]; i < offsets[c + 1]; ++i) {
      const Index a = cellVertices[i];
      const auto& cells = vertexCells[a];
      if (cells[0] != c && cells[1] != c && cells[2] != c)
        throw InputError("collision tree: vertex " + std::to_string(a) + " is in cell " + std::to_string(c) + ", not one of its own");
      const int k = (cells[0] < c) + (cells[1] < c) + (cells[2] < c);
      const Index next = i + 1 == offsets[c + 1] ? offsets[c] : i + 1;
      tree.tris[3 * size_t(a) + k] = {int(a), int(cellVertices[next]), int(c)};
    }
  }, 1024);
  const auto x = store.positions();
  std::vector<Key> keys(store.vertexCount());
  store.executor().forEach(store.vertexCount(), [&](Index v) { keys[v] = {{x[v].x(), x[v].y(), x[v].z()}, int(v)}; }, 4096);
  Builder b{tree, keys, store.executor()};
  tree.nodes.reserve(size_t(store.vertexCount()) / 2 + 2 * size_t(store.meshCount()));
  tree.leaves.reserve(size_t(store.vertexCount()) / 4 + 2 * size_t(store.meshCount()));
  for (Index m = 0; m < store.meshCount(); ++m)
    tree.roots.push_back(b.shape(int(store.range(m).vertexBegin), int(store.range(m).vertexEnd), -1));
  store.executor().forEach(Index(tree.roots.size()), [&](Index m) { b.split(tree.roots[m]); }, 1);
  tree.order.resize(keys.size());
  store.executor().forEach(Index(keys.size()), [&](Index i) { tree.order[i] = keys[i].index; }, 4096);
  tree.boxes.resize(tree.nodes.size());
  tree.refit(x, store.cellCentres(), store.executor());
  return tree;
}

void CollisionTree::refit(std::span<const Vec3> positions, std::span<const Vec3> centres, const Executor& executor) {
  const collision::BvhView v = view();
  const collision::P3* x = asP3(positions);
  const collision::P3* c = asP3(centres);
  executor.forEach(Index(leaves.size()), [&](Index l) { boxes[leaves[l]] = collision::leafBox(v, nodes[leaves[l]], x, c); });
  // Each structure's nodes follow its root, children after parents: the structures side by side,
  // each from its last node up.
  executor.forEach(Index(roots.size()), [&](Index m) {
    const int end = m + 1 < Index(roots.size()) ? roots[m + 1] : int(nodes.size());
    for (int id = end - 1; id >= roots[m]; --id)
      if (nodes[id].left >= 0) boxes[id] = collision::merge(boxes[nodes[id].left], boxes[nodes[id].right]);
  }, 1);
}

std::string CollisionTree::Enclosure::message(const SceneData& scene, float margin) const {
  return "collision: structure '" + scene.structureName(inner) + "' lies inside structure '" + scene.structureName(outer) +
         "' (" + std::to_string(inside) + " of " + std::to_string(sampled) + " of its vertices, sampled evenly, inside it or within the " +
         std::to_string(margin).substr(0, 4) + " mm margin of its surface), which no contact response can separate; "
         "correct the initialisation of one of them, or, if one lies inside the other by design (nested labels), "
         "set the collision force's ignore_enclosed to 1";
}

std::vector<CollisionTree::Enclosure> CollisionTree::findEnclosures(MeshStore& store, float margin, float fraction) {
  std::vector<Enclosure> found;
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
      // An even sample of at most kSample of its vertices (every vertex of a smaller structure),
      // chunk by chunk (each in parallel), stopping as soon as more than (1 - fraction) of the
      // sample is clear of it: most pairs stop after the first chunk. Every vertex, 4,096 at a
      // time, took the check 150-280 ms a level on two cores at 81,408-325,632 vertices; the
      // fraction is a threshold for a gross error, which a sample of 512 finds as well.
      constexpr Index kSample = 512, kChunk = 128;
      const Index stride = std::max<Index>(1, (r.vertexCount() + kSample - 1) / kSample);
      const Index sampled = (r.vertexCount() + stride - 1) / stride;
      const Index allowedOutside = sampled - Index(std::ceil(fraction * float(sampled)));
      Index outside = 0;
      for (Index begin = 0; begin < sampled && outside <= allowedOutside; begin += kChunk) {
        outside += store.executor().reduce(
            begin, std::min(begin + kChunk, sampled), Index(0),
            [&](Index b, Index e, Index acc) {
              for (Index k = b; k < e; ++k) {
                const Index i = r.vertexBegin + k * stride;
                const collision::Hit h = collision::closestPoint(v, int(outer), x[i], x, c, 3.0e38f);
                acc += h.d2 < 3.0e38f && h.side < margin ? 0 : 1;
              }
              return acc;
            },
            std::plus<Index>(), 16);
      }
      if (outside <= allowedOutside) found.push_back({inner, outer, sampled - outside, sampled});
    }
  }
  return found;
}

void CollisionTree::handleEnclosures(MeshStore& store, const SceneData& scene, float margin, bool ignore) {
  const std::vector<Enclosure> found = findEnclosures(store, margin);
  if (found.empty()) return;
  if (!ignore) throw NumericalError(found.front().message(scene, margin));
  const Index n = store.meshCount();
  exempt.assign(size_t(n) * n, 0);
  for (const Enclosure& e : found) exempt[e.inner * n + e.outer] = exempt[e.outer * n + e.inner] = 1;
}

std::vector<unsigned char> contactMask(MeshStore& store, const SceneData& scene, float margin) {
  std::vector<unsigned char> mask(store.vertexCount(), 0);
  if (store.meshCount() < 2) return mask;
  if (!store.has(Attribute::CellCentre)) store.require(Attribute::CellCentre);
  CollisionTree tree = CollisionTree::build(store);
  tree.handleEnclosures(store, scene, margin, true);
  const collision::BvhView v = tree.view();
  const collision::P3* x = asP3(store.positions());
  const collision::P3* c = asP3(store.cellCentres());
  const auto meshOf = store.meshOfVertex();
  store.executor().forEach(store.vertexCount(), [&](Index i) {
    const int own = int(meshOf[i]);
    for (int other = 0; other < v.meshes && !mask[i]; ++other) {
      if (other == own || (v.exempt && v.exempt[own * v.meshes + other])) continue;
      if (collision::squaredDistance(v.boxes[v.roots[other]], x[i]) > margin * margin) continue;
      const collision::Hit h = collision::closestPoint(v, other, x[i], x, c, 3.0e38f);
      mask[i] = h.d2 < 3.0e38f && h.side < margin;
    }
  });
  return mask;
}

collision::BvhView CollisionTree::view() {
  return {nodes.data(),
          boxes.data(),
          tris.data(),
          order.data(),
          roots.data(),
          exempt.empty() ? nullptr : exempt.data(),
          int(roots.size()),
          int(nodes.size()),
          share.empty() ? nullptr : share.data()};
}

collision::ContactSettings contactSettingsOf(const ParamTable& params) {
  const auto get = [&](const char* name) { return params.getf(0, params.indexOf(name)); };
  const float holdStep = get("hold_step");
  return {get("margin_mm"), get("contact_damping"), get("reach_mm"),  get("retreat_mm"),
          get("hold_mm"),   get("ahead_mm"),        holdStep > 0.0f ? holdStep : 3.0e38f, get("reaction")};
}

int fullSearchEveryOf(const ParamTable& params) { return std::max(1, int(params.get(0, params.indexOf("full_search_every")))); }

int fullSearchFirstOf(const ParamTable& params) { return std::max(0, int(params.get(0, params.indexOf("full_search_first")))); }

namespace {

// collision::shareOf's table by the structures' surface areas (CollisionTree::setShares).
std::vector<float> sharesBySize(MeshStore& store, double exponent, const std::function<bool(Index)>& responds) {
  const Index n = store.meshCount();
  const auto area = store.areas();
  std::vector<double> size(n, 0.0);
  for (Index m = 0; m < n; ++m) {
    double a = 0.0;
    for (Index v = store.range(m).vertexBegin; v < store.range(m).vertexEnd; ++v) a += area[v];
    size[m] = std::pow(a, exponent);
  }
  std::vector<float> share(size_t(n) * n, 1.0f);
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < n; ++j)
      if (size[i] + size[j] > 0.0 && responds(j))
        share[size_t(i) * n + j] = float(std::min(1.0, 2.0 * size[i] / (size[i] + size[j])));
  return share;
}

}  // namespace

void CollisionTree::setShares(MeshStore& store, const SceneData& scene, const ParamTable& collisionParams) {
  share.clear();
  const double exponent = collisionParams.get(0, collisionParams.indexOf("size_share"));
  const Index n = store.meshCount();
  const auto responds = [&](Index m) { return collisionParams.get(m, 0) > 0.0; };
  if (!(exponent > 0.0)) {
    if (scene.collisionShares().empty()) return;
    share.assign(size_t(n) * n, 1.0f);
  } else {
    share = sharesBySize(store, exponent, responds);
  }
  for (const SceneData::PairShare& p : scene.collisionShares()) {
    if (p.a < 0 || p.b < 0 || p.a >= n || p.b >= n) throw std::logic_error("collision shares: structure index out of range");
    share[size_t(p.a) * n + p.b] = responds(p.b) ? p.aShare : 1.0f;  // against one that does not respond, all
    share[size_t(p.b) * n + p.a] = responds(p.a) ? p.bShare : 1.0f;
  }
}

}  // namespace sinew
