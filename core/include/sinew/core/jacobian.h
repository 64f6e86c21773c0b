// The forces' derivative with respect to positions, K = df/dx, for implicit integrators. A simplex
// mesh vertex has exactly three neighbours, so K is block-sparse with fixed structure: per vertex
// one 3x3 self block and three 3x3 neighbour blocks (in the order of MeshStore::neighbours()).
#pragma once

#include "sinew/core/types.h"

#include <array>
#include <vector>

namespace sinew {

using Mat3 = Eigen::Matrix3f;

struct JacobianBlocks {
  std::vector<Mat3> self;                     // d f_v / d x_v
  std::vector<std::array<Mat3, 3>> neighbour;  // d f_v / d x_{neighbours[v][k]}

  void reset(Index vertices) {
    self.assign(vertices, Mat3::Zero());
    neighbour.assign(vertices, {Mat3::Zero(), Mat3::Zero(), Mat3::Zero()});
  }
  Index size() const { return static_cast<Index>(self.size()); }
};

}  // namespace sinew
