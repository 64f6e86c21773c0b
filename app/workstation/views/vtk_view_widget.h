// A VTK render window hosted in a Qt6 QOpenGLWidget. Debian 12's VTK Qt module is built against
// Qt5, so Sinew does not use it: VTK renders into its own framebuffer inside Qt's context and the
// widget blits the result into its default framebuffer in paintGL (VTK 9.1 cannot be told to render
// into Qt's framebuffer). Interaction is handled by the Qt subclasses, not by VTK interactor styles.
#pragma once

#include <QOpenGLWidget>
#include <QPointF>

#include <vtkSmartPointer.h>

class vtkGenericOpenGLRenderWindow;
class vtkGenericRenderWindowInteractor;
class vtkRenderer;

namespace sinew {

class VtkViewWidget : public QOpenGLWidget {
  Q_OBJECT
public:
  explicit VtkViewWidget(QWidget* parent = nullptr);
  ~VtkViewWidget() override;

  vtkRenderer* renderer() const;
  vtkGenericOpenGLRenderWindow* renderWindow() const;
  // Widget position (logical pixels, origin top-left) -> VTK display position (device pixels,
  // origin bottom-left).
  QPointF toDisplay(const QPointF& widgetPos) const;
  // Where a widget position lies in world (scene) coordinates on the focal plane of the camera.
  void displayToWorld(const QPointF& widgetPos, double world[3]) const;
  long framesRendered() const { return frames_; }
  // Wall time spent in paintGL so far (CPU side: GL work still queued is not included).
  double paintSeconds() const { return paintSeconds_; }

protected:
  void initializeGL() override;
  void resizeGL(int w, int h) override;
  void paintGL() override;
  // Called just before VTK renders (subclasses bring their actors up to date here).
  virtual void prepareRender() {}

private:
  vtkSmartPointer<vtkGenericOpenGLRenderWindow> window_;
  vtkSmartPointer<vtkGenericRenderWindowInteractor> interactor_;
  vtkSmartPointer<vtkRenderer> renderer_;
  QMetaObject::Connection contextConnection_;
  bool contextReady_ = false;
  long frames_ = 0;
  double paintSeconds_ = 0.0;
};

}  // namespace sinew
