// Registration of the model's atlas image to the target with ITK's v4 framework (rigid, then
// affine; Mattes mutual information; multi-resolution) and ITK transform files.
#pragma once

#include "sinew/core/io.h"

namespace sinew {

RegistrationResult registerImagesItk(const Image3D& target, const Image3D& model, const RegistrationOptions& options);
Eigen::Matrix4d readAffineTransform(const std::filesystem::path& path);
void writeAffineTransform(const std::filesystem::path& path, const Eigen::Matrix4d& fixedToMoving);

}  // namespace sinew
