// The 3D view: each structure's surface, the three slice planes through the cursor, and the
// attraction points. Left drag rotates, right drag or wheel zooms, middle drag pans.
#pragma once

#include "display_scene.h"
#include "vtk_view_widget.h"

#include <functional>
#include <vector>

class vtkActor;
class vtkImageSlice;
class vtkImageSliceMapper;
class vtkPolyData;
class vtkPolyDataMapper;

namespace sinew {

class VolumeView : public VtkViewWidget {
  Q_OBJECT
public:
  using MapperFactory = std::function<vtkSmartPointer<vtkPolyDataMapper>(Index structure)>;
  using PointsProvider = std::function<std::vector<Vec3>(Index structure)>;

  explicit VolumeView(DisplayScene& scene, QWidget* parent = nullptr);
  ~VolumeView() override;

  // The surfaces' mappers come from here (the CUDA interop mapper, or VTK's own by default).
  void setMapperFactory(MapperFactory factory) { mapperFactory_ = std::move(factory); }
  void setPointsProvider(PointsProvider points) { points_ = std::move(points); }
  void setLandmarksProvider(LandmarksProvider landmarks) { landmarks_ = std::move(landmarks); }
  void setMarkersProvider(MarkersProvider markers) { markers_ = std::move(markers); }
  void resetScene();
  void resetCamera();
  void invalidate() { dirty_ = true; update(); }
  vtkPolyDataMapper* surfaceMapper(Index s) const;
  // Hook run before each render (the interop path writes the surfaces' buffers here).
  std::function<void()> beforeRender;

protected:
  void prepareRender() override;
  void mousePressEvent(QMouseEvent* e) override;
  void mouseMoveEvent(QMouseEvent* e) override;
  void mouseReleaseEvent(QMouseEvent* e) override;
  void wheelEvent(QWheelEvent* e) override;

private:
  DisplayScene& scene_;
  MapperFactory mapperFactory_;
  PointsProvider points_;
  LandmarksProvider landmarks_;
  MarkersProvider markers_;
  std::vector<vtkSmartPointer<vtkActor>> surfaces_;
  vtkSmartPointer<vtkImageSliceMapper> sliceMappers_[3];
  vtkSmartPointer<vtkImageSlice> slices_[3];
  vtkSmartPointer<vtkPolyData> pointsData_;
  vtkSmartPointer<vtkActor> pointsActor_;
  bool dirty_ = true;
  Qt::MouseButton button_ = Qt::NoButton;
  QPointF last_;
};

}  // namespace sinew
