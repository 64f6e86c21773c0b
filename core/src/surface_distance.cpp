#include "sinew/core/surface_distance.h"

#include "sinew/core/executor.h"
#include "sinew/core/triangle_bvh_wide.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

namespace sinew {

float trianglebvh::closestSquaredDistance(const WideView& v, int wideRoot, P3 p, float maxD2, P3* closest, int* triangle) {
  return walk(v, wideRoot, p, maxD2, closest, triangle);
}

namespace {
// Splits by the surface area heuristic along the longest axis of the triangles' centroids: the
// split that minimises area(left) * count(left) + area(right) * count(right) over every position
// in centroid order. On the demo's ground truths (marching-cubes surfaces) and meshes it made the
// exact evaluation 1.3-1.4x faster than median splits (docs/benchmarks.md); the distances are the
// same, only the walk is shorter. From kSahDepth levels down the splits are medians, which keeps
// every tree shallower than the queries' stack (kSahDepth + log2 of the leaves).
constexpr int kSahDepth = 32;

float halfArea(const collision::Box& b) {
  const float dx = b.hi.x - b.lo.x, dy = b.hi.y - b.lo.y, dz = b.hi.z - b.lo.z;
  return dx * dy + dy * dz + dz * dx;
}

// The triangles are sorted by centroid once per axis (ties by index); a node's range [first, end)
// holds the same triangles in each of the three lists, each in its axis' order, so a split is a
// sweep along one list and a stable partition of the other two: O(n) a level, no sort per node.
struct Builder {
  const TriangleMesh& mesh;
  std::vector<Vec3> centroid;
  std::vector<collision::Box> box;
  std::array<std::vector<int>, 3> sorted;
  std::vector<float> leftArea;
  std::vector<char> goesLeft;
  std::vector<int> scratch;
  TriangleBvh& out;

  Builder(const TriangleMesh& m, TriangleBvh& bvh) : mesh(m), out(bvh) {
    const int n = int(m.triangles.size());
    for (const auto& t : m.triangles) {
      centroid.push_back((m.points[t[0]] + m.points[t[1]] + m.points[t[2]]) / 3.0f);
      collision::Box b = collision::emptyBox();
      for (Index k : t) collision::extend(b, asP3(m.points[k]));
      box.push_back(b);
    }
    std::vector<std::pair<float, int>> keys(n);  // sorted by value, not through the index (cache misses)
    for (int axis = 0; axis < 3; ++axis) {
      for (int t = 0; t < n; ++t) keys[t] = {centroid[t][axis], t};
      std::sort(keys.begin(), keys.end());
      sorted[axis].resize(n);
      for (int t = 0; t < n; ++t) sorted[axis][t] = keys[t].second;
    }
    leftArea.resize(n), goesLeft.resize(n), scratch.resize(n);
  }

  int sahSplit(int first, int end, const std::vector<int>& order) {
    collision::Box b = collision::emptyBox();
    for (int i = first; i < end; ++i) leftArea[i] = halfArea(b = collision::merge(b, box[order[i]]));
    b = collision::emptyBox();
    float best = 3.0e38f;
    int split = (first + end) / 2;
    for (int i = end - 1; i > first; --i) {
      b = collision::merge(b, box[order[i]]);
      const float cost = leftArea[i - 1] * float(i - first) + halfArea(b) * float(end - i);
      if (cost < best) best = cost, split = i;
    }
    return split;
  }

  int build(int first, int end, int depth) {
    trianglebvh::Node n{collision::emptyBox(), -1, -1, first, end - first};
    const int id = int(out.nodes.size());
    if (end - first <= trianglebvh::kLeafTriangles) {
      for (int i = first; i < end; ++i) n.box = collision::merge(n.box, box[sorted[0][i]]);
      out.nodes.push_back(n);
      return id;
    }
    out.nodes.push_back(n);  // its box is its children's, once they are built
    int axis = 0;
    float longest = -1.0f;
    for (int a = 0; a < 3; ++a) {
      const float extent = centroid[sorted[a][end - 1]][a] - centroid[sorted[a][first]][a];
      if (extent > longest) longest = extent, axis = a;
    }
    const std::vector<int>& order = sorted[axis];
    const int mid = depth < kSahDepth ? sahSplit(first, end, order) : (first + end) / 2;
    for (int i = first; i < end; ++i) goesLeft[order[i]] = i < mid;
    for (int a = 0; a < 3; ++a) {
      if (a == axis) continue;
      std::vector<int>& list = sorted[a];  // stable: the left ones first, each side in its order
      int l = first, r = 0;
      for (int i = first; i < end; ++i) {  // both written, one kept: no branch to mispredict
        const int t = list[i];
        const int left = goesLeft[t];
        list[l] = t, scratch[r] = t;
        l += left, r += 1 - left;
      }
      std::copy_n(scratch.begin(), r, list.begin() + l);
    }
    const int left = build(first, mid, depth + 1);
    const int right = build(mid, end, depth + 1);
    out.nodes[id].left = left;
    out.nodes[id].right = right;
    out.nodes[id].box = collision::merge(out.nodes[left].box, out.nodes[right].box);
    return id;
  }
};

// The wide node over binary node `root`'s subtree (triangle_bvh_wide.h): its children, then the
// largest (by box area) inner one replaced by its two until there are four or only leaves; each
// inner child collapsed in turn. Returns its index in bvh.wide.
int collapse(TriangleBvh& bvh, int root) {
  using trianglebvh::kWideChildren;
  const std::vector<trianglebvh::Node>& nodes = bvh.nodes;
  int slot[kWideChildren];
  int count = 0;
  if (nodes[root].left < 0) {
    slot[count++] = root;  // a root that is a leaf: one child
  } else {
    slot[count++] = nodes[root].left, slot[count++] = nodes[root].right;
  }
  while (count < kWideChildren) {
    int widest = -1;
    for (int k = 0; k < count; ++k)
      if (nodes[slot[k]].left >= 0 && (widest < 0 || halfArea(nodes[slot[k]].box) > halfArea(nodes[slot[widest]].box)))
        widest = k;
    if (widest < 0) break;
    const trianglebvh::Node& n = nodes[slot[widest]];
    slot[widest] = n.left, slot[count++] = n.right;
  }
  const int id = int(bvh.wide.size());
  bvh.wide.emplace_back();
  std::array<int, kWideChildren> source;
  source.fill(-1);
  for (int k = 0; k < count; ++k) source[k] = slot[k];
  bvh.wideSource.push_back(source);
  bvh.wideOf[std::size_t(root)] = id;
  int child[kWideChildren] = {-1, -1, -1, -1};  // unused slots: never opened (empty boxes)
  for (int k = 0; k < count; ++k) {
    const trianglebvh::Node& n = bvh.nodes[slot[k]];
    if (n.left >= 0) {
      child[k] = collapse(bvh, slot[k]);
      continue;
    }
    child[k] = -1 - int(bvh.wideLeaves.size());
    trianglebvh::WideLeaf leaf{};
    leaf.first = n.first, leaf.count = n.count;
    bvh.wideLeaves.push_back(leaf);  // its corners: copyWideLeaves
  }
  for (int k = 0; k < kWideChildren; ++k) bvh.wide[std::size_t(id)].child[k] = child[k];
  return id;
}

// Every wide leaf's corners from the corners (lanes past a leaf's count repeat its first triangle).
void copyWideLeaves(TriangleBvh& bvh, const Executor* executor) {
  auto fill = [&](Index i) {
    trianglebvh::WideLeaf& l = bvh.wideLeaves[std::size_t(i)];
    for (int k = 0; k < trianglebvh::kWideChildren; ++k) {
      const collision::P3* c = bvh.corners.data() + 3 * (l.first + (k < l.count ? k : 0));
      l.ax[k] = c[0].x, l.ay[k] = c[0].y, l.az[k] = c[0].z;
      l.bx[k] = c[1].x, l.by[k] = c[1].y, l.bz[k] = c[1].z;
      l.cx[k] = c[2].x, l.cy[k] = c[2].y, l.cz[k] = c[2].z;
    }
  };
  if (executor)
    executor->forEach(Index(bvh.wideLeaves.size()), fill);
  else
    for (Index i = 0; i < Index(bvh.wideLeaves.size()); ++i) fill(i);
}

// Every wide node's children's boxes from the binary nodes they stand for.
void copyWideBoxes(TriangleBvh& bvh) {
  for (std::size_t w = 0; w < bvh.wide.size(); ++w) {
    trianglebvh::WideNode& n = bvh.wide[w];
    for (int k = 0; k < trianglebvh::kWideChildren; ++k) {
      const int s = bvh.wideSource[w][std::size_t(k)];
      const collision::Box b = s >= 0 ? bvh.nodes[std::size_t(s)].box : collision::emptyBox();
      n.loX[k] = b.lo.x, n.loY[k] = b.lo.y, n.loZ[k] = b.lo.z;
      n.hiX[k] = b.hi.x, n.hiY[k] = b.hi.y, n.hiZ[k] = b.hi.z;
    }
  }
}
}  // namespace

TriangleBvh TriangleBvh::build(const TriangleMesh& mesh) {
  if (mesh.triangles.empty()) throw InputError("surface distance: the mesh has no triangles");
  TriangleBvh bvh;
  Builder b(mesh, bvh);
  b.build(0, int(mesh.triangles.size()), 0);
  bvh.corners.reserve(3 * mesh.triangles.size());
  for (int t : b.sorted[0]) {  // every list holds each leaf's triangles together; any gives the leaf order
    bvh.triangles.push_back(mesh.triangles[t]);
    for (Index k : mesh.triangles[t]) bvh.corners.push_back(asP3(mesh.points[k]));
  }
  return bvh;
}

void TriangleBvh::reserveFor(std::span<const TriangleBvh> trees) {
  std::size_t n = nodes.size(), t = triangles.size(), w = wide.size(), l = wideLeaves.size();
  for (const TriangleBvh& tree : trees)
    n += tree.nodes.size(), t += tree.triangles.size(), w += tree.wide.size(), l += tree.wideLeaves.size();
  nodes.reserve(n), triangles.reserve(t), corners.reserve(3 * t);
  wide.reserve(w), wideSource.reserve(w), wideOf.reserve(n), wideLeaves.reserve(l);
}

int TriangleBvh::append(const TriangleBvh& other, Index pointShift) {
  const int root = int(nodes.size()), shift = int(corners.size() / 3);
  for (trianglebvh::Node n : other.nodes) {
    if (n.left >= 0) n.left += root, n.right += root;
    n.first += shift;
    nodes.push_back(n);
  }
  corners.insert(corners.end(), other.corners.begin(), other.corners.end());
  for (auto t : other.triangles) triangles.push_back({t[0] + pointShift, t[1] + pointShift, t[2] + pointShift});
  if (!other.hasWide() || (root > 0 && !hasWide())) {  // no longer the whole tree's
    wide.clear(), wideLeaves.clear(), wideSource.clear(), wideOf.clear();
    return root;
  }
  const int wideShift = int(wide.size()), leafShift = int(wideLeaves.size());
  for (std::size_t w = 0; w < other.wide.size(); ++w) {
    trianglebvh::WideNode n = other.wide[w];
    for (int k = 0; k < trianglebvh::kWideChildren; ++k)
      if (other.wideSource[w][std::size_t(k)] >= 0) n.child[k] += n.child[k] >= 0 ? wideShift : -leafShift;
    wide.push_back(n);
  }
  for (trianglebvh::WideLeaf l : other.wideLeaves) {
    l.first += shift;
    wideLeaves.push_back(l);
  }
  for (auto source : other.wideSource) {
    for (int& s : source) s = s >= 0 ? s + root : s;
    wideSource.push_back(source);
  }
  for (int w : other.wideOf) wideOf.push_back(w >= 0 ? w + wideShift : w);
  return root;
}

void TriangleBvh::refit(std::span<const Vec3> points, const Executor& executor) {
  executor.forEach(Index(triangles.size()), [&](Index t) {
    for (int k = 0; k < 3; ++k) corners[3 * t + k] = asP3(points[triangles[t][k]]);
  });
  // Children come after their parents: from the last node back, every child is done first.
  for (int id = int(nodes.size()) - 1; id >= 0; --id) {
    trianglebvh::Node& n = nodes[id];
    if (n.left >= 0) {
      n.box = collision::merge(nodes[n.left].box, nodes[n.right].box);
      continue;
    }
    n.box = collision::emptyBox();
    for (int i = 3 * n.first; i < 3 * (n.first + n.count); ++i) collision::extend(n.box, corners[i]);
  }
  if (!wideOf.empty()) {
    copyWideBoxes(*this);
    copyWideLeaves(*this, &executor);
  }
}

void TriangleBvh::requireWide() {
  if (!wideOf.empty() || nodes.empty()) return;
  wideOf.assign(nodes.size(), -1);
  std::vector<char> isChild(nodes.size(), 0);
  for (const trianglebvh::Node& n : nodes)
    if (n.left >= 0) isChild[std::size_t(n.left)] = isChild[std::size_t(n.right)] = 1;
  for (std::size_t root = 0; root < nodes.size(); ++root)
    if (!isChild[root]) collapse(*this, int(root));
  copyWideBoxes(*this);
  copyWideLeaves(*this, nullptr);  // callers make several side by side
}

float SurfaceDistanceQuery::distance(const Vec3& p) const {
  return std::sqrt(trianglebvh::closestSquaredDistance(bvh_.wideView(), bvh_.wideRoot(0), asP3(p), 3.0e38f));
}
SurfaceDistanceQuery::Closest SurfaceDistanceQuery::closest(const Vec3& p) const {
  collision::P3 q = asP3(p);
  int t = 0;
  const float d2 = trianglebvh::closestSquaredDistance(bvh_.wideView(), bvh_.wideRoot(0), asP3(p), 3.0e38f, &q, &t);
  return {asVec3(q), std::sqrt(d2), bvh_.triangles[std::size_t(t)]};
}
// On the binary tree: the wide walk has no facing filter, and this search runs only where a model
// is built.
SurfaceDistanceQuery::Closest SurfaceDistanceQuery::closestFacing(const Vec3& p, const Vec3& direction, float within) const {
  collision::P3 q = asP3(p);
  const collision::P3 facing = asP3(direction);
  int t = -1;
  const float d2 = trianglebvh::closestSquaredDistance(bvh_.view(), 0, asP3(p), within * within, &q, &t, &facing);
  if (t < 0) return {p, std::numeric_limits<float>::infinity(), {0, 0, 0}};
  return {asVec3(q), std::sqrt(d2), bvh_.triangles[std::size_t(t)]};
}
Vec3 SurfaceDistanceQuery::closestPoint(const Vec3& p) const {
  collision::P3 q = asP3(p);
  trianglebvh::closestSquaredDistance(bvh_.wideView(), bvh_.wideRoot(0), asP3(p), 3.0e38f, &q);
  return asVec3(q);
}

std::vector<SurfaceSample> sampleSurface(const TriangleMesh& mesh, float spacing) {
  std::vector<SurfaceSample> out;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.points[t[0]], &b = mesh.points[t[1]], &c = mesh.points[t[2]];
    const float longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const int n = std::max(1, static_cast<int>(std::ceil(longest / spacing)));
    const float subArea = 0.5f * (b - a).cross(c - a).norm() / static_cast<float>(n * n);
    const Vec3 u = (b - a) / static_cast<float>(n), v = (c - a) / static_cast<float>(n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        const Vec3 o = a + static_cast<float>(i) * u + static_cast<float>(j) * v;
        out.push_back({o + (u + v) / 3.0f, subArea});  // upright sub-triangle
        if (i + j + 1 < n) out.push_back({o + 2.0f * (u + v) / 3.0f, subArea});  // inverted one
      }
  }
  return out;
}

namespace {
// Distances from samples of one surface to another, with their areas, appended to `all`; computed
// in parallel, summed later in order, so the result does not depend on threads.
void distances(const std::vector<SurfaceSample>& samples, const SurfaceDistanceQuery& to, std::vector<WeightedDistance>& all,
               const Executor& executor) {
  const size_t first = all.size();
  all.resize(first + samples.size());
  executor.forEach(static_cast<Index>(samples.size()), [&](Index i) {
    all[first + i] = {to.distance(samples[i].point), samples[i].area};
  });
}
}  // namespace

SurfaceDistanceStats surfaceDistance(const TriangleMesh& a, const TriangleMesh& b, float spacing,
                                     const Executor& executor) {
  return ReferenceSurface(b, spacing).compare(a, executor);
}

ReferenceSurface::ReferenceSurface(TriangleMesh surface, float spacing)
    : surface_(std::move(surface)), spacing_(spacing), query_(surface_), samples_(sampleSurface(surface_, spacing)) {}

SurfaceDistanceStats ReferenceSurface::compare(const TriangleMesh& other, const Executor& executor) const {
  const SurfaceDistanceQuery otherQuery(other);
  std::vector<WeightedDistance> all;
  distances(sampleSurface(other, spacing_), query_, all, executor);
  const std::size_t toThis = all.size();
  distances(samples_, otherQuery, all, executor);
  return summarise(std::move(all), toThis);
}

SurfaceDistanceStats ReferenceSurface::summarise(std::vector<WeightedDistance> all, std::size_t toThis) {
  double sumAB = 0, areaA = 0, sumBA = 0, areaB = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    double& sum = i < toThis ? sumAB : sumBA;
    double& area = i < toThis ? areaA : areaB;
    sum += static_cast<double>(all[i].d) * all[i].w;
    area += all[i].w;
  }
  SurfaceDistanceStats st;
  st.meanAtoB = areaA > 0 ? sumAB / areaA : 0.0;
  st.meanBtoA = areaB > 0 ? sumBA / areaB : 0.0;
  st.assd = (sumAB + sumBA) / std::max(areaA + areaB, 1e-30);
  if (!all.empty()) st.hd95 = weightedQuantile(all, 0.95 * (areaA + areaB));
  return st;
}

float weightedQuantile(std::span<WeightedDistance> all, double target) {
  // Quickselect on three-way partitions: `below` is the area of everything left of [lo, hi), which
  // holds the answer. nth_element only picks the pivot (the range's median, so no bad pivots); the
  // partitions put the pivot's ties together, which carry one value. A sort of every distance did
  // the same and was most of the summary's time.
  auto lo = all.begin(), hi = all.end();
  double below = 0.0;
  const auto area = [](auto first, auto last) {
    double a = 0.0;
    for (; first != last; ++first) a += first->w;
    return a;
  };
  while (hi - lo > 1) {
    const auto mid = lo + (hi - lo) / 2;
    std::nth_element(lo, mid, hi, [](const WeightedDistance& x, const WeightedDistance& y) { return x.d < y.d; });
    const float pivot = mid->d;
    const auto less = std::partition(lo, hi, [pivot](const WeightedDistance& w) { return w.d < pivot; });
    const auto more = std::partition(less, hi, [pivot](const WeightedDistance& w) { return w.d == pivot; });
    const double lessArea = area(lo, less);
    if (below + lessArea >= target && less != lo) {
      hi = less;
      continue;
    }
    const double equalArea = area(less, more);
    if (below + lessArea + equalArea >= target || more == hi) return pivot;
    below += lessArea + equalArea;
    lo = more;
  }
  return lo->d;
}

}  // namespace sinew
