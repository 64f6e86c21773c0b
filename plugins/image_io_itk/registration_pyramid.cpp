#include "registration_pyramid.h"

#include <itkGradientRecursiveGaussianImageFilter.h>
#include <itkSmoothingRecursiveGaussianImageFilter.h>

namespace sinew {

namespace {
using ImageType = RegistrationImage;
using GradientImageType = RegistrationMetric::MovingImageGradientImageType;
using GradientFilterType = itk::GradientRecursiveGaussianImageFilter<ImageType, GradientImageType>;
using GradientSource = RegistrationMetric::MovingImageGradientFilterType;

ImageType::Pointer smoothed(ImageType* image, double sigmaMm, itk::ThreadIdType threads) {
  auto smooth = itk::SmoothingRecursiveGaussianImageFilter<ImageType, ImageType>::New();
  smooth->SetNumberOfWorkUnits(threads);
  smooth->SetSigmaArray(itk::SmoothingRecursiveGaussianImageFilter<ImageType, ImageType>::SigmaArrayType(sigmaMm));
  smooth->SetInput(image);
  smooth->Update();
  ImageType::Pointer out = smooth->GetOutput();
  out->DisconnectPipeline();
  return out;
}

// The metric's default gradient filter (ImageToImageMetricv4::InitializeDefaultMovingImageGradientFilter).
GradientSource::Pointer gradientOf(ImageType* moving, itk::ThreadIdType threads) {
  auto f = GradientFilterType::New();
  double maximumSpacing = 0.0;
  for (int a = 0; a < 3; ++a) maximumSpacing = std::max(maximumSpacing, moving->GetSpacing()[a]);
  f->SetSigma(maximumSpacing);
  f->SetNormalizeAcrossScale(true);
  f->SetUseImageDirection(true);
  f->SetNumberOfWorkUnits(threads);
  f->SetInput(moving);
  f->Update();
  return f.GetPointer();
}

// A gradient computed already, handed out as a gradient filter's output (the metric asks a filter
// for it, and updates that filter at each Initialize): the output shares the given voxels.
class GivenGradient final : public GradientSource {
public:
  using Self = GivenGradient;
  using Pointer = itk::SmartPointer<Self>;
  itkNewMacro(Self)
  itkTypeMacro(GivenGradient, ImageToImageFilter)
  void setGradient(const GradientImageType* gradient) { gradient_ = gradient; }

protected:
  GivenGradient() = default;
  void GenerateInputRequestedRegion() override {}  // the input (the moving image) is not read
  void EnlargeOutputRequestedRegion(itk::DataObject* output) override { output->SetRequestedRegionToLargestPossibleRegion(); }
  void GenerateData() override {
    GradientImageType* out = this->GetOutput();
    out->SetBufferedRegion(gradient_->GetBufferedRegion());
    out->SetPixelContainer(const_cast<GradientImageType::PixelContainer*>(gradient_->GetPixelContainer()));
  }

private:
  GradientImageType::ConstPointer gradient_;
};

ImageType::Pointer viewOf(const ImageType* image) {
  auto view = ImageType::New();
  view->CopyInformation(image);
  view->SetRegions(image->GetBufferedRegion());
  view->SetPixelContainer(const_cast<ImageType::PixelContainer*>(image->GetPixelContainer()));
  return view;
}
}  // namespace

std::vector<PyramidLevel> pyramidOf(ImageType* fixed, ImageType* moving, int levels, itk::ThreadIdType threads) {
  std::vector<PyramidLevel> out(std::size_t(std::max(1, levels)));
  const SampledRegion sampled = foregroundOf(fixed, threads);
  for (std::size_t l = 0; l < out.size(); ++l) {
    const unsigned factor = 1u << (out.size() - 1 - l);
    const double sigma = 0.5 * factor * kWorkingSpacingMm * (factor > 1);
    PyramidLevel& level = out[l];
    level.shrink = factor;
    level.fixed = sigma > 0 ? smoothed(fixed, sigma, threads) : ImageType::Pointer(fixed);
    level.moving = sigma > 0 ? smoothed(moving, sigma, threads) : ImageType::Pointer(moving);
    level.movingGradient = gradientOf(level.moving, threads);
    level.sampled = sampled;
  }
  return out;
}

std::vector<PyramidLevel> viewOf(const std::vector<PyramidLevel>& pyramid) {
  std::vector<PyramidLevel> out(pyramid.size());
  SampledRegion sampled = pyramid.front().sampled;  // one mask for every level, as in the pyramid
  if (sampled.mask) {
    auto mask = ForegroundMask::New();
    mask->SetImage(sampled.mask->GetImage());
    mask->Update();
    mask->prepare();
    sampled.mask = mask;
  }
  for (std::size_t l = 0; l < pyramid.size(); ++l) {
    out[l].shrink = pyramid[l].shrink;
    out[l].fixed = viewOf(pyramid[l].fixed.GetPointer());
    out[l].moving = viewOf(pyramid[l].moving.GetPointer());
    auto gradient = GivenGradient::New();
    gradient->setGradient(pyramid[l].movingGradient->GetOutput());
    out[l].movingGradient = gradient.GetPointer();
    out[l].sampled = sampled;
  }
  return out;
}

}  // namespace sinew
