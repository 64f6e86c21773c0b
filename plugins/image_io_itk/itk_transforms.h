// ITK's transforms and Sinew's: an affine as a 4x4 matrix, a cubic B-spline as a BSplineWarp (whose
// layout is ITK's BSplineTransform's), and transform files holding an affine or an affine after a
// B-spline (a registration's map of target points to model points, ITK's fixed-to-moving
// convention).
#pragma once

#include "sinew/core/io.h"

#include <itkBSplineTransform.h>
#include <itkMatrixOffsetTransformBase.h>

namespace sinew {

Eigen::Matrix4d toMatrix(const itk::MatrixOffsetTransformBase<double, 3, 3>& transform);
BSplineWarp bsplineWarpOf(const itk::BSplineTransform<double, 3, 3>& transform);
itk::BSplineTransform<double, 3, 3>::Pointer bsplineTransformOf(const BSplineWarp& warp);

// The transform a file holds: an affine alone, or the composite below.
itk::Transform<double, 3, 3>::Pointer itkTransformOf(const RegistrationTransform& transform);
// An affine alone, or ITK's composite transform of an affine and a cubic B-spline applied before it
// (the last added, as ITK applies them). Reading throws InputError naming the file and the problem.
RegistrationTransform readRegistrationTransform(const std::filesystem::path& path);
void writeRegistrationTransform(const std::filesystem::path& path, const RegistrationTransform& transform);

}  // namespace sinew
