#include "itk_registration.h"

#include "itk_convert.h"
#include "itk_transforms.h"
#include "registration_pyramid.h"

#include <map>
#include <mutex>

#include <itkAffineTransform.h>
#include <itkBSplineTransform.h>
#include <itkBSplineTransformInitializer.h>
#include <itkBinShrinkImageFilter.h>
#include <itkCenteredTransformInitializer.h>
#include <itkImageRegistrationMethod.h>
#include <itkImageRegistrationMethodv4.h>
#include <itkLBFGSBOptimizer.h>
#include <itkLinearInterpolateImageFunction.h>
#include <itkMattesMutualInformationImageToImageMetric.h>
#include <itkMattesMutualInformationImageToImageMetricv4.h>
#include <itkMatrixOffsetTransformBase.h>
#include <itkMultiThreaderBase.h>
#include <itkRegistrationParameterScalesFromPhysicalShift.h>
#include <itkRegularStepGradientDescentOptimizerv4.h>
#include <itkResampleImageFilter.h>
#include <itkVersorRigid3DTransform.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <random>
#include <thread>

namespace sinew {

namespace {
namespace fs = std::filesystem;
using ImageType = RegistrationImage;
using RigidType = itk::VersorRigid3DTransform<double>;
using AffineType = itk::AffineTransform<double, 3>;
using BSplineType = itk::BSplineTransform<double, 3, 3>;
using MetricType = RegistrationMetric;
using OptimizerType = itk::RegularStepGradientDescentOptimizerv4<double>;
using Clock = std::chrono::steady_clock;

// ITK's global default number of threads for a scope, restored to what it was after. Objects take
// the global default when they are made (and so do the filters a filter makes for itself, whatever
// its own work units: GradientRecursiveGaussianImageFilter's smoothing and derivative filters).
class ItkDefaultThreads {
public:
  explicit ItkDefaultThreads(itk::ThreadIdType threads) : before_(itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads()) {
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(threads);
  }
  ~ItkDefaultThreads() { itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(before_); }
  itk::ThreadIdType before() const { return before_; }
  ItkDefaultThreads(const ItkDefaultThreads&) = delete;
  ItkDefaultThreads& operator=(const ItkDefaultThreads&) = delete;

private:
  itk::ThreadIdType before_;
};

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

ImageType::Pointer binned(const Image3D& v, itk::ThreadIdType threads) {
  const ImageType::Pointer image = itkViewOf(v);  // read only: no copy of a full-resolution atlas
  auto shrink = itk::BinShrinkImageFilter<ImageType, ImageType>::New();
  shrink->SetNumberOfWorkUnits(threads);
  shrink->SetInput(image);
  itk::BinShrinkImageFilter<ImageType, ImageType>::ShrinkFactorsType factors;
  for (int a = 0; a < 3; ++a)
    factors[a] = std::max<unsigned>(1, unsigned(std::lround(kWorkingSpacingMm / v.geometry().spacing[a])));
  shrink->SetShrinkFactors(factors);
  shrink->Update();
  return shrink->GetOutput();
}

double metricValue(MetricType* metric, itk::Transform<double, 3, 3>* transform, const PyramidLevel& finest) {
  metric->SetFixedImage(finest.fixed);
  metric->SetMovingImage(finest.moving);
  metric->SetMovingImageGradientFilter(finest.movingGradient);
  metric->SetMovingTransform(transform);
  metric->SetFixedImageMask(finest.sampled.mask);
  metric->Initialize();
  return metric->GetValue();
}

// One stage (rigid or affine) over the pyramid; the transform is optimised in place. Each level
// is a one-level ImageRegistrationMethodv4 on that level's images, with one metric and one
// optimizer for the stage, as a multi-level method would run them; its sampling seeds are the
// ones a multi-level method would take at that level (two per level: the points and their jitter).
template <class TransformType>
RegistrationStage runStage(const char* name, TransformType* transform, const std::vector<PyramidLevel>& pyramid,
                           const RegistrationOptions& o, OptimizerType* optimizer, MetricType* metric) {
  const auto t0 = Clock::now();
  using RegistrationType = itk::ImageRegistrationMethodv4<ImageType, ImageType, TransformType>;
  // A cancelled registration stops at the optimiser's next iteration (about 10 ms on the 2-core
  // machine with the default samples), not at the stage's end. Asked at every iteration, so that
  // an iteration after the stop would show (tst_registration).
  bool stopped = false;
  if (o.cancelled)
    optimizer->AddObserver(itk::IterationEvent(), [&](const itk::EventObject&) {
      if (o.cancelled()) stopped = true, optimizer->StopOptimization();
    });

  // The method draws over the whole grid and keeps what falls in the mask: the share is taken of the
  // mask's voxels, so that a level keeps about `samplesPerLevel`.
  const double voxels = pyramid.back().sampled.voxels;
  RegistrationStage stage;
  stage.name = name;
  for (std::size_t l = 0; l < pyramid.size(); ++l) {
    const PyramidLevel& level = pyramid[l];
    auto registration = RegistrationType::New();
    registration->SetFixedImage(level.fixed);
    registration->SetMovingImage(level.moving);
    metric->SetMovingImageGradientFilter(level.movingGradient);  // computed already: Initialize reuses it
    // The method takes the metric's virtual domain when it has one, which after a coarser level is
    // that level's shrunk grid: the full grid again, for the method to shrink.
    metric->SetVirtualDomainFromImage(level.fixed);
    metric->SetFixedImageMask(level.sampled.mask);
    registration->SetMetric(metric);
    registration->SetOptimizer(optimizer);
    registration->SetInitialTransform(transform);
    registration->InPlaceOn();
    typename RegistrationType::ShrinkFactorsArrayType shrink(1);
    typename RegistrationType::SmoothingSigmasArrayType sigmas(1);
    typename RegistrationType::MetricSamplingPercentageArrayType percent(1);
    shrink[0] = level.shrink;
    sigmas[0] = 0.0;  // smoothed in the pyramid
    percent[0] = std::min(1.0, double(o.samplesPerLevel) * std::pow(double(level.shrink), 3) / voxels);
    registration->SetNumberOfLevels(1);
    registration->SetShrinkFactorsPerLevel(shrink);
    registration->SetSmoothingSigmasPerLevel(sigmas);
    registration->SmoothingSigmasAreSpecifiedInPhysicalUnitsOn();
    registration->SetMetricSamplingStrategy(RegistrationType::MetricSamplingStrategyEnum::RANDOM);
    registration->SetMetricSamplingPercentagePerLevel(percent);
    registration->MetricSamplingReinitializeSeed(int(o.seed + 2 * l));
    try {
      registration->Update();
    } catch (const itk::ExceptionObject& e) {
      std::string d = e.GetDescription();
      while (!d.empty() && (d.back() == '\n' || d.back() == ' ')) d.pop_back();
      throw InputError(std::string("registration, ") + name + " stage: " + d +
                       " (do the target and the model's atlas image overlap?)");
    }
    if (stopped) throw RegistrationCancelled();
  }
  stage.metric = optimizer->GetValue();
  stage.iterations = int(optimizer->GetCurrentIteration());
  stage.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (o.log)
    o.log(std::string("registration: ") + name + " stage, Mattes MI " + fmt(stage.metric) + " after " +
          std::to_string(stage.iterations) + " iterations (" + fmt(stage.seconds) + " s)");
  return stage;
}

// A rigid or affine stage: regular steps, scaled by the parameters' physical shifts.
template <class TransformType>
RegistrationStage runLinearStage(const char* name, TransformType* transform, const std::vector<PyramidLevel>& pyramid,
                                 const RegistrationOptions& o, double initialStepMm) {
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
  return runStage(name, transform, pyramid, o, optimizer.GetPointer(), metric.GetPointer());
}

// The smallest determinant of the B-spline's Jacobian (I + the warp's gradient) accepted at the
// sampled points: below it the warp squeezes a region to a fifth of its volume or folds it, which
// a coarse mesh of an anatomy's smooth differences does not need.
constexpr double kLeastWarpDeterminant = 0.2;
constexpr double kBSplineBoundMm = 8.0; // the most a control point is displaced

// The B-spline stage's metric in this many parts, whatever the machine: ITK's v3 Mattes metric
// gives each part its own histograms and derivative and adds them up in the parts' order, so the
// result repeats exactly and is the same on every machine. On the H200's 16-thread host 8 parts
// took the stage from 0.74 s to 0.18 s (docs/accuracy.md).
constexpr itk::ThreadIdType kBSplineWorkUnits = 8;

// The B-spline stage, with ITK's classic (v3) registration: its Mattes metric evaluates a cubic
// B-spline from the 64 control points around each sample. The v4 metric takes a B-spline for a
// global transform, every parameter at every sample: with 4 cells its stage took 2.2-2.4 s on the
// 2-core machine, this one 0.2 s (docs/accuracy.md). The atlas image is resampled through the
// affine onto the target's grid first, so that the B-spline is optimised alone and the map is the
// affine after it. L-BFGS-B with every control point's displacement bounded (kBSplineBoundMm):
// Mattes MI has no term against folding, and bounded coefficients on a coarse mesh keep the warp
// smooth. On the pyramid's first level's images (the 2 mm grid smoothed by 2 mm with the default
// two levels): cells of 30-45 mm need no finer detail. On every thread (`threads`, what ITK had
// before SerialItk) in kBSplineWorkUnits parts, with a fixed random sample (the options' seed):
// runs repeat exactly. The metric's derivatives are implicit: explicit ones keep a histogram's
// derivative per part (bins^2 x parameters, 30 MB with 5 cells), whose clearing and summing set the
// time with more than one part.
RegistrationStage runBSplineStage(BSplineType* bspline, AffineType& affine, const PyramidLevel& level,
                                  const RegistrationOptions& o, itk::ThreadIdType threads) {
  const auto t0 = Clock::now();
  const ItkDefaultThreads all(threads);  // every filter and the metric below: each sums in a fixed order
  auto resample = itk::ResampleImageFilter<ImageType, ImageType>::New();
  resample->SetInput(level.moving);
  resample->SetTransform(&affine);
  resample->SetReferenceImage(level.fixed);
  resample->UseReferenceImageOn();
  resample->SetDefaultPixelValue(0.0f);
  resample->Update();
  using Metric3 = itk::MattesMutualInformationImageToImageMetric<ImageType, ImageType>;
  auto metric = Metric3::New();
  metric->SetNumberOfHistogramBins(o.histogramBins);
  metric->SetNumberOfSpatialSamples(itk::SizeValueType(o.bsplineSamples));
  metric->ReinitializeSeed(int(o.seed));
  metric->SetUseExplicitPDFDerivatives(false);
  metric->SetFixedImageMask(level.sampled.mask);  // v3 draws its samples until that many fall in it
  auto optimizer = itk::LBFGSBOptimizer::New();
  const unsigned parameters = bspline->GetNumberOfParameters();
  itk::LBFGSBOptimizer::BoundSelectionType select(parameters);
  itk::LBFGSBOptimizer::BoundValueType lower(parameters), upper(parameters);
  select.Fill(2);  // both bounds
  lower.Fill(-kBSplineBoundMm);
  upper.Fill(kBSplineBoundMm);
  optimizer->SetBoundSelection(select);
  optimizer->SetLowerBound(lower);
  optimizer->SetUpperBound(upper);
  optimizer->SetMaximumNumberOfIterations(unsigned(o.bsplineIterations));
  optimizer->SetMaximumNumberOfEvaluations(unsigned(2 * o.bsplineIterations));
  optimizer->SetMaximumNumberOfCorrections(5);
  optimizer->SetCostFunctionConvergenceFactor(1e7);
  optimizer->SetProjectedGradientTolerance(1e-6);
  optimizer->SetTrace(false);
  auto registration = itk::ImageRegistrationMethod<ImageType, ImageType>::New();
  registration->SetMetric(metric);
  registration->SetOptimizer(optimizer);
  registration->SetNumberOfWorkUnits(kBSplineWorkUnits);  // it sets the metric's when initialised
  registration->SetTransform(bspline);
  registration->SetInterpolator(itk::LinearInterpolateImageFunction<ImageType, double>::New());
  registration->SetFixedImage(level.fixed);
  registration->SetMovingImage(resample->GetOutput());
  registration->SetFixedImageRegion(level.fixed->GetBufferedRegion());
  const BSplineType::ParametersType identity = bspline->GetParameters();
  registration->SetInitialTransformParameters(identity);
  // A cancelled registration stops at the optimiser's next iteration. v3's L-BFGS-B has no stop:
  // the observer throws, between the metric's evaluations (on this thread, its parts done), and
  // the exception leaves through the method's update.
  if (o.cancelled)
    optimizer->AddObserver(itk::IterationEvent(), [&o](const itk::EventObject&) {
      if (o.cancelled()) throw RegistrationCancelled();
    });
  RegistrationStage stage;
  stage.name = "bspline";
  try {
    // Initialised once before the update as well: each initialisation draws the next random
    // sample (the seed counts up), and the measured settings (docs/accuracy.md) optimised on the
    // second.
    registration->Initialize();
    registration->Update();
    // Before and after on the same sample, the one optimised on. By value: the transform would
    // otherwise keep a reference to the method's array (the metric's GetValue sets the parameters
    // it is given, the identity's last).
    const BSplineType::ParametersType found = registration->GetLastTransformParameters();
    stage.startMetric = metric->GetValue(identity);
    stage.metric = metric->GetValue(found);
    bspline->SetParametersByValue(found);
  } catch (const itk::ExceptionObject& e) {
    std::string d = e.GetDescription();
    while (!d.empty() && (d.back() == '\n' || d.back() == ' ')) d.pop_back();
    throw InputError("registration, bspline stage: " + d);
  }
  stage.iterations = int(optimizer->GetCurrentIteration());
  stage.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (o.log)
    o.log("registration: bspline stage, Mattes MI " + fmt(stage.metric) + " (" + fmt(stage.startMetric) +
          " with the affine alone) after " + std::to_string(stage.iterations) + " iterations (" + fmt(stage.seconds) + " s)");
  return stage;
}

// A cubic B-spline over the target's domain, optimised on top of the affine (runBSplineStage),
// kept only when it improves its metric, squeezes no region and maps every point somewhere. Its
// result leaves as its control grid (bsplineWarpOf): the initialisation evaluates the map, affine
// after B-spline (target -> model), and its inverse in core (SpatialMap::warpThenAffine).
void refineByBSpline(AffineType& affine, ImageType* fixed, const std::vector<PyramidLevel>& pyramid,
                     const RegistrationOptions& o, RegistrationResult& result, itk::ThreadIdType threads) {
  auto bspline = BSplineType::New();
  auto init = itk::BSplineTransformInitializer<BSplineType, ImageType>::New();
  init->SetTransform(bspline);
  init->SetImage(fixed);
  BSplineType::MeshSizeType mesh;
  mesh.Fill(unsigned(o.bsplineCells));
  init->SetTransformDomainMeshSize(mesh);
  init->InitializeTransform();
  bspline->SetIdentity();
  RegistrationStage stage = runBSplineStage(bspline.GetPointer(), affine, pyramid.front(), o, threads);
  BSplineWarp warp = bsplineWarpOf(*bspline);
  const bool finite = warp.valid();
  // The warp's Jacobian determinant on a grid of 2 cells + 1 points per axis over the target, one
  // voxel in from its edges (where the transform's domain ends: past it ITK's map is the identity,
  // and BSplineWarp's continues the edge's displacement).
  const int n = 2 * o.bsplineCells + 1;
  const auto size = fixed->GetLargestPossibleRegion().GetSize();
  double least = 1e300;
  for (int k = 0; k < n && finite; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        itk::ContinuousIndex<double, 3> index;
        const int ijk[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) index[a] = 1.0 + double(size[a] - 3) * double(ijk[a]) / double(n - 1);
        ImageType::PointType x;
        fixed->TransformContinuousIndexToPhysicalPoint(index, x);
        Eigen::Matrix3d jac;
        warp.displacement({x[0], x[1], x[2]}, &jac);
        least = std::min(least, (Eigen::Matrix3d::Identity() + jac).determinant());
      }
  const bool better = std::isfinite(stage.metric) && stage.metric < stage.startMetric;
  const bool folds = !(least > kLeastWarpDeterminant);  // a NaN anywhere in the Jacobians too
  if (o.log && (!better || folds || !finite))
    o.log(std::string("registration: B-spline stage not kept (") +
          (!finite ? std::string("its coefficients are not finite")
           : folds ? "the warp squeezes or folds a region: least Jacobian determinant " + fmt(least)
                   : "Mattes MI " + fmt(stage.metric) + ", " + fmt(stage.startMetric) + " before it") +
          "); the affine alone places the model");
  stage.kept = better && !folds && finite;
  result.stages.push_back(stage);
  if (stage.kept) result.deformation = std::move(warp);
}
}  // namespace

namespace {
// The rigid stage's reach from the moments' alignment is about 20-25 degrees of head rotation
// (subject 201 turned by 21 degrees registered; turned by 34, its initialisation was 3.4 mm off
// on average and the run ended with exit 0; docs/accuracy.md, "Subjects on other grids, cut and
// turned"). So the start is searched first: the metric's value, on the pyramid's first
// (smoothest) level at kSearchPoints random points, for the moments' alignment turned about its
// centre by rotation vectors on a lattice of kSearchTurnDeg: the 26 around none, then, while the
// best start moves, the lattice points around the best, for at most kSearchRounds rounds (turns of
// up to 90 degrees about an axis). A rotation vector within the cube of half side 1.5
// kSearchTurnDeg around a lattice point lies within about 26 degrees of it.
// The metric does not always rank the right turn first (subject 214 turned by 42 degrees: third),
// so the rigid stage runs from none and from the kTurnedStarts best turns that beat none, no two
// of them neighbours on the lattice, and keeps the best end (docs/accuracy.md, "Heads turned
// further").
constexpr double kSearchTurnDeg = 30.0;
constexpr int kSearchPoints = 10000;
constexpr int kSearchRounds = 3;
constexpr int kLatticeReach = 3;  // lattice coordinates within -3..3: 90 degrees about an axis
constexpr std::size_t kTurnedStarts = 3;

using LatticePoint = std::array<int, 3>;

struct TurnedStart {
  RigidType::VersorType versor;
  double degrees = 0.0, metric = 0.0;
};
// The turns that beat none, best first (none if none does), from one search.
struct SearchedStarts {
  std::vector<TurnedStart> turns;
  double unturnedMetric = 0.0, seconds = 0.0;
  int evaluated = 0;
};

RigidType::VersorType latticeTurn(const LatticePoint& p, double* degrees) {
  itk::Vector<double, 3> axis;
  for (int a = 0; a < 3; ++a) axis[a] = p[a];
  *degrees = kSearchTurnDeg * axis.GetNorm();
  RigidType::VersorType turn;
  turn.Set(axis / axis.GetNorm(), *degrees * M_PI / 180.0);
  return turn;
}

// Values only, on every thread (the threads' joint histograms are summed in their order: the same
// on every run).
SearchedStarts searchRotation(const RigidType& start, const PyramidLevel& level, const RegistrationOptions& o,
                              itk::ThreadIdType threads) {
  const auto t0 = Clock::now();
  MetricType::Pointer metric;
  {
    const ItkDefaultThreads all(threads);
    metric = MetricType::New();
  }
  metric->SetNumberOfHistogramBins(o.histogramBins);
  auto points = MetricType::FixedSampledPointSetType::New();
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto size = level.fixed->GetLargestPossibleRegion().GetSize();
  const ForegroundMask* mask = level.sampled.mask;  // holds >= 2 % of the grid: about 50 draws a point at most
  for (int i = 0, drawn = 0; i < kSearchPoints && drawn < 100 * kSearchPoints; ++drawn) {
    itk::ContinuousIndex<double, 3> index;
    for (int a = 0; a < 3; ++a) index[a] = unit(rng) * double(size[a] - 1);
    ImageType::PointType p;
    level.fixed->TransformContinuousIndexToPhysicalPoint(index, p);
    if (mask && !mask->IsInsideInWorldSpace(p)) continue;  // the stages' samples too lie in it
    points->SetPoint(i++, p);
  }
  metric->SetFixedSampledPointSet(points);
  metric->SetUseSampledPointSet(true);
  auto trial = RigidType::New();
  trial->SetCenter(start.GetCenter());
  trial->SetTranslation(start.GetTranslation());
  trial->SetRotation(start.GetVersor());
  SearchedStarts out;
  try {
    out.unturnedMetric = metricValue(metric, trial, level);
  } catch (const itk::ExceptionObject&) {
    return out;  // the unturned start's own check (the probe) says why
  }
  out.evaluated = 1;
  // The metric at each lattice point visited; infinite where too few points fall in the atlas.
  std::map<LatticePoint, double> visited{{LatticePoint{0, 0, 0}, out.unturnedMetric}};
  LatticePoint centre{0, 0, 0}, best = centre;
  for (int round = 0; round < kSearchRounds; ++round) {
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b)
        for (int c = -1; c <= 1; ++c) {
          const LatticePoint p{centre[0] + a, centre[1] + b, centre[2] + c};
          if (std::abs(p[0]) > kLatticeReach || std::abs(p[1]) > kLatticeReach || std::abs(p[2]) > kLatticeReach ||
              visited.count(p))
            continue;
          double degrees;
          trial->SetRotation(latticeTurn(p, &degrees) * start.GetVersor());
          double value = std::numeric_limits<double>::infinity();
          try {
            value = metric->GetValue();
            ++out.evaluated;
          } catch (const itk::ExceptionObject&) {
          }
          visited[p] = value;
          if (value < visited[best]) best = p;
        }
    if (best == centre) break;
    centre = best;
  }
  std::vector<std::pair<double, LatticePoint>> ranked;
  for (const auto& [p, value] : visited)
    if (value < out.unturnedMetric) ranked.emplace_back(value, p);
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  std::vector<LatticePoint> taken;
  for (const auto& [value, p] : ranked) {
    const bool beside = std::any_of(taken.begin(), taken.end(), [&p = p](const LatticePoint& q) {
      return std::abs(p[0] - q[0]) <= 1 && std::abs(p[1] - q[1]) <= 1 && std::abs(p[2] - q[2]) <= 1;
    });
    if (beside) continue;
    taken.push_back(p);
    TurnedStart t;
    t.versor = latticeTurn(p, &t.degrees) * start.GetVersor();
    t.metric = value;
    out.turns.push_back(t);
    if (out.turns.size() == kTurnedStarts) break;
  }
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

// ITK on one thread while the registration's metric is made and run. With more threads in the v4
// metric (the rigid and affine stages), the transform differs in its last digits from run to run
// (ITK 5.2's v4 Mattes metric adds the threads' joint-PDF derivatives into a shared buffer in
// whatever order its mutex is taken, and capping the metric's work units alone did not make it
// repeat), and the segmentation after it by up to 0.1 mm ASSD per structure. What computes each
// voxel on its own (the pyramid's filters) or sums its threads in order (the probe's value, the
// B-spline stage's v3 metric) is made inside an ItkDefaultThreads of threadsBefore(): with one
// thread, each moving gradient took about 75 ms on the 2-core machine.
// Registrations in one process run one at a time, so that each restores what it found. Other ITK
// objects made meanwhile (a label map still being read) also get one thread: slower, not wrong.
class SerialItk {
public:
  SerialItk() : lock_(mutex()) {}
  itk::ThreadIdType threadsBefore() const { return one_.before(); }  // for what may use them
  SerialItk(const SerialItk&) = delete;
  SerialItk& operator=(const SerialItk&) = delete;

private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;  // before one_: set and restored under the lock
  ItkDefaultThreads one_{1};
};

// How many of the rigid stages run at once: one a thread the process has.
std::size_t stagesAtOnce(std::size_t stages, itk::ThreadIdType threads) {
  return std::min<std::size_t>(stages, std::max<itk::ThreadIdType>(1, threads));
}

// The rigid stage from each start, optimised in place. Each stage runs on one thread (SerialItk);
// where the process has more, up to that many stages run at once, each but the first on its own
// view of the pyramid. They share only the voxels they read, so each ends as it would alone, and
// their lines are logged in the starts' order; the first error in that order is thrown.
std::vector<RegistrationStage> runRigidStages(const std::vector<RigidType::Pointer>& starts,
                                              const std::vector<PyramidLevel>& pyramid, const RegistrationOptions& o,
                                              itk::ThreadIdType threads) {
  const std::size_t n = starts.size();
  std::vector<RegistrationStage> ends(n);
  std::vector<std::vector<std::string>> logs(n);
  std::vector<std::exception_ptr> errors(n);
  std::vector<std::vector<PyramidLevel>> views(stagesAtOnce(n, threads) - 1);
  for (std::vector<PyramidLevel>& view : views) view = viewOf(pyramid);
  std::atomic<std::size_t> next{0};
  const auto work = [&](const std::vector<PyramidLevel>& levels) {
    for (std::size_t i = next++; i < n; i = next++) {
      RegistrationOptions mine = o;
      mine.log = [&lines = logs[i]](const std::string& line) { lines.push_back(line); };
      try {
        ends[i] = runLinearStage("rigid", starts[i].GetPointer(), levels, mine, 2.0);
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
  };
  {
    std::vector<std::thread> helpers;
    struct JoinAll {  // also where starting a thread throws: none is left running
      std::vector<std::thread>& threads;
      ~JoinAll() {
        for (std::thread& t : threads) t.join();
      }
    } joinAll{helpers};
    for (const std::vector<PyramidLevel>& view : views) helpers.emplace_back(work, std::cref(view));
    work(pyramid);
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (o.log)
      for (const std::string& line : logs[i]) o.log(line);
    if (errors[i]) std::rethrow_exception(errors[i]);
  }
  return ends;
}

}  // namespace

RegistrationResult registerImagesItk(const Image3D& target, const Image3D& model, const RegistrationOptions& o) {
  const auto checkCancelled = [&o] {
    if (o.cancelled && o.cancelled()) throw RegistrationCancelled();
  };
  checkCancelled();
  const SerialItk serial;  // may wait for another registration: asked again after it
  checkCancelled();
  const itk::ThreadIdType threads = serial.threadsBefore();
  const ImageType::Pointer fixed = binned(target, threads), moving = binned(model, threads);
  checkCancelled();
  std::vector<PyramidLevel> pyramid;
  try {
    const ItkDefaultThreads all(threads);
    pyramid = pyramidOf(fixed, moving, o.levels, threads);
  } catch (const itk::ExceptionObject& e) {
    throw InputError(std::string("registration, smoothing the images: ") + e.GetDescription());
  }
  if (o.log)
    o.log(pyramid.front().sampled.mask ? "registration: the metric samples the target's foreground (" +
                                             fmt(100.0 * pyramid.front().sampled.share) + " % of its grid)"
                                       : std::string("registration: the metric samples the target's whole grid (no "
                                                     "foreground told apart from its background)"));
  checkCancelled();
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
    // Its value alone, on every thread: the threads' joint histograms are summed in their order
    // (only the derivatives' are not: the stages' metrics stay on one), and it only decides the
    // divergence check below.
    MetricType::Pointer probe;
    {
      const ItkDefaultThreads all(threads);
      probe = MetricType::New();
    }
    probe->SetNumberOfHistogramBins(o.histogramBins);
    try {
      before = metricValue(probe, rigid, pyramid.back());
    } catch (const itk::ExceptionObject& e) {
      std::string d = e.GetDescription();
      while (!d.empty() && (d.back() == '\n' || d.back() == ' ')) d.pop_back();
      throw InputError("registration, initial alignment: Mattes MI cannot be evaluated (" + d +
                       "): do the target and the model's atlas image overlap, and does the target hold an image?");
    }
  }
  // The rigid stage from the moments' alignment and from each turned start the search found: the
  // best end (by its metric) is kept; of equal ends, the first.
  const SearchedStarts searched = searchRotation(*rigid, pyramid.front(), o, threads);
  const RigidType::CenterType centre = rigid->GetCenter();
  const RigidType::TranslationType translation = rigid->GetTranslation();  // the moments', as the turns'
  if (o.log && !searched.turns.empty()) {
    std::string turns, values;
    for (std::size_t i = 0; i < searched.turns.size(); ++i) {
      const char* sep = i == 0 ? "" : i + 1 == searched.turns.size() ? " and " : ", ";
      turns += sep + fmt(searched.turns[i].degrees);
      values += sep + fmt(searched.turns[i].metric);
    }
    o.log("registration: rotation search (" + fmt(searched.seconds) + " s, " + std::to_string(searched.evaluated) +
          " starts): " + (searched.turns.size() == 1 ? "a start turned by " : "starts turned by ") + turns +
          " degrees have Mattes MI " + values + " against " + fmt(searched.unturnedMetric) +
          " unturned; the rigid stage from each");
  }
  std::vector<RigidType::Pointer> starts{rigid};
  for (const TurnedStart& start : searched.turns) {
    auto turned = RigidType::New();
    turned->SetCenter(centre);
    turned->SetTranslation(translation);
    turned->SetRotation(start.versor);
    starts.push_back(turned);
  }
  const auto rigidStarted = Clock::now();
  const std::vector<RegistrationStage> ends = runRigidStages(starts, pyramid, o, threads);
  RegistrationStage rigidStage = ends.front();
  if (!searched.turns.empty()) {
    const double fromNone = rigidStage.metric;
    double keptDegrees = 0.0;
    for (std::size_t i = 1; i < ends.size(); ++i)
      if (ends[i].metric < rigidStage.metric) {
        rigidStage = ends[i];
        keptDegrees = searched.turns[i - 1].degrees;
        rigid->SetParameters(starts[i]->GetParameters());  // the same centre
      }
    rigidStage.seconds = std::chrono::duration<double>(Clock::now() - rigidStarted).count();  // all of them, waited for
    if (o.log)
      o.log("registration: the rigid stage kept its end from the " +
            (keptDegrees > 0.0 ? "turned start (by " + fmt(keptDegrees) + " degrees)" : std::string("unturned start")) +
            " (Mattes MI " + fmt(rigidStage.metric) + ", " + fmt(fromNone) + " unturned; " + std::to_string(starts.size()) +
            " stages, " + std::to_string(stagesAtOnce(starts.size(), threads)) + " at a time, " + fmt(rigidStage.seconds) + " s)");
  }
  rigidStage.seconds += searched.seconds;
  result.stages.push_back(rigidStage);
  Eigen::Matrix4d m = toMatrix(*rigid);
  if (o.affine) {
    auto affine = AffineType::New();
    affine->SetCenter(rigid->GetCenter());
    affine->SetMatrix(rigid->GetMatrix());
    affine->SetTranslation(rigid->GetTranslation());
    result.stages.push_back(runLinearStage("affine", affine.GetPointer(), pyramid, o, 1.0));
    m = toMatrix(*affine);
    if (o.bsplineCells > 0) refineByBSpline(*affine, fixed, pyramid, o, result, threads);
  }
  const RegistrationStage& last = result.stages[o.affine ? 1 : 0];  // the affine's checks: the B-spline's are its own
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

}  // namespace sinew
