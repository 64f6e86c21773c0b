// One orthogonal slice of the image (axis 2: axial, 1: coronal, 0: sagittal, in grid axes) with
// every visible structure's contour, the crosshair and the attraction points near the slice.
// Navigation is built in: wheel scrolls slices, right drag zooms, middle drag pans, Shift + left
// drag sets window/level. Left button events go to the active interaction tool.
#pragma once

#include "display_scene.h"
#include "vtk_view_widget.h"

#include <functional>
#include <vector>

class vtkActor;
class vtkImageSlice;
class vtkImageSliceMapper;
class vtkPolyData;

namespace sinew {

struct ViewPointerEvent {
  Vec3 display;  // on the slice, display space
  Vec3 world;
  int axis = 2;
  double pickRadiusMm = 3.0;  // about 8 screen pixels at the current zoom
  bool control = false;
};

class DisplayScene;
// The index of the point (world mm) nearest the click on its slice (within a voxel of it), within
// the pick radius, or -1: what the point-placing tools pick.
int nearestOnSlice(const DisplayScene& scene, const std::vector<Vec3>& worldPoints, const ViewPointerEvent& e);

class SliceView : public VtkViewWidget {
  Q_OBJECT
public:
  // Every structure's contour on a plane (segments per structure).
  using ContourProvider = std::function<std::vector<std::vector<ContourSegment>>(const SlicePlane& plane)>;
  using PointsProvider = std::function<std::vector<Vec3>(Index structure)>;

  SliceView(int axis, DisplayScene& scene, QWidget* parent = nullptr);
  ~SliceView() override;
  int axis() const { return axis_; }
  static const char* axisName(int axis);

  void setProviders(ContourProvider contours, PointsProvider points);
  void setLandmarksProvider(LandmarksProvider landmarks) { landmarks_ = std::move(landmarks); }
  void setMarkersProvider(MarkersProvider markers) { markers_ = std::move(markers); }
  // Rebuilds actors for a new scene (image, structures) and frames the slice.
  void resetScene();
  void resetCamera();
  // The overlays are recomputed at the next paint when the revision moved.
  void invalidate() { dirty_ = true; update(); }
  // Widget position -> display-space point on the current slice.
  Vec3 pickOnSlice(const QPointF& widgetPos) const;
  // Widget position of a display-space point (for tests and tools).
  QPointF widgetPosition(const Vec3& display) const;

Q_SIGNALS:
  void toolPressed(const ViewPointerEvent& e);
  void toolDragged(const ViewPointerEvent& e);
  void toolReleased(const ViewPointerEvent& e);
  void cursorMoved();      // the slice changed (wheel)
  void windowLevelChanged();

protected:
  void prepareRender() override;
  void mousePressEvent(QMouseEvent* e) override;
  void mouseMoveEvent(QMouseEvent* e) override;
  void mouseReleaseEvent(QMouseEvent* e) override;
  void wheelEvent(QWheelEvent* e) override;

private:
  ViewPointerEvent pointerEvent(const QPointF& pos, Qt::KeyboardModifiers mods) const;
  void rebuildOverlays();

  int axis_;
  DisplayScene& scene_;
  ContourProvider contours_;
  PointsProvider points_;
  LandmarksProvider landmarks_;
  MarkersProvider markers_;
  vtkSmartPointer<vtkImageSliceMapper> sliceMapper_;
  vtkSmartPointer<vtkImageSlice> slice_;
  std::vector<vtkSmartPointer<vtkPolyData>> contourData_;
  std::vector<vtkSmartPointer<vtkActor>> contourActors_;
  vtkSmartPointer<vtkPolyData> crosshair_, points_data_;
  vtkSmartPointer<vtkActor> crosshairActor_, pointsActor_;
  bool dirty_ = true;
  enum class Drag { None, Tool, Pan, Zoom, WindowLevel } drag_ = Drag::None;
  QPointF last_;
};

}  // namespace sinew
