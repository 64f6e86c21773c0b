#include "sinew/core/level_of_detail.h"

#include <algorithm>

namespace sinew {

void Prolongation::apply(std::span<const Vec3> coarse, std::span<Vec3> fine, const Executor& executor) const {
  executor.forEach(fineCount(), [&](Index i) {
    Vec3 sum = Vec3::Zero();
    for (Index k = rowOffsets[i]; k < rowOffsets[i + 1]; ++k) sum += weight[k] * coarse[coarseIndex[k]];
    fine[i] = sum;
  }, 4096);
}

std::vector<Vec3> Prolongation::apply(std::span<const Vec3> coarse) const {
  std::vector<Vec3> fine(fineCount());
  apply(coarse, fine);
  return fine;
}

namespace {
// Numbers the cells in the order of their least vertex, each cell's own vertex order kept. dualOf
// numbers the fine cells as refine builds them (the coarse cells, then the edges' midpoints in the
// order they are met), so a run of consecutive cells had vertices all over the level; a pass over
// the cells then gathers from fewer cache lines (at 1.3 M vertices 56 sectors of positions a warp of
// 32 cells instead of 90; H100, smoothing + shape prior at 169,984 / 2,719,744 vertices 19.3 / 240
// -> 16.7 / 232 us a step; docs/benchmarks.md).
void numberCellsByLeastVertex(SimplexTopology& t) {
  const Index cells = t.cellCount();
  std::vector<Index> least(cells), order(cells), rank(cells);
  for (Index c = 0; c < cells; ++c) {
    least[c] = *std::min_element(t.cellVertices.begin() + t.cellOffsets[c], t.cellVertices.begin() + t.cellOffsets[c + 1]);
    order[c] = c;
  }
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return least[a] < least[b]; });
  std::vector<Index> offsets{0}, vertices;
  offsets.reserve(cells + 1);
  vertices.reserve(t.cellVertices.size());
  for (Index i = 0; i < cells; ++i) {
    const Index c = order[i];
    rank[c] = i;
    vertices.insert(vertices.end(), t.cellVertices.begin() + t.cellOffsets[c], t.cellVertices.begin() + t.cellOffsets[c + 1]);
    offsets.push_back(static_cast<Index>(vertices.size()));
  }
  for (auto& vc : t.vertexCells)
    for (Index& c : vc) c = rank[c];
  t.cellOffsets = std::move(offsets);
  t.cellVertices = std::move(vertices);
}
}  // namespace

RefinedTopology refine(const SimplexTopology& coarse) {
  const Index nCoarse = coarse.vertexCount();
  const Index nCells = coarse.cellCount();
  // Fine triangle-mesh vertices: the coarse cells, then one midpoint per coarse simplex edge,
  // numbered as the loop below first meets them. Edge k of t (to neighbour k) separates cells k
  // and k + 1; its other side is the neighbour's edge between the same cells, the other way round.
  // (A std::map keyed by the two cells took about 0.9 s of refine's 4.1 s at 1,310,720 fine
  // vertices; with this array and DirectedEdges in dualOf refine takes 0.35 s; docs/benchmarks.md.)
  std::vector<Index> midpointOfEdge(static_cast<size_t>(nCoarse) * 3, -1);
  Index nextMidpoint = nCells;
  auto midpoint = [&](Index t, int k) {
    Index& id = midpointOfEdge[static_cast<size_t>(t) * 3 + k];
    if (id < 0) {
      id = nextMidpoint++;
      const Index n = coarse.neighbours[t][k], a = coarse.vertexCells[t][k], b = coarse.vertexCells[t][(k + 1) % 3];
      for (int j = 0; j < 3; ++j)
        if (coarse.vertexCells[n][j] == b && coarse.vertexCells[n][(j + 1) % 3] == a) midpointOfEdge[static_cast<size_t>(n) * 3 + j] = id;
    }
    return id;
  };
  TriangleMesh fineTriangles;
  fineTriangles.triangles.reserve(static_cast<size_t>(nCoarse) * 4);
  for (Index t = 0; t < nCoarse; ++t) {
    const auto [a, b, c] = coarse.vertexCells[t];
    const Index ab = midpoint(t, 0), bc = midpoint(t, 1), ca = midpoint(t, 2);
    fineTriangles.triangles.push_back({ab, bc, ca});  // centre child: fine vertex 4t
    fineTriangles.triangles.push_back({a, ab, ca});   // corner a: 4t + 1
    fineTriangles.triangles.push_back({b, bc, ab});   // corner b: 4t + 2
    fineTriangles.triangles.push_back({c, ca, bc});   // corner c: 4t + 3
  }
  // Connectivity is all dualOf needs; points only have to exist.
  fineTriangles.points.assign(nextMidpoint, Vec3::Zero());

  RefinedTopology out;
  out.fine = SimplexTopology::dualOf(fineTriangles);
  numberCellsByLeastVertex(out.fine);
  Prolongation& p = out.prolongation;
  p.rowOffsets.reserve(static_cast<size_t>(nCoarse) * 4 + 1);
  p.rowOffsets.push_back(0);
  auto closeRow = [&] { p.rowOffsets.push_back(static_cast<Index>(p.coarseIndex.size())); };
  for (Index t = 0; t < nCoarse; ++t) {
    p.coarseIndex.push_back(t);
    p.weight.push_back(1.0f);
    closeRow();
    for (int k = 0; k < 3; ++k) {
      const Index cell = coarse.vertexCells[t][k];
      const Index begin = coarse.cellOffsets[cell], end = coarse.cellOffsets[cell + 1];
      const float share = 0.5f / static_cast<float>(end - begin);
      float own = 0.5f;
      for (Index i = begin; i < end; ++i) {
        if (coarse.cellVertices[i] == t) {
          own += share;
          continue;
        }
        p.coarseIndex.push_back(coarse.cellVertices[i]);
        p.weight.push_back(share);
      }
      p.coarseIndex.push_back(t);
      p.weight.push_back(own);
      closeRow();
    }
  }
  return out;
}

LevelHierarchy LevelHierarchy::build(const SimplexTopology& coarsest, int levelCount) {
  LevelHierarchy h;
  h.levels.push_back(coarsest);
  for (int l = 1; l < levelCount; ++l) {
    RefinedTopology r = refine(h.levels.back());
    h.levels.push_back(std::move(r.fine));
    h.prolongations.push_back(std::move(r.prolongation));
  }
  return h;
}

std::vector<Vec3> LevelHierarchy::carry(std::span<const Vec3> values, int from, int to) const {
  std::vector<Vec3> current(values.begin(), values.end());
  for (int l = from; l < to; ++l) current = prolongations[l].apply(current);
  return current;
}

}  // namespace sinew
