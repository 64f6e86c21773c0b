// The image plugin's registration against ITK's own multi-resolution method. The plugin builds
// its pyramid once (the smoothed images and the moving image's gradient per level, shared by the
// probe and both stages) and runs each level as a one-level ImageRegistrationMethodv4; that is
// only a saving if it gives what the multi-level method gives. This test runs the multi-level
// method itself (rigid, then affine, as the plugin did before the pyramid was shared) on Colin27
// (mricron-data) moved by a known rotation and shift, and requires the same matrix. The B-spline
// stage is checked against a known warp, and core's evaluation of its map against ITK's.
#include "synthetic.h"
#include "../../plugins/image_io_itk/itk_transforms.h"
#include "../../plugins/image_io_itk/itk_convert.h"
#include "../../plugins/image_io_itk/registration_mask.h"
#include "sinew/core/scene.h"
#include "sinew/core/spatial_map.h"

#include <QTemporaryDir>
#include <QtTest>

#include <itkAffineTransform.h>
#include <itkCompositeTransform.h>
#include <itkBinShrinkImageFilter.h>
#include <itkCenteredTransformInitializer.h>
#include <itkImageRegistrationMethodv4.h>
#include <itkMattesMutualInformationImageToImageMetricv4.h>
#include <itkImageRegionIteratorWithIndex.h>
#include <itkMultiThreaderBase.h>
#include <itkRegistrationParameterScalesFromPhysicalShift.h>
#include <itkRegularStepGradientDescentOptimizerv4.h>
#include <itkVersorRigid3DTransform.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <filesystem>
#include <random>

using namespace sinew;
using namespace sinew::testing;

namespace {

const std::filesystem::path kTemplates = "/usr/share/mricron/templates";
using ImageType = itk::Image<float, 3>;
using MetricType = itk::MattesMutualInformationImageToImageMetricv4<ImageType, ImageType>;
using OptimizerType = itk::RegularStepGradientDescentOptimizerv4<double>;

ImageType::Pointer binnedTo2mm(const Image3D& v) {
  auto shrink = itk::BinShrinkImageFilter<ImageType, ImageType>::New();
  shrink->SetInput(toItk<float>(v));
  itk::BinShrinkImageFilter<ImageType, ImageType>::ShrinkFactorsType factors;
  for (int a = 0; a < 3; ++a) factors[a] = std::max<unsigned>(1, unsigned(std::lround(2.0 / v.geometry().spacing[a])));
  shrink->SetShrinkFactors(factors);
  shrink->Update();
  return shrink->GetOutput();
}

// ITK's multi-level method over two levels (virtual domain shrunk by 2 and smoothed by 2 mm, then
// the 2 mm grid); samples a level, bins, iterations and seed from the options, drawn in the fixed
// image's foreground (`sampled`, as the plugin takes it).
template <class TransformType>
void multiLevelStage(TransformType* transform, ImageType* fixed, ImageType* moving, double step,
                     const RegistrationOptions& o, const SampledRegion& sampled) {
  using RegistrationType = itk::ImageRegistrationMethodv4<ImageType, ImageType, TransformType>;
  auto metric = MetricType::New();
  metric->SetNumberOfHistogramBins(o.histogramBins);
  auto optimizer = OptimizerType::New();
  auto scales = itk::RegistrationParameterScalesFromPhysicalShift<MetricType>::New();
  scales->SetMetric(metric);
  optimizer->SetScalesEstimator(scales);
  optimizer->SetLearningRate(step);
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
  metric->SetFixedImageMask(sampled.mask);
  const double voxels = sampled.voxels;
  typename RegistrationType::ShrinkFactorsArrayType shrink(2);
  typename RegistrationType::SmoothingSigmasArrayType sigmas(2);
  typename RegistrationType::MetricSamplingPercentageArrayType percent(2);
  shrink[0] = 2, shrink[1] = 1;
  sigmas[0] = 2.0, sigmas[1] = 0.0;
  const double samples = o.samplesPerLevel;
  percent[0] = std::min(1.0, samples * 8 / voxels), percent[1] = std::min(1.0, samples / voxels);
  registration->SetNumberOfLevels(2);
  registration->SetShrinkFactorsPerLevel(shrink);
  registration->SetSmoothingSigmasPerLevel(sigmas);
  registration->SmoothingSigmasAreSpecifiedInPhysicalUnitsOn();
  registration->SetMetricSamplingStrategy(RegistrationType::MetricSamplingStrategyEnum::RANDOM);
  registration->SetMetricSamplingPercentagePerLevel(percent);
  registration->MetricSamplingReinitializeSeed(int(o.seed));
  registration->Update();
}

Eigen::Matrix4d multiLevelRegistration(const Image3D& target, const Image3D& model, const RegistrationOptions& o) {
  const auto threads = itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads();
  itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(1);  // as the plugin's metric runs
  const ImageType::Pointer fixed = binnedTo2mm(target), moving = binnedTo2mm(model);
  auto rigid = itk::VersorRigid3DTransform<double>::New();
  auto init = itk::CenteredTransformInitializer<itk::VersorRigid3DTransform<double>, ImageType, ImageType>::New();
  init->SetTransform(rigid);
  init->SetFixedImage(fixed);
  init->SetMovingImage(moving);
  init->MomentsOn();
  init->InitializeTransform();
  const SampledRegion sampled = foregroundOf(fixed, 1);
  multiLevelStage(rigid.GetPointer(), fixed, moving, 2.0, o, sampled);
  auto affine = itk::AffineTransform<double, 3>::New();
  affine->SetCenter(rigid->GetCenter());
  affine->SetMatrix(rigid->GetMatrix());
  affine->SetTranslation(rigid->GetTranslation());
  multiLevelStage(affine.GetPointer(), fixed, moving, 1.0, o, sampled);
  itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(threads);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m(r, c) = affine->GetMatrix()[r][c];
    m(r, 3) = affine->GetOffset()[r];
  }
  return m;
}

}  // namespace

class TestRegistration : public QObject {
  Q_OBJECT

private slots:
  void sharedPyramidGivesTheMultiLevelMethodsResult() {
    if (!std::filesystem::exists(kTemplates / "ch2.nii.gz")) QSKIP("mricron-data is not installed");
    const ImageIODescriptor& io = builtinRegistry().imageIOFor("ch2.nii.gz");
    Image3D target = io.readImage(kTemplates / "ch2.nii.gz");
    const Image3D model = io.readImage(kTemplates / "ch2better.nii.gz");
    // The target moved: 6 degrees about the axis (1, 2, 3) and (5, -4, 3) mm, so that both stages
    // have work at both levels.
    ImageGeometry g = target.geometry();
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(6.0 * M_PI / 180.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    g.direction = turn * g.direction;
    g.origin = turn * g.origin + Eigen::Vector3d(5, -4, 3);
    Image3D moved(g);
    moved.voxels() = target.voxels();
    target = std::move(moved);

    RegistrationOptions options;  // the defaults: rigid then affine, 2 levels (the oracle's shape)
    QCOMPARE(options.levels, 2);
    QVERIFY(options.affine);
    const RegistrationResult plugin = io.registerImages(target, model, options);
    const Eigen::Matrix4d reference = multiLevelRegistration(target, model, options);
    const double difference = (plugin.targetToModel - reference).cwiseAbs().maxCoeff();
    qInfo("largest difference from ITK's multi-level method: %.3g (translation %.2f mm, %d + %d iterations)",
          difference, plugin.targetToModel.block<3, 1>(0, 3).norm(), plugin.stages[0].iterations,
          plugin.stages[1].iterations);
    QVERIFY2(difference <= 1e-9, qPrintable(QString::number(difference)));
    // Not a trivial agreement: the registration undid most of the move.
    const Eigen::Matrix3d undone = plugin.targetToModel.topLeftCorner<3, 3>() * turn;
    QVERIFY2((undone - Eigen::Matrix3d::Identity()).norm() < 0.05, "the rotation is not undone");
  }

  // Where the metric samples: ch2's head with its ventricles (holes filled), not the air at the grid's
  // corners; an image without a background, all of it; the same mask on any number of threads.
  void metricSamplesTheForeground() {
    if (!std::filesystem::exists(kTemplates / "ch2.nii.gz")) QSKIP("mricron-data is not installed");
    const Image3D ch2 = builtinRegistry().imageIOFor("ch2.nii.gz").readImage(kTemplates / "ch2.nii.gz");
    const ImageType::Pointer fixed = binnedTo2mm(ch2);
    const SampledRegion head = foregroundOf(fixed, 1);
    QVERIFY(head.mask);
    qInfo("ch2's foreground: %.1f %% of its 2 mm grid", 100.0 * head.share);
    QVERIFY(head.share > 0.3 && head.share < 0.8);
    // The voxels it counts (from its own coarser grid, 8 image voxels to a mask voxel) are the image
    // voxels whose centres it holds, counted one by one; and its fast answer is ITK's general one.
    double counted = 0.0;
    int disagree = 0;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> jitter(-0.5, 0.5);
    for (itk::ImageRegionIteratorWithIndex<ImageType> it(fixed, fixed->GetLargestPossibleRegion()); !it.IsAtEnd(); ++it) {
      ImageType::PointType centre, near;
      fixed->TransformIndexToPhysicalPoint(it.GetIndex(), centre);
      counted += head.mask->IsInsideInWorldSpace(centre);
      itk::ContinuousIndex<double, 3> off;
      for (int a = 0; a < 3; ++a) off[a] = double(it.GetIndex()[a]) + jitter(rng);
      fixed->TransformContinuousIndexToPhysicalPoint(off, near);
      disagree += head.mask->IsInsideInWorldSpace(near) != head.mask->itk::ImageMaskSpatialObject<3>::IsInsideInWorldSpace(near);
    }
    QCOMPARE(head.voxels, counted);
    QCOMPARE(disagree, 0);
    const auto inside = [&](const Vec3& index) {
      const Vec3 w = ch2.indexToWorld(index);
      ImageType::PointType p;
      for (int a = 0; a < 3; ++a) p[a] = w[a];
      return head.mask->IsInsideInWorldSpace(p);
    };
    QVERIFY(inside(Vec3(90, 108, 90)));  // the brain's centre
    QVERIFY(!inside(Vec3(2, 2, 2)) && !inside(Vec3(178, 214, 178)));
    const SampledRegion again = foregroundOf(fixed, 4);
    QCOMPARE(again.voxels, head.voxels);
    // A dark cavity enclosed by bright tissue (a ventricle, CSF dark in T1, here 16 mm across, wider
    // than the 4 mm growth reaches) is filled: a shell of radius 8-24 mm in a 100 mm box of air.
    auto shell = ImageType::New();
    ImageType::RegionType box;
    box.SetSize({{50, 50, 50}});
    shell->SetRegions(box);
    ImageType::SpacingType two;
    two.Fill(2.0);
    shell->SetSpacing(two);
    shell->Allocate();
    for (itk::ImageRegionIteratorWithIndex<ImageType> it(shell, box); !it.IsAtEnd(); ++it) {
      double r2 = 0.0;
      for (int a = 0; a < 3; ++a) r2 += std::pow(2.0 * (double(it.GetIndex()[a]) - 25.0), 2);
      it.Set(r2 >= 8.0 * 8.0 && r2 <= 24.0 * 24.0 ? 100.0f : 2.0f);
    }
    const SampledRegion filled = foregroundOf(shell, 1);
    QVERIFY(filled.mask);
    ImageType::PointType middle, corner;
    middle.Fill(50.0);
    corner.Fill(2.0);
    QVERIFY(filled.mask->IsInsideInWorldSpace(middle));
    QVERIFY(!filled.mask->IsInsideInWorldSpace(corner));
    // A constant image has no foreground to tell apart: every voxel is sampled.
    auto flat = ImageType::New();
    flat->CopyInformation(fixed);
    flat->SetRegions(fixed->GetLargestPossibleRegion());
    flat->Allocate();
    flat->FillBuffer(5.0f);
    const SampledRegion all = foregroundOf(flat, 1);
    QVERIFY(!all.mask);
    QCOMPARE(all.voxels, double(fixed->GetLargestPossibleRegion().GetNumberOfPixels()));
  }

  // A head turned beyond the rigid stage's reach from the moments' alignment: ch2 turned by 40
  // degrees (a turn of the search's first ring), and by 65 degrees (beyond it: the search climbs on,
  // where the first ring alone left brain points 43 mm off). The rotation search must
  // find a start from which the rigid stage undoes the turn (the registration says so in its log),
  // and the map must then put brain points within 1.5 mm of where they belong.
  void rotationSearchReachesATurnedHead_data() {
    QTest::addColumn<double>("degrees");
    QTest::addColumn<double>("x");
    QTest::addColumn<double>("y");
    QTest::addColumn<double>("z");
    QTest::newRow("40 degrees") << 40.0 << 1.0 << 0.5 << -0.3;
    QTest::newRow("65 degrees") << 65.0 << -0.5 << 0.1 << 0.9;
  }
  void rotationSearchReachesATurnedHead() {
    if (!std::filesystem::exists(kTemplates / "ch2.nii.gz")) QSKIP("mricron-data is not installed");
    QFETCH(double, degrees);
    QFETCH(double, x);
    QFETCH(double, y);
    QFETCH(double, z);
    const ImageIODescriptor& io = builtinRegistry().imageIOFor("ch2.nii.gz");
    const Image3D original = io.readImage(kTemplates / "ch2.nii.gz");
    const Image3D model = io.readImage(kTemplates / "ch2better.nii.gz");
    ImageGeometry g = original.geometry();
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(degrees * M_PI / 180.0, Eigen::Vector3d(x, y, z).normalized()).toRotationMatrix();
    g.direction = turn * g.direction;
    g.origin = turn * g.origin;
    Image3D target(g);
    target.voxels() = original.voxels();
    std::vector<std::string> log;
    RegistrationOptions options;
    options.log = [&](const std::string& line) { log.push_back(line); };
    // With 4 threads the rigid stages from the search's starts run at once, each on its own view of
    // the pyramid; with 1, one after another. The same ends either way, to the bit.
    const auto before = itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads();
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(4);
    const RegistrationResult r = io.registerImages(target, model, options);
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(1);
    RegistrationOptions alone;
    const RegistrationResult one = io.registerImages(target, model, alone);
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(before);
    QVERIFY2(r.targetToModel == one.targetToModel, "the rigid stages at once ended elsewhere than one after another");
    QCOMPARE(r.stages.size(), one.stages.size());
    for (std::size_t k = 0; k < r.stages.size(); ++k) QCOMPARE(r.stages[k].metric, one.stages[k].metric);
    const auto said = [&](const char* text) {
      return std::any_of(log.begin(), log.end(), [&](const std::string& l) { return l.find(text) != std::string::npos; });
    };
    for (const auto& l : log) qInfo("%s", l.c_str());
    QVERIFY(said("rotation search"));
    QVERIFY(said("kept its end from the turned start"));
    QVERIFY2(!said(" 1 at a time"), "with 4 threads the stages ran one after another");
    // The target's point turn * q shows the model's point q.
    double largest = 0.0;
    const Eigen::Vector3d centre = original.indexToWorld(Vec3(90, 108, 90)).cast<double>();
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b)
        for (int c = -1; c <= 1; ++c) {
          const Eigen::Vector3d q = centre + 30.0 * Eigen::Vector3d(a, b, c);
          const Eigen::Vector4d mapped = r.targetToModel * (turn * q).homogeneous();
          largest = std::max(largest, (mapped.head<3>() - q).norm());
        }
    qInfo("largest error within 52 mm of the brain's centre: %.2f mm", largest);
    QVERIFY2(largest < 1.5, qPrintable(QString::number(largest)));
  }

  // The B-spline stage on top of the affine: Colin27 (ch2) pushed by a smooth bump of 6 mm at the
  // brain's centre is the target, ch2better the model. Around the centre, the inverse of the
  // stage's map (what the initialisation places the model with) must put model points far closer
  // to where the bump put them than the affine alone can. With another number of threads, the
  // stage must find the same warp.
  void bsplineStageFollowsASmoothWarp() {
    if (!std::filesystem::exists(kTemplates / "ch2.nii.gz")) QSKIP("mricron-data is not installed");
    const ImageIODescriptor& io = builtinRegistry().imageIOFor("ch2.nii.gz");
    const Image3D original = io.readImage(kTemplates / "ch2.nii.gz");
    const Image3D model = io.readImage(kTemplates / "ch2better.nii.gz");
    const ImageGeometry& g = original.geometry();
    const Vec3 centre = original.indexToWorld(Vec3(g.size[0] / 2.0f, g.size[1] / 2.0f, g.size[2] / 2.0f));
    const Eigen::Vector3d direction = Eigen::Vector3d(1.0, -0.6, 0.4).normalized();
    // The target's point x shows the original's point x + bump(x).
    const auto bump = [&](const Eigen::Vector3d& x) {
      return Eigen::Vector3d(6.0 * std::exp(-(x - centre.cast<double>()).squaredNorm() / (2.0 * 30.0 * 30.0)) * direction);
    };
    Image3D target(g);
    for (int k = 0; k < g.size[2]; ++k)
      for (int j = 0; j < g.size[1]; ++j)
        for (int i = 0; i < g.size[0]; ++i) {
          const Eigen::Vector3d x = original.indexToWorld(Vec3(i, j, k)).cast<double>();
          target.voxels()[target.offset(i, j, k)] = original.sample((x + bump(x)).cast<float>());
        }
    RegistrationOptions options;
    options.bsplineCells = kDefaultBSplineCells;
    const RegistrationResult r = io.registerImages(target, model, options);
    QCOMPARE(int(r.stages.size()), 3);
    QCOMPARE(QString::fromStdString(r.stages[2].name), QString("bspline"));
    QVERIFY2(r.stages[2].kept, "the B-spline stage was not kept");
    QVERIFY(r.stages[2].metric < r.stages[2].startMetric);
    QVERIFY(r.deformation.valid());
    QCOMPARE(r.deformation.size[0], kDefaultBSplineCells + 3);
    const SpatialMap affine = SpatialMap::affine(r.targetToModel.inverse());
    const SpatialMap forward = SpatialMap::warpThenAffine(r.deformation, r.targetToModel);
    const SpatialMap spline = forward.inverse();
    double affineError = 0.0, splineError = 0.0;
    int n = 0;
    for (int a = -2; a <= 2; ++a)
      for (int b = -2; b <= 2; ++b)
        for (int c = -2; c <= 2; ++c) {
          const Eigen::Vector3d y = centre.cast<double>() + 8.0 * Eigen::Vector3d(a, b, c);  // a model point
          Eigen::Vector3d x = y;  // where the target shows it: x + bump(x) = y
          for (int it = 0; it < 50; ++it) x = y - bump(x);
          affineError += (affine.apply(y) - x).norm();
          splineError += (spline.apply(y) - x).norm();
          QVERIFY((forward.apply(spline.apply(y)) - y).norm() < 1e-6);  // the inverse is one
          ++n;
        }
    affineError /= n;
    splineError /= n;
    qInfo("mean error within 16 mm of the bump's centre: affine %.3f mm, with the B-spline %.3f mm (%.2f s)",
          affineError, splineError, r.stages[2].seconds);
    QVERIFY2(affineError > 1.5, "the bump must be beyond an affine map for the test to mean anything");
    QVERIFY2(splineError < 0.5 * affineError, qPrintable(QString("%1 against %2").arg(splineError).arg(affineError)));

    // The stage's metric runs in a fixed number of parts on whatever threads ITK has: on one
    // thread it must find the same coefficients, to the last bit.
    const auto threads = itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads();
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(threads == 1 ? 3 : 1);
    const RegistrationResult again = io.registerImages(target, model, options);
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(threads);
    QVERIFY(again.deformation.coefficients == r.deformation.coefficients);
    QCOMPARE(again.stages[2].metric, r.stages[2].metric);
  }

  // Core evaluates the B-spline stage's map without ITK (BSplineWarp has ITK's layout): for a
  // transform over an oblique, anisotropic domain with random coefficients, the displacement and
  // its Jacobian must be ITK's TransformPoint's inside the domain; outside it, where ITK gives the
  // identity, the displacement is ITK's at the domain's nearest point (BSplineWarp: no jump at the edge).
  // The warp must go back to ITK and through a transform file unchanged.
  void bsplineWarpEvaluatesAsItk() {
    using BSpline = itk::BSplineTransform<double, 3, 3>;
    auto t = BSpline::New();
    BSpline::PhysicalDimensionsType extent;
    BSpline::MeshSizeType mesh;
    BSpline::OriginType origin;
    for (int a = 0; a < 3; ++a) {
      extent[a] = 120.0 + 30.0 * a;
      mesh[a] = unsigned(3 + a);
      origin[a] = -60.0 + 7.0 * a;
    }
    BSpline::DirectionType direction;
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) direction[r][c] = turn(r, c);
    t->SetTransformDomainOrigin(origin);
    t->SetTransformDomainPhysicalDimensions(extent);
    t->SetTransformDomainMeshSize(mesh);
    t->SetTransformDomainDirection(direction);
    BSpline::ParametersType p(t->GetNumberOfParameters());
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> coefficient(-6.0, 6.0), position(-90.0, 140.0);
    for (unsigned i = 0; i < p.GetSize(); ++i) p[i] = coefficient(rng);
    t->SetParametersByValue(p);
    const BSplineWarp warp = bsplineWarpOf(*t);
    QVERIFY(warp.valid());
    int inside = 0;
    double largest = 0.0, largestJacobian = 0.0, largestPast = 0.0;
    for (int i = 0; i < 3000; ++i) {
      const Eigen::Vector3d x(position(rng), position(rng), position(rng));
      BSpline::InputPointType px;
      for (int a = 0; a < 3; ++a) px[a] = x[a];
      const auto y = t->TransformPoint(px);
      Eigen::Matrix3d jac;
      const Eigen::Vector3d d = warp.displacement(x, &jac);
      if (Eigen::Vector3d(y[0] - x[0], y[1] - x[1], y[2] - x[2]).norm() == 0.0) {
        // Outside: ITK at the nearest point, a billionth of a cell in (at the edge itself, a
        // round trip through the index could leave it outside for ITK).
        itk::ContinuousIndex<double, 3> index;
        const auto grid = t->GetCoefficientImages()[0];  // a copy: the array is returned by value
        grid->TransformPhysicalPointToContinuousIndex(px, index);
        for (int a = 0; a < 3; ++a)
          index[a] = std::clamp(index[a], 1.0 + 1e-9, double(grid->GetLargestPossibleRegion().GetSize()[a]) - 2.0 - 1e-9);
        BSpline::InputPointType nearest;
        grid->TransformContinuousIndexToPhysicalPoint(index, nearest);
        const auto moved = t->TransformPoint(nearest) - nearest;
        largestPast = std::max(largestPast, (Eigen::Vector3d(moved[0], moved[1], moved[2]) - d).norm());
        continue;
      }
      largest = std::max(largest, (Eigen::Vector3d(y[0], y[1], y[2]) - (x + d)).norm());
      ++inside;
      for (int a = 0; a < 3; ++a) {  // central differences of ITK's map
        BSpline::InputPointType lo = px, hi = px;
        lo[a] -= 1e-4;
        hi[a] += 1e-4;
        const auto diff = t->TransformPoint(hi) - t->TransformPoint(lo);
        for (int r = 0; r < 3; ++r)
          largestJacobian = std::max(largestJacobian, std::abs(diff[r] / 2e-4 - (jac(r, a) + (r == a ? 1.0 : 0.0))));
      }
    }
    qInfo("%d of 3000 points inside the domain; largest difference from ITK %.3g mm, in the Jacobian %.3g, "
          "outside from ITK's at the nearest point %.3g mm", inside, largest, largestJacobian, largestPast);
    QVERIFY2(inside > 500 && inside < 2500, "the points must fall both inside and outside the domain");
    QVERIFY2(largest < 1e-9, qPrintable(QString::number(largest)));
    QVERIFY2(largestPast < 1e-6, qPrintable(QString::number(largestPast)));
    QVERIFY2(largestJacobian < 1e-5, qPrintable(QString::number(largestJacobian)));

    // Back to ITK, and through a transform file (a composite: the affine, then the B-spline added
    // last, which ITK applies first): the same grid and coefficients.
    const BSplineWarp back = bsplineWarpOf(*bsplineTransformOf(warp));
    QCOMPARE(back.size, warp.size);
    QVERIFY((back.origin - warp.origin).norm() < 1e-9 && (back.spacing - warp.spacing).norm() < 1e-9 &&
            (back.direction - warp.direction).norm() < 1e-12);
    QVERIFY(back.coefficients == warp.coefficients);
    QTemporaryDir dir;
    const std::filesystem::path file = dir.filePath("map.tfm").toStdString();
    RegistrationTransform written;
    written.targetToModel << 1.02, 0.05, -0.01, 3.5, -0.04, 0.98, 0.02, -7.25, 0.01, -0.03, 1.01, 0.125, 0, 0, 0, 1;
    written.deformation = warp;
    writeRegistrationTransform(file, written);
    const RegistrationTransform read = readRegistrationTransform(file);
    QCOMPARE(read.targetToModel, written.targetToModel);
    QCOMPARE(read.deformation.size, warp.size);
    QVERIFY(read.deformation.coefficients == warp.coefficients);
    QVERIFY((read.deformation.origin - warp.origin).norm() < 1e-9);
    // The composite the writer writes does to a point of the B-spline's domain (the registration's
    // target) what Sinew's map does.
    const auto composite = itkTransformOf(read);
    QVERIFY((dynamic_cast<const itk::CompositeTransform<double, 3>*>(composite.GetPointer())));
    const SpatialMap map = SpatialMap::warpThenAffine(read.deformation, read.targetToModel);
    double largestMap = 0.0;
    int inDomain = 0;
    for (int i = 0; i < 600; ++i) {
      const Eigen::Vector3d x(position(rng), position(rng), position(rng));
      const itk::Point<double, 3> p(x.data());
      if (t->TransformPoint(p) == p) continue;  // outside the domain
      ++inDomain;
      const auto y = composite->TransformPoint(p);
      largestMap = std::max(largestMap, (Eigen::Vector3d(y[0], y[1], y[2]) - map.apply(x)).norm());
    }
    QVERIFY(inDomain > 50);
    QVERIFY2(largestMap < 1e-9, qPrintable(QString::number(largestMap)));
    // An affine alone stays a plain affine file; a composite of two affines is refused.
    written.deformation = BSplineWarp{};
    writeRegistrationTransform(file, written);
    QVERIFY(readRegistrationTransform(file).deformation.empty());
    QFile plain(QString::fromStdString(file.string()));
    QVERIFY(plain.open(QIODevice::ReadOnly) && !plain.readAll().contains("Composite"));
    {
      QFile twoAffines(QString::fromStdString(file.string()));
      QVERIFY(twoAffines.open(QIODevice::WriteOnly | QIODevice::Truncate));
      const char* identity = "Transform: AffineTransform_double_3_3\nParameters: 1 0 0 0 1 0 0 0 1 0 0 0\nFixedParameters: 0 0 0\n";
      twoAffines.write(QByteArray("#Insight Transform File V1.0\n#Transform 0\nTransform: CompositeTransform_double_3_3\n") +
                       "#Transform 1\n" + identity + "#Transform 2\n" + identity);
    }
    try {
      readRegistrationTransform(file);
      QFAIL("a composite of two affines was read");
    } catch (const InputError& e) {
      QVERIFY2(std::string(e.what()).find("is not a cubic 3D B-spline") != std::string::npos, e.what());
      QVERIFY2(std::string(e.what()).find(file.string()) == 0, e.what());
    }
  }

  // A run whose loading fails cancels its registration (scene_runner_loaded.h): it must stop at the
  // next question, not at the end of the stage. Counted: how often a whole registration asks, then
  // a registration cancelled at its first question and one cancelled at its sixth (the rigid
  // stage's second iteration at the coarse level) must throw RegistrationCancelled and ask no more
  // (the optimiser asks at every iteration, so one more iteration after the stop would count). The
  // B-spline stage likewise.
  void cancelledRegistrationStopsAtTheNextQuestion() {
    if (!std::filesystem::exists(kTemplates / "ch2.nii.gz")) QSKIP("mricron-data is not installed");
    const ImageIODescriptor& io = builtinRegistry().imageIOFor("ch2.nii.gz");
    const Image3D target = io.readImage(kTemplates / "ch2.nii.gz");
    const Image3D model = io.readImage(kTemplates / "ch2better.nii.gz");
    int asked = 0;
    RegistrationOptions options;
    options.cancelled = [&asked] { return ++asked < 0; };
    io.registerImages(target, model, options);
    const int whole = asked;
    qInfo("a whole registration asks %d times", whole);
    // Both stages' iterations at both levels: far more than the stops below.
    QVERIFY2(whole > 30, qPrintable(QString::number(whole)));
    for (const int at : {1, 6}) {
      asked = 0;
      options.cancelled = [&asked, at] { return ++asked >= at; };
      QVERIFY_THROWS_EXCEPTION(RegistrationCancelled, io.registerImages(target, model, options));
      QCOMPARE(asked, at);
    }
    // The B-spline stage asks at each of its iterations too, and stops at the one asked: here a
    // few iterations into it.
    asked = 0;
    options.bsplineCells = kDefaultBSplineCells;
    options.cancelled = [&asked] { return ++asked < 0; };
    io.registerImages(target, model, options);
    const int withBSpline = asked;
    qInfo("with the B-spline stage, %d times", withBSpline);
    QVERIFY2(withBSpline > whole + 10, qPrintable(QString("%1 against %2").arg(withBSpline).arg(whole)));
    asked = 0;
    options.cancelled = [&asked, at = whole + 3] { return ++asked >= at; };
    QVERIFY_THROWS_EXCEPTION(RegistrationCancelled, io.registerImages(target, model, options));
    QCOMPARE(asked, whole + 3);
  }

  // The optimiser's metrics run on one thread (their threads' derivative sums would not repeat),
  // while the pyramid's filters and the probe are made with every thread (itk_registration.cpp's
  // ItkDefaultThreads): the global default is 1 again at every question after the first (asked before
  // SerialItk lowers it), and what it was before once the registration returns.
  void stagesRunOnOneThread() {
    if (!std::filesystem::exists(kTemplates / "ch2.nii.gz")) QSKIP("mricron-data is not installed");
    const ImageIODescriptor& io = builtinRegistry().imageIOFor("ch2.nii.gz");
    const Image3D target = io.readImage(kTemplates / "ch2.nii.gz");
    const Image3D model = io.readImage(kTemplates / "ch2better.nii.gz");
    const auto before = itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads();
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(4);
    std::vector<itk::ThreadIdType> seen;
    RegistrationOptions options;
    options.cancelled = [&seen] {
      seen.push_back(itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads());
      return false;
    };
    io.registerImages(target, model, options);
    const auto after = itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads();
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(before);
    QCOMPARE(after, itk::ThreadIdType(4));
    QVERIFY(seen.size() > 30);
    QCOMPARE(seen.front(), itk::ThreadIdType(4));
    for (std::size_t k = 1; k < seen.size(); ++k)
      QVERIFY2(seen[k] == 1, qPrintable(QString("question %1: %2 threads").arg(k).arg(seen[k])));
  }
};

QTEST_APPLESS_MAIN(TestRegistration)
#include "tst_registration.moc"
