#include "itk_registration.h"

#include "itk_convert.h"

#include <mutex>

#include <itkAffineTransform.h>
#include <itkBinShrinkImageFilter.h>
#include <itkCenteredTransformInitializer.h>
#include <itkImageRegistrationMethodv4.h>
#include <itkMultiThreaderBase.h>
#include <itkMattesMutualInformationImageToImageMetricv4.h>
#include <itkMatrixOffsetTransformBase.h>
#include <itkRegistrationParameterScalesFromPhysicalShift.h>
#include <itkRegularStepGradientDescentOptimizerv4.h>
#include <itkTransformFactory.h>
#include <itkTransformFileReader.h>
#include <itkTransformFileWriter.h>
#include <itkVersorRigid3DTransform.h>

#include <chrono>
#include <cmath>
#include <cstdio>

namespace sinew {

namespace {
namespace fs = std::filesystem;
using ImageType = itk::Image<float, 3>;
using RigidType = itk::VersorRigid3DTransform<double>;
using AffineType = itk::AffineTransform<double, 3>;
using MetricType = itk::MattesMutualInformationImageToImageMetricv4<ImageType, ImageType>;
using OptimizerType = itk::RegularStepGradientDescentOptimizerv4<double>;
using Clock = std::chrono::steady_clock;

// Registration runs on images of about this voxel size (mm): bin-averaged once, so the v4
// pyramid never smooths a full-resolution atlas (a 0.5 mm brain has 57 M voxels).
constexpr double kWorkingSpacingMm = 2.0;
constexpr double kSamplesPerLevel = 40000.0;

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

ImageType::Pointer binned(const Image3D& v) {
  ImageType::Pointer image = toItk<float>(v);
  auto shrink = itk::BinShrinkImageFilter<ImageType, ImageType>::New();
  shrink->SetInput(image);
  itk::BinShrinkImageFilter<ImageType, ImageType>::ShrinkFactorsType factors;
  for (int a = 0; a < 3; ++a)
    factors[a] = std::max<unsigned>(1, unsigned(std::lround(kWorkingSpacingMm / v.geometry().spacing[a])));
  shrink->SetShrinkFactors(factors);
  shrink->Update();
  return shrink->GetOutput();
}

Eigen::Matrix4d toMatrix(const itk::MatrixOffsetTransformBase<double, 3, 3>& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m(r, c) = t.GetMatrix()[r][c];
    m(r, 3) = t.GetOffset()[r];
  }
  return m;
}

double metricValue(MetricType* metric, itk::Transform<double, 3, 3>* transform, ImageType* fixed, ImageType* moving) {
  metric->SetFixedImage(fixed);
  metric->SetMovingImage(moving);
  metric->SetMovingTransform(transform);
  metric->Initialize();
  return metric->GetValue();
}

// One stage (rigid or affine) over the pyramid; the transform is optimised in place.
template <class TransformType>
RegistrationStage runStage(const char* name, TransformType* transform, ImageType* fixed, ImageType* moving,
                           const RegistrationOptions& o, double initialStepMm) {
  const auto t0 = Clock::now();
  using RegistrationType = itk::ImageRegistrationMethodv4<ImageType, ImageType, TransformType>;
  auto metric = MetricType::New();
  metric->SetNumberOfHistogramBins(o.histogramBins);
  auto optimizer = OptimizerType::New();
  auto scales = itk::RegistrationParameterScalesFromPhysicalShift<MetricType>::New();
  scales->SetMetric(metric);
  optimizer->SetScalesEstimator(scales);
  optimizer->SetLearningRate(initialStepMm);
  optimizer->SetMinimumStepLength(0.01);
  optimizer->SetRelaxationFactor(0.5);
  optimizer->SetNumberOfIterations(o.iterations);
  optimizer->SetReturnBestParametersAndValue(true);

  auto registration = RegistrationType::New();
  registration->SetFixedImage(fixed);
  registration->SetMovingImage(moving);
  registration->SetMetric(metric);
  registration->SetOptimizer(optimizer);
  registration->SetInitialTransform(transform);
  registration->InPlaceOn();
  const int levels = std::max(1, o.levels);
  typename RegistrationType::ShrinkFactorsArrayType shrink(levels);
  typename RegistrationType::SmoothingSigmasArrayType sigmas(levels);
  typename RegistrationType::MetricSamplingPercentageArrayType percent(levels);
  const double voxels = double(fixed->GetLargestPossibleRegion().GetNumberOfPixels());
  for (int l = 0; l < levels; ++l) {
    const int factor = 1 << (levels - 1 - l);
    shrink[l] = factor;
    sigmas[l] = 0.5 * factor * kWorkingSpacingMm * (factor > 1);
    percent[l] = std::min(1.0, kSamplesPerLevel * factor * factor * factor / voxels);
  }
  registration->SetNumberOfLevels(levels);
  registration->SetShrinkFactorsPerLevel(shrink);
  registration->SetSmoothingSigmasPerLevel(sigmas);
  registration->SmoothingSigmasAreSpecifiedInPhysicalUnitsOn();
  registration->SetMetricSamplingStrategy(RegistrationType::MetricSamplingStrategyEnum::RANDOM);
  registration->SetMetricSamplingPercentagePerLevel(percent);
  registration->MetricSamplingReinitializeSeed(int(o.seed));

  RegistrationStage stage;
  stage.name = name;
  try {
    registration->Update();
  } catch (const itk::ExceptionObject& e) {
    std::string d = e.GetDescription();
    while (!d.empty() && (d.back() == '\n' || d.back() == ' ')) d.pop_back();
    throw InputError(std::string("registration, ") + name + " stage: " + d +
                     " (do the target and the model's atlas image overlap?)");
  }
  stage.metric = optimizer->GetValue();
  stage.iterations = int(optimizer->GetCurrentIteration());
  stage.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (o.log)
    o.log(std::string("registration: ") + name + " stage, Mattes MI " + fmt(stage.metric) + " after " +
          std::to_string(stage.iterations) + " iterations (" + fmt(stage.seconds) + " s)");
  return stage;
}
}  // namespace

namespace {
// ITK on one thread while the registration's objects are made and run. With more, the transform
// differs in its last digits from run to run (ITK 5.2's Mattes metric adds the threads' joint-PDF
// derivatives into a shared buffer in whatever order its mutex is taken, and capping the metric's
// work units alone did not make it repeat), and the segmentation after it by up to 0.1 mm ASSD per
// structure. Objects take the global default when they are made, so the others are not affected.
// Registrations in one process run one at a time, so that each restores what it found. Other ITK
// objects made meanwhile (a label map still being read) also get one thread: slower, not wrong.
class SerialItk {
public:
  SerialItk() : lock_(mutex()), before_(itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads()) {
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(1);
  }
  ~SerialItk() { itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(before_); }
  SerialItk(const SerialItk&) = delete;
  SerialItk& operator=(const SerialItk&) = delete;

private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
  itk::ThreadIdType before_;
};
}  // namespace

RegistrationResult registerImagesItk(const Image3D& target, const Image3D& model, const RegistrationOptions& o) {
  const SerialItk serial;
  const ImageType::Pointer fixed = binned(target), moving = binned(model);
  RegistrationResult result;

  auto rigid = RigidType::New();
  using Initializer = itk::CenteredTransformInitializer<RigidType, ImageType, ImageType>;
  auto init = Initializer::New();
  init->SetTransform(rigid);
  init->SetFixedImage(fixed);
  init->SetMovingImage(moving);
  init->MomentsOn();
  init->InitializeTransform();

  // The metric before any optimisation: the stages must end better than this, or they diverged.
  double before = 0.0;
  {
    auto probe = MetricType::New();
    probe->SetNumberOfHistogramBins(o.histogramBins);
    try {
      before = metricValue(probe, rigid, fixed, moving);
    } catch (const itk::ExceptionObject& e) {
      std::string d = e.GetDescription();
      while (!d.empty() && (d.back() == '\n' || d.back() == ' ')) d.pop_back();
      throw InputError("registration, initial alignment: Mattes MI cannot be evaluated (" + d +
                       "): do the target and the model's atlas image overlap, and does the target hold an image?");
    }
  }
  result.stages.push_back(runStage("rigid", rigid.GetPointer(), fixed, moving, o, 2.0));
  Eigen::Matrix4d m = toMatrix(*rigid);
  if (o.affine) {
    auto affine = AffineType::New();
    affine->SetCenter(rigid->GetCenter());
    affine->SetMatrix(rigid->GetMatrix());
    affine->SetTranslation(rigid->GetTranslation());
    result.stages.push_back(runStage("affine", affine.GetPointer(), fixed, moving, o, 1.0));
    m = toMatrix(*affine);
  }
  const RegistrationStage& last = result.stages.back();
  // Mattes MI is negative; near 0 means the images share no information where they overlap.
  if (!std::isfinite(last.metric) || !m.allFinite() || last.metric > before + 1e-4 || last.metric > -0.02)
    throw InputError("registration, " + last.name + " stage: the metric diverged (Mattes MI " + fmt(last.metric) +
                     ", " + fmt(before) + " before registration)");
  const double det = m.topLeftCorner<3, 3>().determinant();
  if (!(det > 0.4 && det < 2.5))
    throw InputError("registration, " + last.name + " stage: implausible result (volume scale " + fmt(det) +
                     ", Mattes MI " + fmt(last.metric) + ")");
  result.targetToModel = m;
  return result;
}

Eigen::Matrix4d readAffineTransform(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path.string() + ": no such transform file");
  itk::TransformFactoryBase::RegisterDefaultTransforms();
  auto reader = itk::TransformFileReaderTemplate<double>::New();
  reader->SetFileName(path.string());
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InputError(path.string() + ": cannot read the transform: " + std::string(e.GetDescription()));
  }
  const auto* list = reader->GetTransformList();
  if (list->size() != 1)
    throw InputError(path.string() + ": holds " + std::to_string(list->size()) + " transforms; one affine is needed");
  const auto* t = dynamic_cast<const itk::MatrixOffsetTransformBase<double, 3, 3>*>(list->front().GetPointer());
  if (!t)
    throw InputError(path.string() + ": transform '" + list->front()->GetNameOfClass() +
                     "' is not affine (rigid, similarity and affine 3D transforms are read)");
  const Eigen::Matrix4d m = toMatrix(*t);
  if (!m.allFinite() || std::abs(m.topLeftCorner<3, 3>().determinant()) < 1e-9)
    throw InputError(path.string() + ": the transform is singular or not finite");
  return m;
}

void writeAffineTransform(const fs::path& path, const Eigen::Matrix4d& m) {
  auto t = AffineType::New();
  AffineType::MatrixType matrix;
  AffineType::OutputVectorType offset;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) matrix[r][c] = m(r, c);
    offset[r] = m(r, 3);
  }
  t->SetMatrix(matrix);
  t->SetOffset(offset);
  AtomicOutput out(path);
  auto writer = itk::TransformFileWriterTemplate<double>::New();
  writer->SetInput(t);
  writer->SetFileName(out.tempPath().string());
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InputError(path.string() + ": cannot write the transform: " + std::string(e.GetDescription()));
  }
  out.commit();
}

}  // namespace sinew
