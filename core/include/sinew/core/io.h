// Image and mesh IO are plugins (ITK and VTK live there, not in core). Core only declares what an
// IO plugin provides and how outputs are written safely.
#pragma once

#include "sinew/core/image.h"
#include "sinew/core/spatial_map.h"
#include "sinew/core/triangle_mesh.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <unordered_map>
#include <vector>

namespace sinew {

using LabelVolume = Volume<std::int32_t>;

// Largest image a reader accepts, checked against the header before anything is allocated.
inline constexpr std::size_t kMaxImageVoxels = std::size_t(1) << 31;

// Intensity-based registration of the model's atlas image to the target (the scene's "initialise"
// stage). Provided by an image plugin (ITK's v4 framework); core only declares it.
struct RegistrationOptions {
  bool affine = true;             // rigid, then affine; false: rigid only
  int bsplineCells = 0;           // > 0 (with affine): then a cubic B-spline, this many cells per axis over the target
  int bsplineIterations = 30;     // the B-spline's L-BFGS-B iterations at most (on the pyramid's first level only)
  int bsplineSamples = 10000;     // the B-spline stage's random voxels
  int levels = 2;                 // multi-resolution levels on images binned to about 2 mm (4, 2 mm)
  int iterations = 100;           // per level and stage at most
  int histogramBins = 32;
  int samplesPerLevel = 10000;    // random voxels of the working grid the metric samples, per level
  std::uint32_t seed = 1;         // the metric's random sampling: fixed, so runs repeat exactly
  std::function<void(const std::string&)> log;
  // Asked between the registration's steps and its optimiser's iterations (when set): true stops
  // it, and it throws RegistrationCancelled. A run whose loading failed meanwhile stops it so.
  // Stages that run at once ask it from their own threads (`log` is called from the caller's).
  std::function<bool()> cancelled;
};

// Thrown by a registration whose RegistrationOptions::cancelled said true.
class RegistrationCancelled : public std::runtime_error {
public:
  RegistrationCancelled() : std::runtime_error("registration cancelled") {}
};

struct RegistrationStage {
  std::string name;       // "rigid", "affine", "bspline"
  double metric = 0.0;    // final Mattes mutual information (negative: lower is better)
  int iterations = 0;     // at the finest level
  double seconds = 0.0;
  bool kept = true;       // false: a B-spline stage that did not improve the metric, or folded
  double startMetric = 0.0;  // the B-spline stage's own metric before it (the affine alone)
};

// A map of target points to model points (ITK's fixed-to-moving convention): what a registration
// found and what a transform file holds. The whole map is
// SpatialMap::warpThenAffine(deformation, targetToModel).
struct RegistrationTransform {
  Eigen::Matrix4d targetToModel = Eigen::Matrix4d::Identity();  // the rigid or affine stage's
  BSplineWarp deformation;  // a B-spline applied before the affine; empty: the affine alone
};

struct RegistrationResult : RegistrationTransform {
  std::vector<RegistrationStage> stages;
};

struct ImageIODescriptor {
  std::string name;
  std::string summary;
  std::vector<std::string> extensions;  // lower case, with the dot (".nii.gz"); "/" = a directory
  std::function<Image3D(const std::filesystem::path&)> readImage;
  std::function<LabelVolume(const std::filesystem::path&)> readLabels;
  std::function<void(const std::filesystem::path&, const LabelVolume&)> writeLabels;
  std::function<void(const std::filesystem::path&, const Image3D&)> writeImage;
  // Optional: registration and transform files (ITK's .tfm/.txt/.mat formats: an affine, or an
  // affine after a cubic B-spline), world millimetres, ITK's fixed-to-moving convention. Errors
  // throw InputError naming the stage and the metric value (registration) or the file (transforms).
  std::function<RegistrationResult(const Image3D& target, const Image3D& model, const RegistrationOptions&)> registerImages;
  std::function<RegistrationTransform(const std::filesystem::path&)> readTransform;
  std::function<void(const std::filesystem::path&, const RegistrationTransform&)> writeTransform;
};

// Where a label lies in a label map: the bounding box of its voxels (index space, both ends
// included) and their count.
struct LabelExtent {
  std::array<int, 3> lo{}, hi{};
  std::size_t count = 0;
};
// Every label's extent, background (0) too, in one pass over the map: a surface builder told a
// label's extent need not scan the whole map for it, once per structure and level.
std::unordered_map<std::int32_t, LabelExtent> labelExtents(const LabelVolume& labels);

// Options for building a surface from a label: the iso-surface of the label's mask, optionally
// smoothed and decimated to about `targetTriangles` (0 keeps every marching-cubes triangle).
// `extent`: the label's (labelExtents), when the caller knows it; otherwise the builder finds it.
struct LabelSurfaceOptions {
  int smoothingIterations = 0;
  int targetTriangles = 0;
  const LabelExtent* extent = nullptr;
};

struct MeshIODescriptor {
  std::string name;
  std::string summary;
  std::vector<std::string> extensions;  // read and write
  std::function<TriangleMesh(const std::filesystem::path&)> read;
  std::function<void(const std::filesystem::path&, const TriangleMesh&)> write;
  // The closed surface of one label of a label map (largest connected piece), in world mm.
  std::function<TriangleMesh(const LabelVolume&, std::int32_t label, const LabelSurfaceOptions&)> labelSurface;
  // Optional: the file's points and triangles exactly as stored, in their order (no merging of
  // points): for files Sinew wrote itself, such as a model's meshes.
  std::function<TriangleMesh(const std::filesystem::path&)> readExact;
};

// The file's extension as IO plugins match it: ".nii.gz" for a gzipped NIfTI, "/" for a directory.
std::string ioExtension(const std::filesystem::path& path);

// Writes go to a temporary file beside the target (same extension, so format detection works)
// and are renamed over it on commit(); an uncommitted output is removed, so a failed run leaves
// nothing half-written.
class AtomicOutput {
public:
  explicit AtomicOutput(std::filesystem::path target);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;
  const std::filesystem::path& tempPath() const { return temp_; }
  void commit();

private:
  std::filesystem::path target_, temp_;
  bool committed_ = false;
};

}  // namespace sinew
