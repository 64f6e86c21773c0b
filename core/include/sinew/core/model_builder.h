// Reference shapes at every level of detail: the dual of a coarse closed triangle mesh, refined
// 1-to-4, and at each level relaxed onto a dense surface of the structure (tangential smoothing
// followed by projection onto the surface), so every level is quasi-regular and lies on the shape.
#pragma once

#include "sinew/core/executor.h"
#include "sinew/core/level_of_detail.h"
#include "sinew/core/registry.h"

#include <string>

namespace sinew {

struct BuiltModel {
  LevelHierarchy levels;
  std::vector<std::vector<Vec3>> positions;  // per level, on the surface
  // From a label: the share of the label's volume inside the model's surface. A label in parts
  // apart from each other (a parcel of both hemispheres) is modelled by its largest part, one
  // closed surface, while its ground truth is all of it; partNote() says so below kWholeLabel.
  double labelShareEnclosed = 1.0;
  static constexpr double kWholeLabel = 0.8;
  // side: "left" or "right" for one side of a label split by side (its share is of the side).
  std::string partNote(const std::string& name, int label, const std::string& side = "") const;
};

// coarse: the closed triangle mesh whose dual is level 0; surface: where vertices must lie.
BuiltModel buildModel(const TriangleMesh& coarse, const TriangleMesh& surface, int levelCount,
                      const Executor& executor, int relaxIterations = 10);

// A structure's reference at every level from one label of a label map (the label's surface, smoothed,
// decimated to about coarseSpacingMm between level-0 vertices, and the dense surface to relax on),
// through the registry's label-surface builder. Throws InputError naming the label map. `extent`:
// the label's (labelExtents), when the caller knows it.
BuiltModel buildModelFromLabel(const Registry& registry, const LabelVolume& labels, const std::filesystem::path& file,
                               int label, const std::string& name, double coarseSpacingMm, int levelCount,
                               const Executor& executor, const LabelExtent* extent = nullptr);
// The same from a closed triangle mesh (its dual is level 0); throws InputError naming the file.
BuiltModel buildModelFromMesh(const TriangleMesh& mesh, const std::filesystem::path& file, int levelCount,
                              const Executor& executor);

// Number of dual triangles that gives about `spacing` between simplex vertices on this surface.
int trianglesForSpacing(const TriangleMesh& surface, double spacingMm);

}  // namespace sinew
