// Rasterisation of closed surfaces onto an image grid (label maps, Dice).
#pragma once

#include "sinew/core/image.h"
#include "sinew/core/io.h"
#include "sinew/core/triangle_mesh.h"

#include <cstdint>
#include <functional>
#include <vector>

namespace sinew {

// 1 for every voxel whose centre is inside the closed mesh (even-odd rule along rows of the
// grid's first axis), 0 elsewhere; in the grid's voxel order. Works for any direction matrix.
std::vector<std::uint8_t> voxelize(const TriangleMesh& mesh, const ImageGeometry& grid);
// The same voxels as runs along the first axis: inside(first voxel's index, count), without a
// full-grid mask.
void forEachInsideRun(const TriangleMesh& mesh, const ImageGeometry& grid,
                      const std::function<void(std::size_t first, std::size_t count)>& inside);

// Volume (mm^3) where two closed meshes overlap: both rasterised on an axis-aligned grid of this
// spacing over the intersection of their bounding boxes (0 when the boxes do not meet). An
// independent measure of inter-penetration, as the issue on collisions asks.
double overlapVolume(const TriangleMesh& a, const TriangleMesh& b, double spacingMm);

struct PairOverlap {
  int a = 0, b = 0;      // indices into the meshes given, a < b
  double volumeMm3 = 0;  // only pairs with a positive overlap are listed
};
// Every overlapping pair of the meshes, in order of (a, b).
std::vector<PairOverlap> pairwiseOverlaps(const std::vector<const TriangleMesh*>& meshes, double spacingMm);

// Dice of a closed mesh, rasterised as voxelize() does, against the voxels of `labels` (on the
// same grid) equal to `label`, of which there are labelCount; without a mask of either (only the
// runs inside the mesh are visited).
double diceOfMesh(const TriangleMesh& mesh, const LabelVolume& labels, std::int32_t label, std::size_t labelCount);

// Dice coefficient of two masks of the same size.
double dice(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b);

}  // namespace sinew
