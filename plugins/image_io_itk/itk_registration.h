// Registration of the model's atlas image to the target with ITK's v4 framework (rigid, then
// affine, then a B-spline; Mattes mutual information; multi-resolution); transform files are
// itk_transforms.h's.
#pragma once

#include "sinew/core/io.h"

namespace sinew {

RegistrationResult registerImagesItk(const Image3D& target, const Image3D& model, const RegistrationOptions& options);

}  // namespace sinew
