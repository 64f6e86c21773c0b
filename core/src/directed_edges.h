// A triangle mesh's directed edges looked up by their two vertices, without a hash table: per start
// vertex its outgoing edges in compressed rows, sorted by end vertex. Private to core (dualOf,
// validateClosedManifold). With std::unordered_map, one node allocated per edge, those two took 3.2
// of the 4.1 s that refining a level to 1,310,720 vertices took, and 0.22 s with this (2-core
// machine; docs/benchmarks.md).
#pragma once

#include "sinew/core/triangle_mesh.h"

#include <algorithm>
#include <array>
#include <span>
#include <vector>

namespace sinew {

// Edge (from, to) of `triangle`: (tri[corner], tri[(corner + 1) % 3]).
struct DirectedEdge {
  Index to = 0, triangle = 0;
  int corner = 0;
};

class DirectedEdges {
public:
  // The edges of triangles[0 .. count - 1], whose indices must lie in [0, points).
  DirectedEdges(const std::vector<std::array<Index, 3>>& triangles, Index count, Index points)
      : offsets_(static_cast<size_t>(points) + 1, 0) {
    for (Index t = 0; t < count; ++t)
      for (Index v : triangles[t]) ++offsets_[v + 1];
    for (Index v = 0; v < points; ++v) offsets_[v + 1] += offsets_[v];
    edges_.resize(offsets_[points]);
    std::vector<Index> fill(offsets_.begin(), offsets_.end() - 1);
    for (Index t = 0; t < count; ++t)
      for (int k = 0; k < 3; ++k) edges_[fill[triangles[t][k]]++] = {triangles[t][(k + 1) % 3], t, k};
    // Filled in triangle order, so equal ends stay in the order a scan of the triangles meets them.
    for (Index v = 0; v < points; ++v)
      std::stable_sort(edges_.begin() + offsets_[v], edges_.begin() + offsets_[v + 1],
                       [](const DirectedEdge& a, const DirectedEdge& b) { return a.to < b.to; });
  }

  // The edges leaving a, by end vertex; equal ends in triangle order.
  std::span<const DirectedEdge> from(Index a) const {
    return {edges_.data() + offsets_[a], edges_.data() + offsets_[a + 1]};
  }
  Index outgoing(Index a) const { return offsets_[a + 1] - offsets_[a]; }
  // The first triangle, in triangle order, holding the directed edge (a, b); -1 if none.
  Index find(Index a, Index b) const {
    const auto row = from(a);
    const auto it = std::lower_bound(row.begin(), row.end(), b, [](const DirectedEdge& e, Index to) { return e.to < to; });
    return it != row.end() && it->to == b ? it->triangle : -1;
  }

private:
  std::vector<Index> offsets_;
  std::vector<DirectedEdge> edges_;
};

// validateClosedManifold, handing back the directed edges it built (dualOf looks its neighbours
// and fans up in them instead of building them again).
DirectedEdges closedManifoldEdges(const TriangleMesh& mesh);

}  // namespace sinew
