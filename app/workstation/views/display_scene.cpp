#include "display_scene.h"

#include "segmentation_session.h"
#include "structure_colour.h"

#include <vtkCellArray.h>
#include <vtkFloatArray.h>
#include <vtkIdTypeArray.h>
#include <vtkImageData.h>
#include <vtkMatrix4x4.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <cmath>

namespace sinew {

DisplayScene::DisplayScene() : worldToDisplay_(vtkSmartPointer<vtkMatrix4x4>::New()) {}
DisplayScene::~DisplayScene() = default;
bool DisplayScene::empty() const { return image_ == nullptr; }
vtkImageData* DisplayScene::image() const { return image_; }
vtkMatrix4x4* DisplayScene::worldToDisplayMatrix() const { return worldToDisplay_; }
vtkPolyData* DisplayScene::surface(Index s) const { return surfaces_[s]; }

void DisplayScene::reset(SegmentationSession& session) {
  resetImage(session.image());
  const Index n = session.structureCount();
  for (Index s = 0; s < n; ++s) {
    StructureLook look;
    look.name = session.scene().structures[s].name;
    const QColor c = structureColour(std::size_t(s), std::size_t(n));
    look.colour = {c.redF(), c.greenF(), c.blueF()};
    looks_.push_back(look);
  }
  for (Index s = 0; s < n; ++s) surfaces_.push_back(vtkSmartPointer<vtkPolyData>::New());
  rebuildSurfaces(session);
}

void DisplayScene::resetImage(const Image3D& img) {
  geometry_ = img.geometry();
  indexToWorld_ = geometry_.indexToWorldMatrix();
  worldToIndex_ = indexToWorld_.inverse();
  // display = S * worldToIndex * (world - origin)
  const Eigen::Matrix3d A = geometry_.spacing.asDiagonal() * worldToIndex_;
  const Eigen::Vector3d b = -A * geometry_.origin;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) worldToDisplay_->SetElement(r, c, A(r, c));
    worldToDisplay_->SetElement(r, 3, b[r]);
  }

  image_ = vtkSmartPointer<vtkImageData>::New();
  image_->SetDimensions(geometry_.size[0], geometry_.size[1], geometry_.size[2]);
  image_->SetSpacing(geometry_.spacing[0], geometry_.spacing[1], geometry_.spacing[2]);
  image_->SetOrigin(0, 0, 0);
  auto scalars = vtkSmartPointer<vtkFloatArray>::New();
  scalars->SetNumberOfTuples(static_cast<vtkIdType>(img.voxels().size()));
  std::copy(img.voxels().begin(), img.voxels().end(), scalars->GetPointer(0));
  scalars->SetName("intensity");
  image_->GetPointData()->SetScalars(scalars);

  // Window/level from the 1st and 99th percentiles of the non-zero voxels.
  std::vector<float> sample;
  for (size_t v = 0; v < img.voxels().size(); v += 7)
    if (std::isfinite(img.voxels()[v]) && img.voxels()[v] != 0.0f) sample.push_back(img.voxels()[v]);
  if (sample.size() > 10) {
    std::sort(sample.begin(), sample.end());
    const double lo = sample[sample.size() / 100], hi = sample[sample.size() * 99 / 100];
    window = std::max(hi - lo, 1e-6);
    level = 0.5 * (hi + lo);
  }
  for (int a = 0; a < 3; ++a) cursor[a] = snapToSlice(a, 0.5 * (geometry_.size[a] - 1) * geometry_.spacing[a]);

  looks_.clear();
  surfaces_.clear();
  selected = 0;
  surfaceLevel_ = -1;
}

std::array<double, 6> DisplayScene::bounds() const {
  return {0.0, (geometry_.size[0] - 1) * geometry_.spacing[0], 0.0, (geometry_.size[1] - 1) * geometry_.spacing[1],
          0.0, (geometry_.size[2] - 1) * geometry_.spacing[2]};
}

std::array<double, 3> DisplayScene::centre() const {
  const auto b = bounds();
  return {0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]), 0.5 * (b[4] + b[5])};
}

Vec3 DisplayScene::toDisplay(const Vec3& world) const {
  const Eigen::Vector3d i = worldToIndex_ * (world.cast<double>() - geometry_.origin);
  return (geometry_.spacing.asDiagonal() * i).cast<float>();
}

Vec3 DisplayScene::toWorld(const Vec3& display) const {
  const Eigen::Vector3d i = display.cast<double>().cwiseQuotient(geometry_.spacing);
  return (indexToWorld_ * i + geometry_.origin).cast<float>();
}

SlicePlane DisplayScene::slicePlane(int axis, double value) const {
  // display_a = spacing_a * row_a(worldToIndex) . (world - origin)
  const Eigen::Vector3d n = geometry_.spacing[axis] * worldToIndex_.row(axis).transpose();
  const double norm = n.norm();
  return {(n / norm).cast<float>(), static_cast<float>((value + n.dot(geometry_.origin)) / norm)};
}

double DisplayScene::snapToSlice(int axis, double value) const {
  const double s = geometry_.spacing[axis];
  const double k = std::clamp(std::round(value / s), 0.0, double(geometry_.size[axis] - 1));
  return k * s;
}

void DisplayScene::rebuildSurfaces(SegmentationSession& session) {
  session.syncHost();
  MeshStore& store = session.simulation().store();
  for (Index s = 0; s < structureCount(); ++s) {
    auto points = vtkSmartPointer<vtkPoints>::New();
    points->SetDataTypeToFloat();
    points->SetNumberOfPoints(surfacePointCount(store, s));
    const auto tris = surfaceTriangles(store, s);
    auto offsets = vtkSmartPointer<vtkIdTypeArray>::New();
    auto conn = vtkSmartPointer<vtkIdTypeArray>::New();
    offsets->SetNumberOfTuples(static_cast<vtkIdType>(tris.size() + 1));
    conn->SetNumberOfTuples(static_cast<vtkIdType>(tris.size() * 3));
    for (size_t t = 0; t <= tris.size(); ++t) offsets->SetValue(static_cast<vtkIdType>(t), static_cast<vtkIdType>(3 * t));
    for (size_t t = 0; t < tris.size(); ++t)
      for (int c = 0; c < 3; ++c) conn->SetValue(static_cast<vtkIdType>(3 * t + c), tris[t][c]);
    auto polys = vtkSmartPointer<vtkCellArray>::New();
    polys->SetData(offsets, conn);
    surfaces_[s]->SetPoints(points);
    surfaces_[s]->SetPolys(polys);
  }
  surfaceLevel_ = session.level();
  updateSurfacePointsFromHost(session);
}

void DisplayScene::updateSurfacePointsFromHost(SegmentationSession& session) {
  session.syncHost();
  MeshStore& store = session.simulation().store();
  for (Index s = 0; s < structureCount(); ++s) {
    vtkPoints* points = surfaces_[s]->GetPoints();
    auto* data = static_cast<vtkFloatArray*>(points->GetData());
    std::span<Vec3> out(reinterpret_cast<Vec3*>(data->GetPointer(0)), static_cast<size_t>(points->GetNumberOfPoints()));
    hostSurfacePoints(store, s, out);
    points->Modified();
    surfaces_[s]->Modified();
  }
}

void fillPointCloud(DisplayScene& scene, const std::function<std::vector<Vec3>(Index)>& worldPoints,
                    const std::function<bool(Vec3&)>& place, double brighten, vtkPolyData* out) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  auto colours = vtkSmartPointer<vtkUnsignedCharArray>::New();
  colours->SetNumberOfComponents(3);
  for (Index s = 0; worldPoints && s < scene.structureCount(); ++s) {
    if (!scene.look(s).visible) continue;
    const auto& c = scene.look(s).colour;
    for (const Vec3& w : worldPoints(s)) {
      Vec3 p = scene.toDisplay(w);
      if (!place(p)) continue;
      const vtkIdType id = points->InsertNextPoint(p.x(), p.y(), p.z());
      verts->InsertNextCell(1, &id);
      colours->InsertNextTuple3(255 * std::min(1.0, c[0] + brighten), 255 * std::min(1.0, c[1] + brighten),
                                255 * std::min(1.0, c[2] + brighten));
    }
  }
  out->SetPoints(points);
  out->SetVerts(verts);
  out->GetPointData()->SetScalars(colours);
}

void appendLandmarks(DisplayScene& scene, const LandmarksProvider& pairs, const std::function<bool(Vec3&)>& place,
                     vtkPolyData* out) {
  if (!pairs || !out->GetPoints()) return;
  vtkPoints* points = out->GetPoints();
  auto* colours = vtkUnsignedCharArray::SafeDownCast(out->GetPointData()->GetScalars());
  auto lines = vtkSmartPointer<vtkCellArray>::New();
  for (const auto& [from, to] : pairs()) {
    vtkIdType ids[2] = {-1, -1};
    const Vec3 ends[2] = {from, to};
    const unsigned char rgb[2][3] = {{80, 230, 255}, {255, 230, 40}};
    for (int k = 0; k < 2; ++k) {
      Vec3 p = scene.toDisplay(ends[k]);
      if (!place(p)) continue;
      ids[k] = points->InsertNextPoint(p.x(), p.y(), p.z());
      out->GetVerts()->InsertNextCell(1, &ids[k]);
      colours->InsertNextTuple3(rgb[k][0], rgb[k][1], rgb[k][2]);
    }
    if (ids[0] >= 0 && ids[1] >= 0) lines->InsertNextCell(2, ids);
  }
  out->SetLines(lines);
  out->Modified();
}

void appendMarkers(DisplayScene& scene, const MarkersProvider& provider, const std::function<bool(Vec3&)>& place,
                   vtkPolyData* out) {
  if (!provider || !out->GetPoints()) return;
  vtkPoints* points = out->GetPoints();
  auto* colours = vtkUnsignedCharArray::SafeDownCast(out->GetPointData()->GetScalars());
  for (Index s = 0; s < scene.structureCount(); ++s) {
    if (!scene.look(s).visible) continue;
    for (const Marker& m : provider(s)) {
      Vec3 p = scene.toDisplay(m.at);
      if (!place(p)) continue;
      const vtkIdType id = points->InsertNextPoint(p.x(), p.y(), p.z());
      out->GetVerts()->InsertNextCell(1, &id);
      colours->InsertNextTuple3(m.rgb[0], m.rgb[1], m.rgb[2]);
    }
  }
  out->Modified();
}

}  // namespace sinew
