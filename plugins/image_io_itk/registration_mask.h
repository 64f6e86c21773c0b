// Where the registration's metric samples the target: its head, not the air around it or the
// padding of a grid resampled obliquely (docs/accuracy.md, "The metric on the head alone").
#pragma once

#include <itkImage.h>
#include <itkImageMaskSpatialObject.h>

namespace sinew {

// ITK's image mask, asked faster: the v4 metric asks its mask at every sample of every iteration
// (and the probe at every voxel), and through SpatialObject's general path (the object's transform,
// its name and depth, its bounding box) the rigid and affine stages took 0.40 and 0.37 s instead of
// 0.24 and 0.16 s on one subject (docs/benchmarks.md, "The metric on the head alone"). The same
// answer as ImageMaskSpatialObject::IsInsideInObjectSpace (the voxel the point rounds to, by ITK's
// rounding, is in the image and non-zero) for a mask whose object transform is the identity, as
// this one's always is. Call prepare() after SetImage.
class ForegroundMask final : public itk::ImageMaskSpatialObject<3> {
public:
  using Self = ForegroundMask;
  using Pointer = itk::SmartPointer<Self>;
  itkNewMacro(Self)
  itkTypeMacro(ForegroundMask, ImageMaskSpatialObject)
  void prepare();
  bool IsInsideInWorldSpace(const PointType& point, unsigned int depth = 0, const std::string& name = "") const override;

protected:
  ForegroundMask() = default;

private:
  const unsigned char* voxels_ = nullptr;
  double toIndex_[3][3] = {}, origin_[3] = {};
  long size_[3] = {};
};

struct SampledRegion {
  ForegroundMask::Pointer mask;  // null: every voxel of the image
  double voxels = 0.0;  // the image's voxels samples are drawn from: those in the mask, else all
  double share = 1.0;   // of the image's voxels
};

// The image's foreground, on a grid of twice its voxel size: above Otsu's threshold, its enclosed
// holes (ventricles, sinuses) filled, grown by one voxel of that grid (4 mm on the registration's
// 2 mm images) so that the head's outline stays in. Where that holds under 2 % or over 98 % of the
// image (an image without air, a constant one), the whole image. On `threads` threads; the same
// mask on any number of them.
SampledRegion foregroundOf(const itk::Image<float, 3>* image, itk::ThreadIdType threads);

}  // namespace sinew
