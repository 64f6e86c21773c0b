// The guard for shape (the issue on reliability): the numerical guard sees non-finite positions
// and over-long steps, not a stable but wrong result (a structure collapsed to a twentieth of its
// volume, or carried off by 12 mm, with exit 0). This one compares each structure with itself at
// the start of the simulation, at every report sample, on the host, for every backend: its volume
// (Fig. 1b tessellation), how far its centroid drifted, how many more of its vertices are outside
// the image than were at the start (a structure may start partly outside a small field of view),
// and how many of its cells turned over or collapsed (each cell's vector area against the start's).
// The scene runner rolls a violating chunk back and halves the step like a numerical failure.
#pragma once

#include "sinew/core/image.h"
#include "sinew/core/mesh_store.h"
#include "sinew/core/stability.h"

#include <string>
#include <vector>

namespace sinew {

class ShapeGuard {
public:
  // Each structure's volume, centroid and how far outside `image` it reaches now become the reference.
  void capture(MeshStore& store, const ImageGeometry& image);
  bool captured() const { return !volume_.empty(); }
  // At a new level of detail (other cells): its cells' orientation and area now become the
  // reference; volumes and centroids stay those of the start. Call before each chunk.
  void followLevel(MeshStore& store);
  // What is wrong, naming the structure and the check, or "" when every structure is within the
  // limits. names: the structures' names in store order. chunkStart: the positions the chunk of
  // steps just run began from (empty: the swing check is skipped).
  std::string check(MeshStore& store, const ImageGeometry& image, const ShapeLimits& limits,
                    const std::vector<std::string>& names, std::span<const Vec3> chunkStart = {}) const;

private:
  std::string checkOne(MeshStore& store, Index mesh, const ImageGeometry& image, const ShapeLimits& limits,
                       const std::vector<std::string>& names, std::span<const Vec3> chunkStart) const;

  std::vector<double> volume_;
  std::vector<Vec3> centroid_;
  std::vector<float> outsideReach_;  // per structure, how far outside the image it reached at the start (mm; 0: inside)
  std::vector<Vec3> cellArea_;  // per cell of the store, its vector area at the start
};

// How many of the points (a structure's vertices) lie outside the image (beyond its border
// voxels' outer faces).
Index pointsOutside(std::span<const Vec3> points, const ImageGeometry& image);
Index verticesOutside(MeshStore& store, Index mesh, const ImageGeometry& image);
// How far (mm) the farthest of the points lies outside the image; 0 when none does.
float farthestOutside(std::span<const Vec3> points, const ImageGeometry& image);
// A structure's enclosed volume (mm^3) and its vertices' centroid.
double structureVolume(MeshStore& store, Index mesh);
Vec3 structureCentroid(MeshStore& store, Index mesh);
// A cell's vector area (half the sum of its polygon's edge cross products): its normal, outward for
// a cell listed counter-clockwise from outside, times its area.
Vec3 cellVectorArea(const MeshStore& store, std::span<const Vec3> positions, Index cell);

}  // namespace sinew
