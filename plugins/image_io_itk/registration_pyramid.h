// The registration's resolution levels, made once and shared by the probe, the rotation search and
// every stage; and views of them, so that rigid stages from several starts may run at once.
#pragma once

#include "registration_mask.h"

#include <itkImage.h>
#include <itkMattesMutualInformationImageToImageMetricv4.h>

#include <vector>

namespace sinew {

using RegistrationImage = itk::Image<float, 3>;
using RegistrationMetric = itk::MattesMutualInformationImageToImageMetricv4<RegistrationImage, RegistrationImage>;

// Registration runs on images of about this voxel size (mm): bin-averaged once, so the v4
// pyramid never smooths a full-resolution atlas (a 0.5 mm brain has 57 M voxels).
constexpr double kWorkingSpacingMm = 2.0;

// The images of one resolution level, made once and used by the probe and by both stages: what
// ImageRegistrationMethodv4 would make again for each stage at each level (the smoothed images) and
// what each metric would make again at each Initialize (the moving image's gradient, a recursive
// Gaussian over the whole image). The same filters with the same settings, so the result is the
// same to the bit; these filters compute every voxel on its own, so they may use every thread
// (only the metric's sums need one: SerialItk).
struct PyramidLevel {
  unsigned shrink = 1;  // of the virtual domain (the fixed image's grid)
  RegistrationImage::Pointer fixed, moving;
  RegistrationMetric::MovingImageGradientFilterType::Pointer movingGradient;
  SampledRegion sampled;  // where the metric samples the fixed image (every level: the binned target's foreground)
};

// Levels coarse to fine: the virtual domain shrunk by 2^(levels-1-l), both images smoothed by half
// of that many working voxels (none at the finest). The metric samples the fixed image's
// foreground at every level: on a target resampled obliquely (a grid turned by 30 degrees, three
// times ch2's voxels) the samples drawn over the whole grid fell mostly on its padding and air, and
// a head turned by 12 degrees was not found (docs/accuracy.md, "The metric on the head alone").
std::vector<PyramidLevel> pyramidOf(RegistrationImage* fixed, RegistrationImage* moving, int levels,
                                    itk::ThreadIdType threads);

// The same levels in new ITK objects over the same voxels (images, the moving gradient, the mask):
// a stage updates its images' and its gradient filter's pipeline state, which two stages running
// at once must not share. Nothing is computed or copied but the objects; the voxels are only read.
std::vector<PyramidLevel> viewOf(const std::vector<PyramidLevel>& pyramid);

}  // namespace sinew
