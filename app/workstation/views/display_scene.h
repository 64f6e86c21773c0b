// What every view shows, shared by the four views (VTK data, no widgets): the image in display
// space, each structure's surface and colour, the cursor, window/level and visibility.
//
// Display space is the image grid scaled by its spacing (display = diag(spacing) * index), so the
// three slice views are the grid's k (axial), j (coronal) and i (sagittal) planes whatever the
// image's direction cosines. Meshes stay in world millimetres; their actors carry the world ->
// display matrix, so the surface points can be written as they are in the store (also by CUDA).
#pragma once

#include "sinew/core/image.h"
#include "sinew/core/scene_data.h"
#include "surface_source.h"

#include <vtkSmartPointer.h>

#include <array>
#include <functional>
#include <string>
#include <vector>

class vtkImageData;
class vtkMatrix4x4;
class vtkPolyData;

namespace sinew {

class SegmentationSession;

struct StructureLook {
  std::string name;
  std::array<double, 3> colour{1, 0, 0};
  bool visible = true;
};

class DisplayScene {
public:
  DisplayScene();
  ~DisplayScene();

  // Rebuilds everything for a freshly opened session.
  void reset(SegmentationSession& session);
  // An image alone (no structures), for viewing before a scene is opened.
  void resetImage(const Image3D& image);
  bool empty() const;

  vtkImageData* image() const;
  const ImageGeometry& geometry() const { return geometry_; }
  // Display-space extent of the image: [min, max] per axis (voxel centres).
  std::array<double, 6> bounds() const;
  std::array<double, 3> centre() const;  // of bounds()
  vtkMatrix4x4* worldToDisplayMatrix() const;
  Vec3 toDisplay(const Vec3& world) const;
  Vec3 toWorld(const Vec3& display) const;
  // The world plane of display axis `axis` at display coordinate `value`.
  SlicePlane slicePlane(int axis, double value) const;
  // Display coordinate of the nearest voxel centre along an axis.
  double snapToSlice(int axis, double value) const;

  Index structureCount() const { return static_cast<Index>(looks_.size()); }
  StructureLook& look(Index s) { return looks_[s]; }
  // Each structure's tessellated surface (world mm). Its point array is rewritten in place; the
  // triangles change only with the level of detail.
  vtkPolyData* surface(Index s) const;
  // Rebuilds topology after a level change; updates points from the host store.
  void rebuildSurfaces(SegmentationSession& session);
  void updateSurfacePointsFromHost(SegmentationSession& session);
  int surfaceLevel() const { return surfaceLevel_; }

  // Crosshair position in display space, and window/level of the image.
  std::array<double, 3> cursor{0, 0, 0};
  double window = 1.0, level = 0.5;
  Index selected = 0;  // the structure tools act on

private:
  vtkSmartPointer<vtkImageData> image_;
  ImageGeometry geometry_;
  Eigen::Matrix3d indexToWorld_, worldToIndex_;
  vtkSmartPointer<vtkMatrix4x4> worldToDisplay_;
  std::vector<StructureLook> looks_;
  std::vector<vtkSmartPointer<vtkPolyData>> surfaces_;
  int surfaceLevel_ = -1;
};

// The visible structures' points (world mm, from worldPoints) as a vertex cloud in display space,
// each in its structure's colour brightened by `brighten`. `place` may move a display point (slice
// views pin them to the slice) or return false to leave it out.
void fillPointCloud(DisplayScene& scene, const std::function<std::vector<Vec3>(Index)>& worldPoints,
                    const std::function<bool(Vec3&)>& place, double brighten, vtkPolyData* out);

// Landmark pairs (world mm): where the model has a point, where it is in the image.
using LandmarksProvider = std::function<std::vector<std::pair<Vec3, Vec3>>()>;
// Appends each pair to a cloud filled by fillPointCloud: the model end in cyan, the image end in
// yellow, a line between them where both ends are placed.
void appendLandmarks(DisplayScene& scene, const LandmarksProvider& pairs, const std::function<bool(Vec3&)>& place,
                     vtkPolyData* out);

// Points drawn in a colour of their own (include / exclude points, contact regions), world mm.
struct Marker {
  Vec3 at = Vec3::Zero();
  std::array<unsigned char, 3> rgb{255, 255, 255};
};
using MarkersProvider = std::function<std::vector<Marker>(Index structure)>;
// Appends the visible structures' markers to a cloud filled by fillPointCloud.
void appendMarkers(DisplayScene& scene, const MarkersProvider& markers, const std::function<bool(Vec3&)>& place,
                   vtkPolyData* out);

}  // namespace sinew
