// What every workstation test program sets before its QApplication exists: GLX (VTK's GLEW fails
// with EGL), shared contexts and an OpenGL 3.2 core default format, as the workstation's main().
#pragma once

#include <QApplication>
#include <QProcess>
#include <QSurfaceFormat>

namespace sinew::testing {

inline void prepareOpenGlForTests() {
  qputenv("QT_XCB_GL_INTEGRATION", "xcb_glx");
  QApplication::setAttribute(Qt::AA_ShareOpenGLContexts);
  QSurfaceFormat format;
  format.setVersion(3, 2);
  format.setProfile(QSurfaceFormat::CoreProfile);
  format.setDepthBufferSize(24);
  format.setStencilBufferSize(8);
  QSurfaceFormat::setDefaultFormat(format);
}

// Where mricron-data keeps the Colin27 atlas and images.
inline const QString kColin27 = "/usr/share/mricron/templates/";

// Writes a Colin27 scene of these structures and per-level iterations (sinew-make-scene: the aal
// atlas on ch2, ch2better as the target); returns its exit code.
inline int makeColin27Scene(const QString& makeScene, const QString& file, const QString& structures,
                            const QString& iterations) {
  return QProcess::execute(makeScene, {"--atlas", kColin27 + "aal.nii.gz", "--labels", kColin27 + "aal.nii.txt",
                                       "--training", kColin27 + "ch2.nii.gz", "--target", kColin27 + "ch2better.nii.gz",
                                       "--structures", structures, "--iterations", iterations, "-o", file});
}

}  // namespace sinew::testing
