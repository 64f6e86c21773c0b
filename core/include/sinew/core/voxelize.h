// Rasterisation of closed surfaces onto an image grid (label maps, Dice).
#pragma once

#include "sinew/core/image.h"
#include "sinew/core/triangle_mesh.h"

#include <cstdint>
#include <vector>

namespace sinew {

// 1 for every voxel whose centre is inside the closed mesh (even-odd rule along rows of the
// grid's first axis), 0 elsewhere; in the grid's voxel order. Works for any direction matrix.
std::vector<std::uint8_t> voxelize(const TriangleMesh& mesh, const ImageGeometry& grid);

// Dice coefficient of two masks of the same size.
double dice(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b);

}  // namespace sinew
