// sinew-make-subject: a seeded synthetic subject for tests and benchmarks. An image and its label
// map are moved by one random transform (a global affine about the image centre composed with a
// smooth B-spline warp) and the image gets a bias field, a gamma change and Rician noise. One RNG
// draws everything in a fixed order, so a seed gives byte-identical outputs. ITK only: no
// sinew_core, so it can make data for any test without the engine.
#include "nifti_sform.h"

#include <itkAffineTransform.h>
#include <itkBSplineTransform.h>
#include <itkCastImageFilter.h>
#include <itkCompositeTransform.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOFactory.h>
#include <itkImageRegionIteratorWithIndex.h>
#include <itkLinearInterpolateImageFunction.h>
#include <itkMetaImageIOFactory.h>
#include <itkMinimumMaximumImageCalculator.h>
#include <itkNearestNeighborInterpolateImageFunction.h>
#include <itkNiftiImageIO.h>
#include <itkNiftiImageIOFactory.h>
#include <itkNrrdImageIOFactory.h>
#include <itkResampleImageFilter.h>
#include <itkVersor.h>
#include <itk_zlib.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <set>

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;
using Image = itk::Image<float, 3>;
using Labels = itk::Image<int32_t, 3>;

namespace {

// ITK 5.2's NIfTI reader zero-fills a truncated .gz without an error: read the stream through once.
void checkGzip(const std::string& path) {
  if (path.size() < 3 || path.compare(path.size() - 3, 3, ".gz") != 0) return;
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) throw std::runtime_error(path + ": cannot open");
  std::vector<char> buffer(1 << 16);
  int n;
  while ((n = gzread(f, buffer.data(), unsigned(buffer.size()))) > 0) continue;
  if (gzclose(f) != Z_OK || n < 0) throw std::runtime_error(path + ": truncated or corrupt gzip data");
}

// Reads a scalar 3D image, checking what ITK would otherwise silently adapt (a 2D or 4D file read
// into a 3D image, a vector image). Returns the file's component type so labels keep theirs.
template <typename TImage>
typename TImage::Pointer readVolume(const std::string& path, itk::IOComponentEnum* componentType = nullptr) {
  if (!fs::exists(path)) throw std::runtime_error(path + ": no such file");
  if (!fs::is_regular_file(path)) throw std::runtime_error(path + ": not a regular file");
  checkGzip(path);
  auto io = itk::ImageIOFactory::CreateImageIO(path.c_str(), itk::IOFileModeEnum::ReadMode);
  if (!io) throw std::runtime_error(path + ": not a readable image (NIfTI, NRRD or MetaImage)");
  auto reader = itk::ImageFileReader<TImage>::New();
  try {
    io->SetFileName(path);
    io->ReadImageInformation();
    if (io->GetNumberOfDimensions() != 3)
      throw std::runtime_error(path + ": expected a 3D image, got " + std::to_string(io->GetNumberOfDimensions()) + "D");
    if (io->GetNumberOfComponents() != 1) throw std::runtime_error(path + ": expected a scalar image");
    if (componentType) *componentType = io->GetComponentType();
    reader->SetImageIO(io);
    reader->SetFileName(path);
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw std::runtime_error(path + ": cannot read (" + std::string(e.GetDescription()) + ")");
  }
  typename TImage::Pointer image = reader->GetOutput();
  image->DisconnectPipeline();
  // Placed as Sinew's image IO places it (its sform where ITK took a qform that differs).
  if (dynamic_cast<itk::NiftiImageIO*>(io.GetPointer()))
    if (const auto sform = sinew::nifti::sformPlacement(path, image->GetSpacing(), {image->GetOrigin(), image->GetDirection()})) {
      image->SetOrigin(sform->origin);
      image->SetDirection(sform->direction);
    }
  return image;
}

// Writes through ITK (which picks the format by extension, hence the ".nii.gz" suffix) into a
// hidden temporary in the output folder; rename() later makes each file appear whole.
template <typename TImage>
void writeVolume(const TImage* image, const fs::path& path) {
  auto writer = itk::ImageFileWriter<TImage>::New();
  writer->SetInput(image);
  writer->SetFileName(path.string());
  writer->SetUseCompression(true);
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw std::runtime_error(path.string() + ": cannot write (" + e.GetDescription() + ")");
  }
}

// Labels are written in the input's integer type (aal.nii.gz is uint8); wider types go to int32.
template <typename T>
void writeLabelsAs(const Labels* labels, const fs::path& path) {
  auto cast = itk::CastImageFilter<Labels, itk::Image<T, 3>>::New();
  cast->SetInput(labels);
  cast->Update();
  writeVolume(cast->GetOutput(), path);
}

void writeLabels(const Labels* labels, itk::IOComponentEnum type, const fs::path& path) {
  switch (type) {
    case itk::IOComponentEnum::UCHAR: return writeLabelsAs<uint8_t>(labels, path);
    case itk::IOComponentEnum::CHAR: return writeLabelsAs<int8_t>(labels, path);
    case itk::IOComponentEnum::USHORT: return writeLabelsAs<uint16_t>(labels, path);
    case itk::IOComponentEnum::SHORT: return writeLabelsAs<int16_t>(labels, path);
    default: return writeLabelsAs<int32_t>(labels, path);
  }
}

// Largest and mean warp displacement (mm) on every 4th voxel of the grid: dense enough for a warp
// with ~5 control intervals per axis, and 64 times cheaper than every voxel.
std::pair<double, double> measureWarp(const itk::Transform<double, 3, 3>& warp, const Image* grid) {
  const auto size = grid->GetLargestPossibleRegion().GetSize();
  double maxD = 0, sum = 0;
  size_t count = 0;
  Image::IndexType idx;
  for (idx[2] = 0; idx[2] < Image::IndexValueType(size[2]); idx[2] += 4)
    for (idx[1] = 0; idx[1] < Image::IndexValueType(size[1]); idx[1] += 4)
      for (idx[0] = 0; idx[0] < Image::IndexValueType(size[0]); idx[0] += 4) {
        Image::PointType p;
        grid->TransformIndexToPhysicalPoint(idx, p);
        const double d = (warp.TransformPoint(p) - p).GetNorm();
        maxD = std::max(maxD, d);
        sum += d;
        ++count;
      }
  return {maxD, count ? sum / double(count) : 0.0};
}

// b(u) with u the voxel index mapped to [-1, 1] per axis: the 9 monomials of degree 1 and 2 (a
// constant term would be a global gain, not a bias).
double biasPolynomial(const std::array<double, 9>& c, const Image::IndexType& idx, const Image::SizeType& size) {
  double u[3];
  for (int d = 0; d < 3; ++d) u[d] = size[d] > 1 ? 2.0 * double(idx[d]) / double(size[d] - 1) - 1.0 : 0.0;
  return c[0] * u[0] + c[1] * u[1] + c[2] * u[2] + c[3] * u[0] * u[0] + c[4] * u[1] * u[1] + c[5] * u[2] * u[2] +
         c[6] * u[0] * u[1] + c[7] * u[0] * u[2] + c[8] * u[1] * u[2];
}

// The direction matrix of an orientation code: three letters, one per index axis, each naming where
// that axis points (L/R, P/A, S/I; NIfTI's convention, e.g. RAS). ITK's physical space is LPS.
Image::DirectionType directionOf(const std::string& code) {
  Image::DirectionType d;
  d.Fill(0.0);
  bool used[3] = {false, false, false};
  if (code.size() != 3) throw std::invalid_argument("--axes " + code + ": expected three letters (e.g. RAS)");
  for (int i = 0; i < 3; ++i) {
    const char c = char(std::toupper(static_cast<unsigned char>(code[size_t(i)])));
    const std::string letters = "LRPASI";
    const auto at = letters.find(c);
    if (at == std::string::npos) throw std::invalid_argument("--axes " + code + ": letters are L, R, P, A, S or I");
    const int axis = int(at) / 2;
    if (used[axis]) throw std::invalid_argument("--axes " + code + ": each of L/R, P/A and S/I once");
    used[axis] = true;
    d(axis, i) = at % 2 == 0 ? 1.0 : -1.0;  // L, P, S: ITK's +x, +y, +z
  }
  return d;
}

// The subject's acquisition grid: `direction` and `spacing`, covering the centres of the image's
// voxels (the box of its corners in the new axes), so that nothing of the image is cut; then the
// central `fov` share of that box along each of the grid's axes (a smaller field of view).
struct Grid {
  Image::PointType origin;
  Image::SpacingType spacing;
  Image::DirectionType direction;
  Image::SizeType size;
};
Grid gridCovering(const Image* image, const Image::SpacingType& spacing, const Image::DirectionType& direction,
                  const double fov[3]) {
  const auto size = image->GetLargestPossibleRegion().GetSize();
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (int corner = 0; corner < 8; ++corner) {
    Image::IndexType idx;
    for (int d = 0; d < 3; ++d) idx[d] = (corner >> d) & 1 ? Image::IndexValueType(size[d]) - 1 : 0;
    Image::PointType p;
    image->TransformIndexToPhysicalPoint(idx, p);
    for (int a = 0; a < 3; ++a) {  // p along the new grid's axis a
      const double along = direction(0, a) * p[0] + direction(1, a) * p[1] + direction(2, a) * p[2];
      lo[a] = std::min(lo[a], along);
      hi[a] = std::max(hi[a], along);
    }
  }
  for (int a = 0; a < 3; ++a) {
    const double middle = 0.5 * (lo[a] + hi[a]), half = 0.5 * fov[a] * (hi[a] - lo[a]);
    lo[a] = middle - half;
    hi[a] = middle + half;
  }
  Grid g;
  g.spacing = spacing;
  g.direction = direction;
  for (int r = 0; r < 3; ++r) g.origin[r] = direction(r, 0) * lo[0] + direction(r, 1) * lo[1] + direction(r, 2) * lo[2];
  for (int a = 0; a < 3; ++a) g.size[a] = Image::SizeValueType(std::floor((hi[a] - lo[a]) / spacing[a] + 1e-9)) + 1;
  return g;
}

template <typename TFilter>
void setGrid(TFilter* filter, const Grid& g) {
  filter->SetOutputOrigin(g.origin);
  filter->SetOutputSpacing(g.spacing);
  filter->SetOutputDirection(g.direction);
  filter->SetSize(g.size);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"sinew-make-subject: write a seeded synthetic subject (moved image and labels, intensity changes)."};
  std::string imagePath, labelsPath, output;
  unsigned seed = 1;
  double warpMm = 4.0, maxRotation = 6.0, maxTranslation = 4.0, scaleMin = 0.93, scaleMax = 1.07;
  double bias = 0.2, contrast = 0.2, noise = 0.03;
  std::vector<double> gridSpacing, fieldOfView;
  std::string axes;
  double tiltDeg = 0.0, intensityScale = 1.0;
  cli.add_option("--image", imagePath, "scalar 3D image (the model's intensities)")->required();
  cli.add_option("--labels", labelsPath, "its integer label map (resampled onto the image's grid)")->required();
  cli.add_option("--seed", seed, "seed of every random draw")->capture_default_str();
  cli.add_option("-o,--output", output, "folder: image.nii.gz, labels.nii.gz, subject.json")->required();
  cli.add_option("--warp-mm", warpMm, "largest displacement of the smooth B-spline warp")->capture_default_str();
  cli.add_option("--max-rotation-deg", maxRotation, "largest rotation of the affine")->capture_default_str();
  cli.add_option("--max-translation-mm", maxTranslation, "largest translation of the affine")->capture_default_str();
  cli.add_option("--scale-min", scaleMin, "smallest scale per axis")->capture_default_str();
  cli.add_option("--scale-max", scaleMax, "largest scale per axis")->capture_default_str();
  cli.add_option("--bias", bias, "multiplicative bias field: max |log gain| = log(1 + bias)")->capture_default_str();
  cli.add_option("--contrast", contrast, "gamma drawn in [1/(1+c), 1+c]")->capture_default_str();
  cli.add_option("--noise", noise, "Rician noise sigma as a fraction of the image range")->capture_default_str();
  cli.add_option("--spacing", gridSpacing, "the subject's voxel size, mm, three values SX,SY,SZ (default: the image's)")
      ->expected(3)
      ->delimiter(',');
  cli.add_option("--axes", axes,
                 "where the subject's index axes point: three letters of L/R, P/A, S/I (NIfTI's convention, e.g. RAS; "
                 "default: the image's directions)");
  cli.add_option("--fov", fieldOfView,
                 "the share of the image's extent that the subject's grid keeps along each of its axes, centred, three "
                 "values in (0, 1] (default: 1,1,1)")
      ->expected(3)
      ->delimiter(',');
  cli.add_option("--tilt-deg", tiltDeg, "the subject's grid turned by this angle about a random axis (an oblique scan)")
      ->capture_default_str();
  cli.add_option("--intensity-scale", intensityScale, "the subject's intensities multiplied by this (another scanner's units)")
      ->capture_default_str();
  cli.set_version_flag("--version", std::string("sinew-make-subject ") + SINEW_VERSION);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;
  }
  const auto badOption = [](const std::string& what) {
    std::cerr << "sinew-make-subject: error: " << what << "\n";
    return 2;
  };
  if (!(warpMm >= 0)) return badOption("--warp-mm: must be >= 0");
  if (!(maxRotation >= 0 && maxRotation <= 180)) return badOption("--max-rotation-deg: must be in [0, 180]");
  if (!(maxTranslation >= 0)) return badOption("--max-translation-mm: must be >= 0");
  if (!(scaleMin > 0 && scaleMin <= scaleMax)) return badOption("--scale-min/--scale-max: need 0 < min <= max");
  if (!(bias >= 0)) return badOption("--bias: must be >= 0");
  if (!(contrast >= 0)) return badOption("--contrast: must be >= 0");
  if (!(noise >= 0)) return badOption("--noise: must be >= 0");
  for (double v : gridSpacing)
    if (!(v > 0 && v <= 100)) return badOption("--spacing: each voxel size must be in (0, 100] mm");
  for (double v : fieldOfView)
    if (!(v > 0 && v <= 1)) return badOption("--fov: each share must be in (0, 1]");
  if (!(tiltDeg >= 0 && tiltDeg <= 180)) return badOption("--tilt-deg: must be in [0, 180]");
  if (!(intensityScale > 0 && std::isfinite(intensityScale))) return badOption("--intensity-scale: must be > 0");
  Image::DirectionType axesDirection;
  try {
    if (!axes.empty()) axesDirection = directionOf(axes);
  } catch (const std::invalid_argument& e) {
    return badOption(e.what());
  }

  // Explicit registration: this program does not use ITK_USE_FILE's generated factory manager.
  itk::NiftiImageIOFactory::RegisterOneFactory();
  itk::NrrdImageIOFactory::RegisterOneFactory();
  itk::MetaImageIOFactory::RegisterOneFactory();

  const fs::path dir(output);
  std::vector<fs::path> temps;
  try {
    // Read and check both inputs before anything is written ("PATH: problem", exit 3).
    const Image::Pointer image = readVolume<Image>(imagePath);
    itk::IOComponentEnum labelType{};
    const Labels::Pointer labels = readVolume<Labels>(labelsPath, &labelType);
    if (labelType == itk::IOComponentEnum::FLOAT || labelType == itk::IOComponentEnum::DOUBLE)
      throw std::runtime_error(labelsPath + ": expected integer labels, got " +
                               itk::ImageIOBase::GetComponentTypeAsString(labelType));
    const bool labelsOnImageGrid =
        labels->GetLargestPossibleRegion() == image->GetLargestPossibleRegion() &&
        labels->GetOrigin() == image->GetOrigin() && labels->GetSpacing() == image->GetSpacing() &&
        labels->GetDirection() == image->GetDirection();
    auto range = itk::MinimumMaximumImageCalculator<Image>::New();
    range->SetImage(image);
    range->Compute();
    const double lo = range->GetMinimum(), hi = range->GetMaximum(), span = std::max(hi - lo, 1e-12);

    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const auto direction = [&] {
      itk::Vector<double, 3> d;
      for (int i = 0; i < 3; ++i) d[i] = gauss(rng);
      return d / d.GetNorm();
    };

    // Global affine about the image centre, in the resampler's convention (subject -> model).
    Image::PointType centre;
    itk::ContinuousIndex<double, 3> mid;
    for (int d = 0; d < 3; ++d) mid[d] = 0.5 * double(image->GetLargestPossibleRegion().GetSize()[d] - 1);
    image->TransformContinuousIndexToPhysicalPoint(mid, centre);
    const auto axis = direction();
    const double angleDeg = maxRotation * unit(rng);
    const auto shift = direction() * (maxTranslation * unit(rng));
    itk::Versor<double> rotation;
    rotation.Set(axis, angleDeg * M_PI / 180.0);
    double scales[3];
    for (double& s : scales) s = scaleMin + (scaleMax - scaleMin) * unit(rng);
    auto matrix = rotation.GetMatrix();  // R * diag(scales): scale along the image axes, then rotate
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) matrix(r, c) *= scales[c];
    auto affine = itk::AffineTransform<double, 3>::New();
    affine->SetCenter(centre);
    affine->SetMatrix(matrix);
    affine->SetTranslation(shift);

    // Smooth warp over the image's physical domain. A displacement is linear in the coefficients,
    // so scaling them by warp / measured max makes the measured max exactly --warp-mm.
    using BSpline = itk::BSplineTransform<double, 3, 3>;
    auto warp = BSpline::New();
    BSpline::PhysicalDimensionsType extent;
    for (int d = 0; d < 3; ++d) extent[d] = image->GetSpacing()[d] * double(image->GetLargestPossibleRegion().GetSize()[d] - 1);
    BSpline::MeshSizeType mesh;
    mesh.Fill(5);
    warp->SetTransformDomainOrigin(image->GetOrigin());
    warp->SetTransformDomainDirection(image->GetDirection());
    warp->SetTransformDomainPhysicalDimensions(extent);
    warp->SetTransformDomainMeshSize(mesh);
    BSpline::ParametersType coefficients(warp->GetNumberOfParameters());
    for (unsigned i = 0; i < coefficients.size(); ++i) coefficients[i] = gauss(rng);
    warp->SetParametersByValue(coefficients);
    const double unitMax = measureWarp(*warp, image).first;
    coefficients *= unitMax > 0 ? warpMm / unitMax : 0.0;
    warp->SetParametersByValue(coefficients);
    const auto [warpMax, warpMean] = measureWarp(*warp, image);

    // A composite applies its last-added transform first: y = A(x + w(x)).
    auto transform = itk::CompositeTransform<double, 3>::New();
    transform->AddTransform(affine);
    transform->AddTransform(warp);

    // The subject's grid: the image's, or another acquisition's (--spacing, --axes, --tilt-deg,
    // --fov). The tilt's axis comes from an RNG of its own, so that every other draw of a seed stays
    // the same.
    const bool ownGrid = !gridSpacing.empty() || !fieldOfView.empty() || !axes.empty() || tiltDeg > 0;
    Image::DirectionType gridDirection = axes.empty() ? image->GetDirection() : axesDirection;
    itk::Vector<double, 3> tiltAxis;
    tiltAxis.Fill(0.0);
    if (tiltDeg > 0) {
      std::mt19937 tiltRng(seed ^ 0x5bd1e995u);
      std::normal_distribution<double> tiltGauss(0.0, 1.0);
      for (int i = 0; i < 3; ++i) tiltAxis[i] = tiltGauss(tiltRng);
      tiltAxis /= tiltAxis.GetNorm();
      itk::Versor<double> tilt;
      tilt.Set(tiltAxis, tiltDeg * M_PI / 180.0);
      gridDirection = tilt.GetMatrix() * gridDirection;
    }
    Image::SpacingType spacing = image->GetSpacing();
    if (!gridSpacing.empty())
      for (int d = 0; d < 3; ++d) spacing[d] = gridSpacing[size_t(d)];
    double fov[3] = {1.0, 1.0, 1.0};
    for (std::size_t d = 0; d < fieldOfView.size(); ++d) fov[d] = fieldOfView[d];
    const Grid grid = gridCovering(image, spacing, gridDirection, fov);

    // Both on the subject's grid with the same transform; the labels straight from their own grid
    // (one nearest-neighbour lookup, so values stay exact), the image linearly, background = min.
    auto moveImage = itk::ResampleImageFilter<Image, Image>::New();
    moveImage->SetInput(image);
    moveImage->SetTransform(transform);
    moveImage->SetInterpolator(itk::LinearInterpolateImageFunction<Image, double>::New());
    if (ownGrid)
      setGrid(moveImage.GetPointer(), grid);
    else
      moveImage->SetOutputParametersFromImage(image);
    moveImage->SetDefaultPixelValue(float(lo));
    auto moveLabels = itk::ResampleImageFilter<Labels, Labels>::New();
    moveLabels->SetInput(labels);
    moveLabels->SetTransform(transform);
    moveLabels->SetInterpolator(itk::NearestNeighborInterpolateImageFunction<Labels, double>::New());
    if (ownGrid)
      setGrid(moveLabels.GetPointer(), grid);
    else
      moveLabels->SetOutputParametersFromImage(image);
    moveLabels->SetDefaultPixelValue(0);
    moveImage->Update();
    moveLabels->Update();
    const Image::Pointer subject = moveImage->GetOutput();
    const Labels::Pointer subjectLabels = moveLabels->GetOutput();

    // Intensities, in the subject's space: gamma on [0, 1], then the bias field, then Rician noise.
    std::array<double, 9> biasCoeff;
    for (double& c : biasCoeff) c = gauss(rng);
    const double gammaLo = 1.0 / (1.0 + contrast), gamma = gammaLo + (1.0 + contrast - gammaLo) * unit(rng);
    const auto size = subject->GetLargestPossibleRegion().GetSize();
    double biasMax = 0;
    for (itk::ImageRegionIteratorWithIndex<Image> it(subject, subject->GetLargestPossibleRegion()); !it.IsAtEnd(); ++it)
      biasMax = std::max(biasMax, std::abs(biasPolynomial(biasCoeff, it.GetIndex(), size)));
    const double biasScale = biasMax > 0 ? std::log(1.0 + bias) / biasMax : 0.0;
    for (double& c : biasCoeff) c *= biasScale;
    const double sigma = noise * (hi - lo);
    for (itk::ImageRegionIteratorWithIndex<Image> it(subject, subject->GetLargestPossibleRegion()); !it.IsAtEnd(); ++it) {
      const double t = std::clamp((double(it.Get()) - lo) / span, 0.0, 1.0);
      double v = (lo + span * std::pow(t, gamma)) * std::exp(biasPolynomial(biasCoeff, it.GetIndex(), size));
      if (sigma > 0) {
        const double n1 = sigma * gauss(rng), n2 = sigma * gauss(rng);
        v = std::sqrt((v + n1) * (v + n1) + n2 * n2);
      }
      it.Set(float(v * intensityScale));
    }

    // Labels pushed wholly out of the field of view (or too thin to survive nearest neighbour).
    const auto values = [](const Labels* l) {
      const int32_t* p = l->GetBufferPointer();
      return std::set<int32_t>(p, p + l->GetLargestPossibleRegion().GetNumberOfPixels());
    };
    const auto before = values(labels), after = values(subjectLabels);
    Json lost = Json::array();
    for (int32_t v : before)
      if (!after.count(v)) lost.push_back(v);

    Json json;
    json["tool"] = std::string("sinew-make-subject ") + SINEW_VERSION;
    json["seed"] = seed;
    json["inputs"] = {{"image", fs::absolute(imagePath).lexically_normal().string()},
                      {"labels", fs::absolute(labelsPath).lexically_normal().string()},
                      {"labels_resampled_from_own_grid", !labelsOnImageGrid}};
    json["parameters"] = {{"warp_mm", warpMm}, {"max_rotation_deg", maxRotation}, {"max_translation_mm", maxTranslation},
                          {"scale_min", scaleMin}, {"scale_max", scaleMax}, {"bias", bias}, {"contrast", contrast},
                          {"noise", noise}, {"intensity_scale", intensityScale}};
    const auto& gd = subject->GetDirection();
    Json directionRows = Json::array();
    for (int r = 0; r < 3; ++r) directionRows.push_back({gd(r, 0), gd(r, 1), gd(r, 2)});
    json["grid"] = {{"size", {size[0], size[1], size[2]}},
                    {"spacing_mm", {subject->GetSpacing()[0], subject->GetSpacing()[1], subject->GetSpacing()[2]}},
                    {"origin_mm", {subject->GetOrigin()[0], subject->GetOrigin()[1], subject->GetOrigin()[2]}},
                    {"direction", directionRows}, {"axes", axes.empty() ? Json(nullptr) : Json(axes)},
                    {"field_of_view", {fov[0], fov[1], fov[2]}}, {"tilt_deg", tiltDeg}, {"tilt_axis", {tiltAxis[0], tiltAxis[1], tiltAxis[2]}}};
    json["convention"] =
        "ITK physical coordinates (LPS, mm). A subject point x (a voxel of the outputs) maps to the model point "
        "y = A(x + w(x)) of the inputs (ResampleImageFilter's output-to-input convention): w, the B-spline warp, "
        "first, then the affine A given as a 4x4 homogeneous matrix.";
    Json rows = Json::array();
    for (int r = 0; r < 3; ++r) rows.push_back({matrix(r, 0), matrix(r, 1), matrix(r, 2), affine->GetOffset()[r]});
    rows.push_back({0.0, 0.0, 0.0, 1.0});
    json["affine"] = {{"matrix", rows}, {"centre_mm", {centre[0], centre[1], centre[2]}},
                      {"rotation_axis", {axis[0], axis[1], axis[2]}}, {"rotation_deg", angleDeg},
                      {"translation_mm", {shift[0], shift[1], shift[2]}}, {"scale", {scales[0], scales[1], scales[2]}}};
    json["warp"] = {{"kind", "cubic B-spline over the image domain"}, {"mesh_size", {mesh[0], mesh[1], mesh[2]}},
                    {"max_displacement_mm", warpMax}, {"mean_displacement_mm", warpMean},
                    {"measured_on", "every 4th voxel of the image grid"}};
    json["intensity"] = {{"gamma", gamma}, {"bias_max_log_gain", std::log(1.0 + bias)}, {"noise_sigma", sigma},
                         {"input_range", {lo, hi}}};
    json["labels_lost"] = lost;

    // All three into temporaries first, then the renames: a failed write leaves the folder as it was.
    fs::create_directories(dir);
    const std::string tag = ".tmp-" + std::to_string(getpid()) + "-";
    const fs::path tmpImage = dir / (tag + "image.nii.gz"), tmpLabels = dir / (tag + "labels.nii.gz"),
                   tmpJson = dir / (tag + "subject.json");
    temps = {tmpImage, tmpLabels, tmpJson};
    writeVolume(subject.GetPointer(), tmpImage);
    writeLabels(subjectLabels, labelType, tmpLabels);
    {
      std::ofstream f(tmpJson);
      f << json.dump(2) << "\n";
      if (!f.flush()) throw std::runtime_error((dir / "subject.json").string() + ": cannot write");
    }
    fs::rename(tmpImage, dir / "image.nii.gz");
    fs::rename(tmpLabels, dir / "labels.nii.gz");
    fs::rename(tmpJson, dir / "subject.json");
    temps.clear();

    std::cerr << "wrote " << (dir / "image.nii.gz").string() << ", labels.nii.gz, subject.json (seed " << seed
              << ", max warp " << warpMax << " mm, mean " << warpMean << " mm"
              << (lost.empty() ? "" : ", " + std::to_string(lost.size()) + " labels lost") << ")\n";
    return 0;
  } catch (const std::exception& e) {
    std::error_code ignored;
    for (const auto& t : temps) fs::remove(t, ignored);
    std::cerr << "sinew-make-subject: error: " << e.what() << "\n";
    return 3;
  }
}
