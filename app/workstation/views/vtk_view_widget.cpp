// Qt side only: no VTK OpenGL header here (VTK's GLEW and Qt's OpenGL headers do not mix); the
// blit is in vtk_blit.cpp.
#include "vtk_view_widget.h"

#include "vtk_blit.h"

#include <QElapsedTimer>
#include <QOpenGLContext>
#include <QSurfaceFormat>

#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCommand.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkGenericRenderWindowInteractor.h>
#include <vtkRenderer.h>

namespace sinew {

namespace {
// VTK asks its host to make the context current. Only when it is not already: QOpenGLWidget's
// makeCurrent() also rebinds Qt's framebuffer, behind VTK's cached state, and VTK then draws
// garbage.
void onMakeCurrent(vtkObject*, unsigned long, void* clientData, void*) {
  auto* w = static_cast<VtkViewWidget*>(clientData);
  if (QOpenGLContext::currentContext() != w->context()) w->makeCurrent();
}
void onIsCurrent(vtkObject*, unsigned long, void* clientData, void* callData) {
  auto* w = static_cast<VtkViewWidget*>(clientData);
  *static_cast<bool*>(callData) = w->context() && QOpenGLContext::currentContext() == w->context();
}
void yes(vtkObject*, unsigned long, void*, void* callData) { *static_cast<int*>(callData) = 1; }
}  // namespace

VtkViewWidget::VtkViewWidget(QWidget* parent) : QOpenGLWidget(parent) {
  window_ = vtkSmartPointer<vtkGenericOpenGLRenderWindow>::New();
  renderer_ = vtkSmartPointer<vtkRenderer>::New();
  window_->AddRenderer(renderer_);
  window_->SetReadyForRendering(false);
  window_->SetFrameBlitModeToNoBlit();
  window_->SetMultiSamples(0);
  window_->SetForceMaximumHardwareLineWidth(1);
  // Generic interactor: never the X11 one, whose event loop would fight Qt's. Rendering on its
  // behalf is disabled; the widget decides when to paint.
  interactor_ = vtkSmartPointer<vtkGenericRenderWindowInteractor>::New();
  interactor_->SetRenderWindow(window_);
  interactor_->EnableRenderOff();

  auto observe = [&](unsigned long event, void (*fn)(vtkObject*, unsigned long, void*, void*)) {
    vtkNew<vtkCallbackCommand> cb;
    cb->SetCallback(fn);
    cb->SetClientData(this);
    window_->AddObserver(event, cb);
  };
  observe(vtkCommand::WindowMakeCurrentEvent, onMakeCurrent);
  observe(vtkCommand::WindowIsCurrentEvent, onIsCurrent);
  observe(vtkCommand::WindowSupportsOpenGLEvent, yes);
  observe(vtkCommand::WindowIsDirectEvent, yes);
  setFocusPolicy(Qt::StrongFocus);
  setMouseTracking(true);
}

vtkRenderer* VtkViewWidget::renderer() const { return renderer_; }
vtkGenericOpenGLRenderWindow* VtkViewWidget::renderWindow() const { return window_; }

VtkViewWidget::~VtkViewWidget() {
  // ~QOpenGLWidget destroys the context after this object's members are gone: stop listening.
  QObject::disconnect(contextConnection_);
  // Graphics resources belong to this widget's context: release them while it still exists.
  if (contextReady_) {
    makeCurrent();
    window_->Finalize();
    doneCurrent();
  }
}

void VtkViewWidget::initializeGL() {
  window_->SetOwnContext(false);
  window_->SetIsCurrent(true);
  window_->SetMapped(1);
  window_->OpenGLInitContext();
  window_->SetReadyForRendering(true);
  contextReady_ = true;
  contextConnection_ = connect(context(), &QOpenGLContext::aboutToBeDestroyed, this, [this] {
    makeCurrent();
    window_->Finalize();
    window_->SetReadyForRendering(false);
    contextReady_ = false;
  });
}

void VtkViewWidget::resizeGL(int w, int h) {
  const double dpr = devicePixelRatioF();
  const int pw = static_cast<int>(w * dpr + 0.5), ph = static_cast<int>(h * dpr + 0.5);
  window_->SetSize(pw, ph);
  interactor_->SetSize(pw, ph);
}

void VtkViewWidget::paintGL() {
  if (!contextReady_) return;
  QElapsedTimer clock;
  clock.start();
  prepareRender();
  const double dpr = devicePixelRatioF();
  const int w = static_cast<int>(width() * dpr + 0.5), h = static_cast<int>(height() * dpr + 0.5);
  if (window_->GetSize()[0] != w || window_->GetSize()[1] != h) window_->SetSize(w, h);
  window_->Render();
  // VTK rendered into its own framebuffer; copy it into the widget's.
  blitToFramebuffer(window_, defaultFramebufferObject(), w, h);
  ++frames_;
  paintSeconds_ += clock.nsecsElapsed() * 1e-9;
}

QPointF VtkViewWidget::toDisplay(const QPointF& p) const {
  const double dpr = devicePixelRatioF();
  return {p.x() * dpr, (height() - p.y()) * dpr};
}

void VtkViewWidget::displayToWorld(const QPointF& widgetPos, double world[3]) const {
  const QPointF d = toDisplay(widgetPos);
  double focal[4];
  vtkCamera* cam = renderer_->GetActiveCamera();
  double fp[3];
  cam->GetFocalPoint(fp);
  renderer_->SetWorldPoint(fp[0], fp[1], fp[2], 1.0);
  renderer_->WorldToDisplay();
  double z = renderer_->GetDisplayPoint()[2];
  renderer_->SetDisplayPoint(d.x(), d.y(), z);
  renderer_->DisplayToWorld();
  renderer_->GetWorldPoint(focal);
  for (int i = 0; i < 3; ++i) world[i] = focal[i] / (focal[3] != 0.0 ? focal[3] : 1.0);
}

}  // namespace sinew
