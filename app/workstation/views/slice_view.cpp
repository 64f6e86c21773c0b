#include "slice_view.h"

#include <QMouseEvent>
#include <QWheelEvent>

#include <vtkActor.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkImageData.h>
#include <vtkImageProperty.h>
#include <vtkImageSlice.h>
#include <vtkImageSliceMapper.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkProperty.h>
#include <vtkRenderer.h>

#include <cmath>

namespace sinew {

namespace {
// Camera direction and up per axis: radiological convention for images stored the usual way
// (patient right on the screen's left, anterior up in axial, superior up otherwise).
const double kDirection[3][3] = {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}};
const double kUp[3][3] = {{0, 0, 1}, {0, 0, 1}, {0, 1, 0}};

vtkSmartPointer<vtkActor> lineActor(vtkPolyData* data, const std::array<double, 3>& colour, double width) {
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputData(data);
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  actor->GetProperty()->SetColor(colour[0], colour[1], colour[2]);
  actor->GetProperty()->SetLineWidth(width);
  actor->GetProperty()->SetLighting(false);
  actor->PickableOff();
  return actor;
}
}  // namespace

const char* SliceView::axisName(int axis) {
  static const char* names[3] = {"Sagittal", "Coronal", "Axial"};
  return names[axis];
}

SliceView::SliceView(int axis, DisplayScene& scene, QWidget* parent)
    : VtkViewWidget(parent), axis_(axis), scene_(scene) {
  renderer()->SetBackground(0, 0, 0);
  sliceMapper_ = vtkSmartPointer<vtkImageSliceMapper>::New();
  sliceMapper_->SetOrientation(axis_);
  slice_ = vtkSmartPointer<vtkImageSlice>::New();
  slice_->SetMapper(sliceMapper_);
  slice_->GetProperty()->SetInterpolationTypeToLinear();
  crosshair_ = vtkSmartPointer<vtkPolyData>::New();
  crosshairActor_ = lineActor(crosshair_, {0.95, 0.85, 0.2}, 1.0);
  points_data_ = vtkSmartPointer<vtkPolyData>::New();
  pointsActor_ = lineActor(points_data_, {1, 1, 1}, 1.0);
  pointsActor_->GetProperty()->SetPointSize(9);
  setAccessibleName(axisName(axis));
}

SliceView::~SliceView() = default;

int nearestOnSlice(const DisplayScene& scene, const std::vector<Vec3>& worldPoints, const ViewPointerEvent& e) {
  const double sliceHalf = scene.geometry().spacing[e.axis];
  int best = -1;
  double bestD = e.pickRadiusMm;
  for (size_t i = 0; i < worldPoints.size(); ++i) {
    const Vec3 p = scene.toDisplay(worldPoints[i]);
    if (std::abs(p[e.axis] - e.display[e.axis]) > sliceHalf) continue;
    Vec3 d = p - e.display;
    d[e.axis] = 0;
    if (d.norm() <= bestD) {
      bestD = d.norm();
      best = static_cast<int>(i);
    }
  }
  return best;
}

void SliceView::setProviders(ContourProvider contours, PointsProvider points) {
  contours_ = std::move(contours);
  points_ = std::move(points);
  dirty_ = true;
}

void SliceView::resetScene() {
  renderer()->RemoveAllViewProps();
  contourData_.clear();
  contourActors_.clear();
  if (scene_.empty()) return;
  sliceMapper_->SetInputData(scene_.image());
  renderer()->AddViewProp(slice_);
  for (Index s = 0; s < scene_.structureCount(); ++s) {
    contourData_.push_back(vtkSmartPointer<vtkPolyData>::New());
    contourActors_.push_back(lineActor(contourData_.back(), scene_.look(s).colour, 2.0));
    renderer()->AddViewProp(contourActors_.back());
  }
  renderer()->AddViewProp(crosshairActor_);
  renderer()->AddViewProp(pointsActor_);
  resetCamera();
  invalidate();
}

void SliceView::resetCamera() {
  if (scene_.empty()) return;
  const auto b = scene_.bounds();
  const auto centre = scene_.centre();
  vtkCamera* cam = renderer()->GetActiveCamera();
  cam->ParallelProjectionOn();
  cam->SetFocalPoint(centre.data());
  const double* d = kDirection[axis_];
  cam->SetPosition(centre[0] - 1000 * d[0], centre[1] - 1000 * d[1], centre[2] - 1000 * d[2]);
  cam->SetViewUp(kUp[axis_]);
  // Fit the slice's extent in both screen directions.
  const int a = axis_ == 0 ? 1 : 0, up = axis_ == 2 ? 1 : 2;
  const double halfW = 0.5 * (b[2 * a + 1] - b[2 * a]), halfH = 0.5 * (b[2 * up + 1] - b[2 * up]);
  const double aspect = std::max(1.0, double(width())) / std::max(1.0, double(height()));
  cam->SetParallelScale(1.05 * std::max(halfH, halfW / aspect));
  cam->SetClippingRange(1, 5000);
}

Vec3 SliceView::pickOnSlice(const QPointF& pos) const {
  double w[3];
  displayToWorld(pos, w);
  w[axis_] = scene_.cursor[axis_];
  return Vec3(float(w[0]), float(w[1]), float(w[2]));
}

QPointF SliceView::widgetPosition(const Vec3& p) const {
  renderer()->SetWorldPoint(p.x(), p.y(), p.z(), 1.0);
  renderer()->WorldToDisplay();
  const double* d = renderer()->GetDisplayPoint();
  const double dpr = devicePixelRatioF();
  return {d[0] / dpr, height() - d[1] / dpr};
}

ViewPointerEvent SliceView::pointerEvent(const QPointF& pos, Qt::KeyboardModifiers mods) const {
  ViewPointerEvent e;
  e.display = pickOnSlice(pos);
  e.world = scene_.toWorld(e.display);
  e.axis = axis_;
  // 8 widget pixels in millimetres at the current zoom.
  e.pickRadiusMm = 8.0 * 2.0 * renderer()->GetActiveCamera()->GetParallelScale() / std::max(1, height());
  e.control = mods & Qt::ControlModifier;
  return e;
}

void SliceView::mousePressEvent(QMouseEvent* e) {
  last_ = e->position();
  if (scene_.empty()) return;
  if (e->button() == Qt::LeftButton && (e->modifiers() & Qt::ShiftModifier)) drag_ = Drag::WindowLevel;
  else if (e->button() == Qt::LeftButton) {
    drag_ = Drag::Tool;
    Q_EMIT toolPressed(pointerEvent(e->position(), e->modifiers()));
  } else if (e->button() == Qt::MiddleButton) drag_ = Drag::Pan;
  else if (e->button() == Qt::RightButton) drag_ = Drag::Zoom;
}

void SliceView::mouseMoveEvent(QMouseEvent* e) {
  const QPointF delta = e->position() - last_;
  vtkCamera* cam = renderer()->GetActiveCamera();
  switch (drag_) {
    case Drag::None:
      return;
    case Drag::Tool:
      Q_EMIT toolDragged(pointerEvent(e->position(), e->modifiers()));
      break;
    case Drag::Pan: {
      double a[3], b[3];
      displayToWorld(last_, a);
      displayToWorld(e->position(), b);
      double fp[3], pos[3];
      cam->GetFocalPoint(fp);
      cam->GetPosition(pos);
      for (int i = 0; i < 3; ++i) fp[i] -= b[i] - a[i], pos[i] -= b[i] - a[i];
      cam->SetFocalPoint(fp);
      cam->SetPosition(pos);
      update();
      break;
    }
    case Drag::Zoom:
      cam->SetParallelScale(cam->GetParallelScale() * std::pow(1.01, delta.y()));
      update();
      break;
    case Drag::WindowLevel:
      scene_.window = std::max(1e-6, scene_.window * std::pow(1.01, delta.x()));
      scene_.level -= delta.y() * scene_.window * 0.005;
      Q_EMIT windowLevelChanged();
      break;
  }
  last_ = e->position();
}

void SliceView::mouseReleaseEvent(QMouseEvent* e) {
  if (drag_ == Drag::Tool) Q_EMIT toolReleased(pointerEvent(e->position(), e->modifiers()));
  drag_ = Drag::None;
}

void SliceView::wheelEvent(QWheelEvent* e) {
  if (scene_.empty()) return;
  const int steps = e->angleDelta().y() / 120;
  if (steps == 0) return;
  if (e->modifiers() & Qt::ControlModifier) {
    vtkCamera* cam = renderer()->GetActiveCamera();
    cam->SetParallelScale(cam->GetParallelScale() * std::pow(0.9, steps));
    update();
    return;
  }
  const double s = scene_.geometry().spacing[axis_];
  scene_.cursor[axis_] = scene_.snapToSlice(axis_, scene_.cursor[axis_] + steps * s);
  Q_EMIT cursorMoved();
}

void SliceView::rebuildOverlays() {
  const double* d = kDirection[axis_];
  const double lift = 0.5;  // overlays float half a millimetre toward the camera (no z-fighting)
  const SlicePlane plane = scene_.slicePlane(axis_, scene_.cursor[axis_]);
  const std::vector<std::vector<ContourSegment>> contours =
      contours_ ? contours_(plane) : std::vector<std::vector<ContourSegment>>();
  for (Index s = 0; s < scene_.structureCount(); ++s) {
    auto pts = vtkSmartPointer<vtkPoints>::New();
    auto lines = vtkSmartPointer<vtkCellArray>::New();
    if (scene_.look(s).visible && s < Index(contours.size())) {
      for (const ContourSegment& seg : contours[s]) {
        Vec3 a = scene_.toDisplay(seg.a), b = scene_.toDisplay(seg.b);
        a[axis_] = b[axis_] = float(scene_.cursor[axis_] - lift * d[axis_]);
        const vtkIdType ia = pts->InsertNextPoint(a.x(), a.y(), a.z());
        const vtkIdType ib = pts->InsertNextPoint(b.x(), b.y(), b.z());
        const vtkIdType ids[2] = {ia, ib};
        lines->InsertNextCell(2, ids);
      }
    }
    contourData_[s]->SetPoints(pts);
    contourData_[s]->SetLines(lines);
    contourActors_[s]->GetProperty()->SetColor(scene_.look(s).colour.data());
    contourActors_[s]->SetVisibility(scene_.look(s).visible);
  }

  // Crosshair through the cursor, across the whole image.
  const auto b = scene_.bounds();
  auto cp = vtkSmartPointer<vtkPoints>::New();
  auto cl = vtkSmartPointer<vtkCellArray>::New();
  for (int a = 0; a < 3; ++a) {
    if (a == axis_) continue;
    double p0[3] = {scene_.cursor[0], scene_.cursor[1], scene_.cursor[2]}, p1[3];
    p0[axis_] -= lift * d[axis_];
    std::copy(p0, p0 + 3, p1);
    p0[a] = b[2 * a];
    p1[a] = b[2 * a + 1];
    const vtkIdType ids[2] = {cp->InsertNextPoint(p0), cp->InsertNextPoint(p1)};
    cl->InsertNextCell(2, ids);
  }
  crosshair_->SetPoints(cp);
  crosshair_->SetLines(cl);

  // Attraction points within one voxel of the slice, brightened, pinned just above it.
  const double half = scene_.geometry().spacing[axis_];
  const float pinned = float(scene_.cursor[axis_] - 2 * lift * d[axis_]);
  auto onSlice = [&](Vec3& p) {
    if (std::abs(p[axis_] - scene_.cursor[axis_]) > half) return false;
    p[axis_] = pinned;
    return true;
  };
  fillPointCloud(scene_, points_, onSlice, 0.3, points_data_);
  appendLandmarks(scene_, landmarks_, onSlice, points_data_);
  appendMarkers(scene_, markers_, onSlice, points_data_);
}

void SliceView::prepareRender() {
  if (scene_.empty()) return;
  const int slice = static_cast<int>(std::lround(scene_.cursor[axis_] / scene_.geometry().spacing[axis_]));
  if (sliceMapper_->GetSliceNumber() != slice) sliceMapper_->SetSliceNumber(slice);
  slice_->GetProperty()->SetColorWindow(scene_.window);
  slice_->GetProperty()->SetColorLevel(scene_.level);
  if (dirty_) {
    rebuildOverlays();
    dirty_ = false;
  }
}

}  // namespace sinew
