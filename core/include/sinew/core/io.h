// Image and mesh IO are plugins (ITK and VTK live there, not in core). Core only declares what an
// IO plugin provides and how outputs are written safely.
#pragma once

#include "sinew/core/image.h"
#include "sinew/core/triangle_mesh.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace sinew {

using LabelVolume = Volume<std::int32_t>;

// Largest image a reader accepts, checked against the header before anything is allocated.
inline constexpr std::size_t kMaxImageVoxels = std::size_t(1) << 31;

struct ImageIODescriptor {
  std::string name;
  std::string summary;
  std::vector<std::string> extensions;  // lower case, with the dot (".nii.gz"); "/" = a directory
  std::function<Image3D(const std::filesystem::path&)> readImage;
  std::function<LabelVolume(const std::filesystem::path&)> readLabels;
  std::function<void(const std::filesystem::path&, const LabelVolume&)> writeLabels;
  std::function<void(const std::filesystem::path&, const Image3D&)> writeImage;
};

// Options for building a surface from a label: the iso-surface of the label's mask, optionally
// smoothed and decimated to about `targetTriangles` (0 keeps every marching-cubes triangle).
struct LabelSurfaceOptions {
  int smoothingIterations = 0;
  int targetTriangles = 0;
};

struct MeshIODescriptor {
  std::string name;
  std::string summary;
  std::vector<std::string> extensions;  // read and write
  std::function<TriangleMesh(const std::filesystem::path&)> read;
  std::function<void(const std::filesystem::path&, const TriangleMesh&)> write;
  // The closed surface of one label of a label map (largest connected piece), in world mm.
  std::function<TriangleMesh(const LabelVolume&, std::int32_t label, const LabelSurfaceOptions&)> labelSurface;
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
