// Levels of detail (paper 001 section 2.1): the dual triangle mesh is refined 1-to-4, so a level
// has exactly four times the vertices of the one below, and every fine vertex is a fixed linear
// combination of coarse ones. The same combination carries positions, velocities and forces.
#pragma once

#include "sinew/core/executor.h"
#include "sinew/core/simplex_mesh.h"

#include <span>
#include <vector>

namespace sinew {

// Sparse fine-from-coarse weights, one row per fine vertex (rows sum to 1).
struct Prolongation {
  std::vector<Index> rowOffsets;  // size fineCount + 1
  std::vector<Index> coarseIndex;
  std::vector<float> weight;

  Index fineCount() const { return static_cast<Index>(rowOffsets.size()) - 1; }
  // fine[i] = sum_k weight[k] * coarse[coarseIndex[k]]; fine must have fineCount() elements.
  void apply(std::span<const Vec3> coarse, std::span<Vec3> fine, const Executor& executor = serialExecutor()) const;
  std::vector<Vec3> apply(std::span<const Vec3> coarse) const;
};

struct RefinedTopology {
  SimplexTopology fine;
  Prolongation prolongation;
};

// Fine vertex 4t is the centre child of coarse vertex t and sits on it; fine vertex 4t + k + 1 is
// the corner child at cell vertexCells[t][k] and sits halfway between t and that cell's centre
// (the centroid of the corner sub-triangle when simplex vertices are dual-triangle centroids).
// The fine cells are numbered in the order of their least vertex.
RefinedTopology refine(const SimplexTopology& coarse);

// A structure's hierarchy: level 0 is the coarsest; prolongations[l] maps level l to l + 1.
struct LevelHierarchy {
  std::vector<SimplexTopology> levels;
  std::vector<Prolongation> prolongations;

  static LevelHierarchy build(const SimplexTopology& coarsest, int levelCount);
  int levelCount() const { return static_cast<int>(levels.size()); }
  // Carries per-vertex vectors from level `from` to level `to` (to >= from).
  std::vector<Vec3> carry(std::span<const Vec3> values, int from, int to) const;
};

}  // namespace sinew
