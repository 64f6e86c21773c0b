// Reference shapes at every level of detail: the dual of a coarse closed triangle mesh, refined
// 1-to-4, and at each level relaxed onto a dense surface of the structure (tangential smoothing
// followed by projection onto the surface), so every level is quasi-regular and lies on the shape.
#pragma once

#include "sinew/core/executor.h"
#include "sinew/core/level_of_detail.h"

namespace sinew {

struct BuiltModel {
  LevelHierarchy levels;
  std::vector<std::vector<Vec3>> positions;  // per level, on the surface
};

// coarse: the closed triangle mesh whose dual is level 0; surface: where vertices must lie.
BuiltModel buildModel(const TriangleMesh& coarse, const TriangleMesh& surface, int levelCount,
                      const Executor& executor, int relaxIterations = 10);

// Number of dual triangles that gives about `spacing` between simplex vertices on this surface.
int trianglesForSpacing(const TriangleMesh& surface, double spacingMm);

}  // namespace sinew
