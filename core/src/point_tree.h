// A k-d tree over points (nanoflann, header only; private to core: the SDK's headers do not need it).
#pragma once

#include "sinew/core/types.h"

#include <span>

#include <nanoflann.hpp>

// Debian 12 ships nanoflann 1.4; 1.5 renamed SearchParams and changed radiusSearch's results.
#if NANOFLANN_VERSION >= 0x150
#error "Sinew uses nanoflann 1.4's interface (Debian 12's libnanoflann-dev)"
#endif

namespace sinew {

struct PointCloud {
  std::span<const Vec3> points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][Eigen::Index(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};
// Built in its constructor: PointTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10)).
using PointTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointCloud>, PointCloud, 3>;

}  // namespace sinew
