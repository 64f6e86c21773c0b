// An ITK cubic B-spline transform's control grid, handed to core as a BSplineWarp (whose layout is
// ITK's BSplineTransform's): the registration's B-spline stage leaves the plugin this way.
#pragma once

#include "sinew/core/bspline_warp.h"

#include <itkBSplineTransform.h>

namespace sinew {

BSplineWarp bsplineWarpOf(const itk::BSplineTransform<double, 3, 3>& transform);

}  // namespace sinew
