#include "registration_mask.h"

#include <itkBinShrinkImageFilter.h>
#include <itkBinaryBallStructuringElement.h>
#include <itkBinaryDilateImageFilter.h>
#include <itkBinaryFillholeImageFilter.h>
#include <itkImageRegionConstIterator.h>
#include <itkMath.h>
#include <itkOtsuThresholdImageFilter.h>

namespace sinew {

namespace {
using FloatImage = itk::Image<float, 3>;
using MaskImage = itk::Image<unsigned char, 3>;
constexpr double kLeastShare = 0.02, kMostShare = 0.98;
}  // namespace

void ForegroundMask::prepare() {
  const MaskImage* image = GetImage();
  voxels_ = image->GetBufferPointer();
  MaskImage::DirectionType scale;  // ImageBase::ComputeIndexToPhysicalPointMatrices's inverse
  for (int a = 0; a < 3; ++a) scale[a][a] = image->GetSpacing()[a];
  const MaskImage::DirectionType m(MaskImage::DirectionType(image->GetDirection() * scale).GetInverse());
  for (int r = 0; r < 3; ++r) {
    origin_[r] = image->GetOrigin()[r];
    size_[r] = long(image->GetBufferedRegion().GetSize()[r]);
    for (int c = 0; c < 3; ++c) toIndex_[r][c] = m[r][c];
  }
}

bool ForegroundMask::IsInsideInWorldSpace(const PointType& point, unsigned int, const std::string&) const {
  long index[3];
  for (int r = 0; r < 3; ++r) {
    double sum = 0.0;  // ImageBase::TransformPhysicalPointToIndex's arithmetic, in its order
    for (int c = 0; c < 3; ++c) sum += toIndex_[r][c] * (point[c] - origin_[c]);
    index[r] = itk::Math::RoundHalfIntegerUp<long>(sum);
    if (index[r] < 0 || index[r] >= size_[r]) return false;
  }
  return voxels_[(index[2] * size_[1] + index[1]) * size_[0] + index[0]] != 0;
}

SampledRegion foregroundOf(const FloatImage* image, itk::ThreadIdType threads) {
  SampledRegion whole;
  whole.voxels = double(image->GetLargestPossibleRegion().GetNumberOfPixels());
  // On a grid of twice the voxel size (an eighth of the voxels): a mask grown by 4 mm needs no finer one.
  auto shrink = itk::BinShrinkImageFilter<FloatImage, FloatImage>::New();
  shrink->SetInput(image);
  itk::BinShrinkImageFilter<FloatImage, FloatImage>::ShrinkFactorsType factors;
  double fine = 1.0;  // image voxels a mask voxel holds
  for (unsigned a = 0; a < 3; ++a) {
    factors[a] = image->GetLargestPossibleRegion().GetSize()[a] >= 4 ? 2 : 1;
    fine *= factors[a];
  }
  shrink->SetShrinkFactors(factors);
  shrink->SetNumberOfWorkUnits(threads);
  auto otsu = itk::OtsuThresholdImageFilter<FloatImage, MaskImage>::New();
  otsu->SetInput(shrink->GetOutput());
  otsu->SetInsideValue(0);  // at or below the threshold: air
  otsu->SetOutsideValue(1);
  otsu->SetNumberOfWorkUnits(threads);
  auto fill = itk::BinaryFillholeImageFilter<MaskImage>::New();
  fill->SetInput(otsu->GetOutput());
  fill->SetForegroundValue(1);
  fill->SetNumberOfWorkUnits(threads);
  using Ball = itk::BinaryBallStructuringElement<unsigned char, 3>;
  Ball ball;
  ball.SetRadius(1);
  ball.CreateStructuringElement();
  auto grow = itk::BinaryDilateImageFilter<MaskImage, MaskImage, Ball>::New();
  grow->SetInput(fill->GetOutput());
  grow->SetKernel(ball);
  grow->SetForegroundValue(1);
  grow->SetNumberOfWorkUnits(threads);
  grow->Update();
  MaskImage::Pointer coarse = grow->GetOutput();
  coarse->DisconnectPipeline();
  SampledRegion region;
  region.mask = ForegroundMask::New();
  region.mask->SetImage(coarse);
  region.mask->Update();
  region.mask->prepare();
  // The image's own voxels in it (the share of the samples drawn over the image that land in it):
  // each mask voxel's bin of image voxels rounds to it (the bin's centre is its centre; the image
  // voxels past the last whole bin round outside the mask).
  double inside = 0.0;
  for (itk::ImageRegionConstIterator<MaskImage> it(coarse, coarse->GetLargestPossibleRegion()); !it.IsAtEnd(); ++it)
    inside += it.Get() != 0;
  inside *= fine;
  region.voxels = inside;
  region.share = inside / whole.voxels;
  if (!(region.share >= kLeastShare && region.share <= kMostShare)) return whole;
  return region;
}

}  // namespace sinew
