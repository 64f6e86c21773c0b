#include "volume_view.h"

#include <QMouseEvent>
#include <QWheelEvent>

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkImageData.h>
#include <vtkImageProperty.h>
#include <vtkImageSlice.h>
#include <vtkImageSliceMapper.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>

#include <cmath>

namespace sinew {

VolumeView::VolumeView(DisplayScene& scene, QWidget* parent) : VtkViewWidget(parent), scene_(scene) {
  renderer()->SetBackground(0.08, 0.09, 0.11);
  renderer()->SetBackground2(0.22, 0.24, 0.28);
  renderer()->GradientBackgroundOn();
  for (int a = 0; a < 3; ++a) {
    sliceMappers_[a] = vtkSmartPointer<vtkImageSliceMapper>::New();
    sliceMappers_[a]->SetOrientation(a);
    slices_[a] = vtkSmartPointer<vtkImageSlice>::New();
    slices_[a]->SetMapper(sliceMappers_[a]);
    slices_[a]->GetProperty()->SetInterpolationTypeToLinear();
    slices_[a]->GetProperty()->SetOpacity(0.6);
  }
  pointsData_ = vtkSmartPointer<vtkPolyData>::New();
  auto pm = vtkSmartPointer<vtkPolyDataMapper>::New();
  pm->SetInputData(pointsData_);
  pointsActor_ = vtkSmartPointer<vtkActor>::New();
  pointsActor_->SetMapper(pm);
  pointsActor_->GetProperty()->SetPointSize(12);
  pointsActor_->GetProperty()->SetRenderPointsAsSpheres(true);
  setAccessibleName("3D");
}

VolumeView::~VolumeView() = default;

vtkPolyDataMapper* VolumeView::surfaceMapper(Index s) const {
  return static_cast<vtkPolyDataMapper*>(surfaces_[s]->GetMapper());
}

void VolumeView::resetScene() {
  renderer()->RemoveAllViewProps();
  surfaces_.clear();
  if (scene_.empty()) return;
  for (int a = 0; a < 3; ++a) {
    sliceMappers_[a]->SetInputData(scene_.image());
    renderer()->AddViewProp(slices_[a]);
  }
  for (Index s = 0; s < scene_.structureCount(); ++s) {
    vtkSmartPointer<vtkPolyDataMapper> mapper =
        mapperFactory_ ? mapperFactory_(s) : vtkSmartPointer<vtkPolyDataMapper>::New();
    mapper->SetInputData(scene_.surface(s));
    mapper->ScalarVisibilityOff();
    auto actor = vtkSmartPointer<vtkActor>::New();
    actor->SetMapper(mapper);
    actor->SetUserMatrix(scene_.worldToDisplayMatrix());
    actor->GetProperty()->SetColor(scene_.look(s).colour.data());
    actor->GetProperty()->SetSpecular(0.3);
    surfaces_.push_back(actor);
    renderer()->AddViewProp(actor);
  }
  renderer()->AddViewProp(pointsActor_);
  resetCamera();
  invalidate();
}

void VolumeView::resetCamera() {
  if (scene_.empty()) return;
  const auto b = scene_.bounds();
  const auto c = scene_.centre();
  vtkCamera* cam = renderer()->GetActiveCamera();
  cam->ParallelProjectionOff();
  cam->SetFocalPoint(c.data());
  // From the front-left, above: the patient's anterior faces the viewer (grid j toward it).
  cam->SetPosition(c[0] - 250, c[1] + 450, c[2] + 200);
  cam->SetViewUp(0, 0, 1);
  renderer()->ResetCamera(b.data());
  cam->Dolly(1.6);  // the structures, not the whole head, fill the view
  renderer()->ResetCameraClippingRange();
}

void VolumeView::prepareRender() {
  if (scene_.empty()) return;
  for (int a = 0; a < 3; ++a) {
    const int slice = static_cast<int>(std::lround(scene_.cursor[a] / scene_.geometry().spacing[a]));
    if (sliceMappers_[a]->GetSliceNumber() != slice) sliceMappers_[a]->SetSliceNumber(slice);
    slices_[a]->GetProperty()->SetColorWindow(scene_.window);
    slices_[a]->GetProperty()->SetColorLevel(scene_.level);
  }
  for (Index s = 0; s < static_cast<Index>(surfaces_.size()); ++s) {
    surfaces_[s]->SetVisibility(scene_.look(s).visible);
    surfaces_[s]->GetProperty()->SetColor(scene_.look(s).colour.data());
  }
  if (beforeRender) beforeRender();
  if (dirty_) {
    fillPointCloud(scene_, points_, [](Vec3&) { return true; }, 0.0, pointsData_);
    appendLandmarks(scene_, landmarks_, [](Vec3&) { return true; }, pointsData_);
    appendMarkers(scene_, markers_, [](Vec3&) { return true; }, pointsData_);
    dirty_ = false;
  }
  renderer()->ResetCameraClippingRange();
}

void VolumeView::mousePressEvent(QMouseEvent* e) {
  button_ = e->button();
  last_ = e->position();
}

void VolumeView::mouseMoveEvent(QMouseEvent* e) {
  if (button_ == Qt::NoButton) return;
  const QPointF d = e->position() - last_;
  last_ = e->position();
  vtkCamera* cam = renderer()->GetActiveCamera();
  if (button_ == Qt::LeftButton) {
    cam->Azimuth(-0.4 * d.x());
    cam->Elevation(0.4 * d.y());
    cam->OrthogonalizeViewUp();
  } else if (button_ == Qt::RightButton) {
    cam->Dolly(std::pow(1.01, -d.y()));
  } else if (button_ == Qt::MiddleButton) {
    double fp[3], pos[3], up[3], dir[3];
    cam->GetFocalPoint(fp);
    cam->GetPosition(pos);
    cam->GetViewUp(up);
    cam->GetDirectionOfProjection(dir);
    const double right[3] = {dir[1] * up[2] - dir[2] * up[1], dir[2] * up[0] - dir[0] * up[2], dir[0] * up[1] - dir[1] * up[0]};
    const double scale = cam->GetDistance() * 0.002;
    for (int i = 0; i < 3; ++i) {
      const double m = scale * (-d.x() * right[i] + d.y() * up[i]);
      fp[i] += m, pos[i] += m;
    }
    cam->SetFocalPoint(fp);
    cam->SetPosition(pos);
  }
  update();
}

void VolumeView::mouseReleaseEvent(QMouseEvent*) { button_ = Qt::NoButton; }

void VolumeView::wheelEvent(QWheelEvent* e) {
  renderer()->GetActiveCamera()->Dolly(std::pow(1.1, e->angleDelta().y() / 120.0));
  update();
}

}  // namespace sinew
