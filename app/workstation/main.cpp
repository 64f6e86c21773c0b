// sinew: the desktop workstation. Opens a scene (or an image), shows it in four views and segments
// it live; see docs/workstation.md.
#include "builtin_plugins.h"
#include "interaction_tool.h"
#include "main_window.h"
#include "slice_view.h"
#include "volume_view.h"

#include <CLI/CLI.hpp>
#include <QApplication>
#include <QElapsedTimer>
#include <QMessageBox>
#include <QStandardPaths>
#include <QSurfaceFormat>
#include <QTimer>

#include <algorithm>
#include <cstdio>
#include <vector>

int main(int argc, char** argv) {
  CLI::App cli{"sinew: the Sinew workstation (segment by looking and clicking)."};
  std::string scene, image;
  sinew::WorkstationOptions options;
  double measureSeconds = 0.0;
  std::string screenshot;
  std::vector<int> windowSize{1400, 900};
  double budgetMs = 0.0;
  int level = 0;
  cli.add_option("scene", scene, "scene file to open");
  cli.add_option("--image", image, "an image to view (without a scene)");
  cli.add_option("--backend", options.backend, "auto: CUDA when a usable GPU exists, else the CPU")
      ->check(CLI::IsMember({"auto", "cuda", "cpu"}))
      ->capture_default_str();
  cli.add_option("--drawing", options.drawing, "how the 3D view gets the meshes: interop (CUDA-OpenGL), host, auto")
      ->check(CLI::IsMember({"auto", "interop", "host"}))
      ->capture_default_str();
  cli.add_option("-j,--threads", options.threads, "CPU threads (0 = all)")->check(CLI::NonNegativeNumber);
  cli.add_option("--measure-fps", measureSeconds,
                 "benchmark: run the scene for this many seconds (after 2 s of warm-up), print frames/s as JSON, exit");
  cli.add_option("--level", level, "with --measure-fps: level of detail to measure at")->check(CLI::NonNegativeNumber);
  cli.add_option("--budget-ms", budgetMs, "simulation time budget per frame (default: the saved setting, 30 ms)")
      ->check(CLI::Range(1.0, 1000.0));
  cli.add_option("--window-size", windowSize, "initial window size in pixels (width height)")
      ->expected(2)
      ->check(CLI::Range(200, 10000))
      ->capture_default_str();
  bool noAutosave = false;
  std::string recoveryDir;
  auto* autosaveOption = cli.add_option("--autosave-seconds", options.autosaveSeconds,
                                        "crash recovery: autosave after at most this many seconds of changes")
                             ->check(CLI::Range(1.0, 3600.0))
                             ->capture_default_str();
  cli.add_flag("--no-autosave", noAutosave, "no autosave and no crash recovery");
  cli.add_option("--recovery-dir", recoveryDir, "where autosaves are kept (default: the user's data directory)");
  cli.add_option("--screenshot", screenshot, "with --measure-fps: save the window as a PNG at the end");
  cli.set_version_flag("--version", std::string("sinew ") + SINEW_VERSION);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;
  }

  // VTK's GLEW needs GLX (EGL breaks it); contexts are shared so a view can move between windows.
  if (qEnvironmentVariableIsEmpty("QT_XCB_GL_INTEGRATION")) qputenv("QT_XCB_GL_INTEGRATION", "xcb_glx");
  QApplication::setAttribute(Qt::AA_ShareOpenGLContexts);
  QSurfaceFormat format;
  format.setRenderableType(QSurfaceFormat::OpenGL);
  format.setVersion(3, 2);
  format.setProfile(QSurfaceFormat::CoreProfile);
  format.setDepthBufferSize(24);
  format.setStencilBufferSize(8);
  format.setSwapInterval(measureSeconds > 0 ? 0 : 1);
  QSurfaceFormat::setDefaultFormat(format);
  QApplication app(argc, argv);
  QApplication::setApplicationName("Sinew");
  QApplication::setOrganizationName("Sinew");
  QApplication::setApplicationVersion(SINEW_VERSION);

  // Built-in plugins, then every run-time plugin on the search path (tools cannot wait for a
  // scene to name them); one that fails is reported and the others still load.
  sinew::Registry registry;
  sinew::ToolRegistry tools;
  sinew::PluginLoader plugins(registry, &tools);
  sinew::addBuiltinPlugins(plugins);
  sinew::addBuiltinTools(plugins);
  plugins.loadAll();
  for (const auto& failure : plugins.failures())
    std::fprintf(stderr, "sinew: plugin not loaded: %s\n", failure.message.c_str());
  options.requirePlugin = [&plugins](const std::string& name) { plugins.load(name); };
  if (measureSeconds > 0) options.persistSettings = false;
  // Autosave: on, except in benchmarks unless asked for (its cost is then measured).
  if (!noAutosave && (measureSeconds <= 0 || autosaveOption->count() > 0))
    options.recoveryRoot = recoveryDir.empty()
                               ? (QStandardPaths::writableLocation(QStandardPaths::AppDataLocation) + "/recovery").toStdString()
                               : recoveryDir;
  sinew::MainWindow window(registry, tools, options);
  window.resize(windowSize[0], windowSize[1]);
  if (budgetMs > 0) window.setFrameBudgetMs(budgetMs);
  window.show();
  if (!plugins.failures().empty() && measureSeconds <= 0) {  // users of the desktop see no stderr
    QString text;
    for (const auto& failure : plugins.failures()) text += QString::fromStdString(failure.message) + "\n\n";
    auto* box = new QMessageBox(QMessageBox::Warning, "Sinew", "Some plugins were not loaded; the others are available.",
                                QMessageBox::Ok, &window);
    box->setDetailedText(text.trimmed());
    box->setAttribute(Qt::WA_DeleteOnClose);
    box->open();
  }
  // A workstation that died left its session: offered before anything else opens.
  if (measureSeconds <= 0) window.offerRecovery();
  const bool restored = window.session().isOpen();
  if (!restored && !image.empty() && !window.openImage(QString::fromStdString(image))) return 3;
  if (!restored && !scene.empty() && !window.openScene(QString::fromStdString(scene))) return 3;
  if (measureSeconds <= 0) return app.exec();

  // Benchmark mode: the same frame loop as a user's Run, measured after a warm-up.
  if (scene.empty()) {
    std::fprintf(stderr, "sinew: --measure-fps needs a scene\n");
    return 2;
  }
  while (window.session().level() < level && window.session().nextLevel()) {
  }
  window.refreshViews();
  window.setFollowSchedule(false);
  window.setSampling(false);
  window.setRunning(true);
  QElapsedTimer clock;
  clock.start();
  long frames0 = 0, iterations0 = 0, paints0 = 0;
  double sim0 = 0.0, update0 = 0.0, paint0 = 0.0;
  bool measuring = false;
  auto paintSeconds = [&] {
    double s = window.volumeView()->paintSeconds();
    for (int axis = 0; axis < 3; ++axis) s += window.sliceView(axis)->paintSeconds();
    return s;
  };
  QTimer poll;
  QObject::connect(&poll, &QTimer::timeout, [&] {
    const double t = clock.elapsed() * 1e-3;
    if (!measuring && t >= 2.0) {
      measuring = true;
      frames0 = window.framesDrawn();
      paints0 = window.volumeView()->framesRendered();
      iterations0 = window.session().simulation().iteration();
      sim0 = window.simulationSeconds();
      update0 = window.updateSeconds();
      paint0 = paintSeconds();
      clock.restart();
    } else if (measuring && t >= measureSeconds) {
      // A frame counts when it was both simulated and painted (paints can coalesce).
      const double frames = double(std::min(window.framesDrawn() - frames0, window.volumeView()->framesRendered() - paints0));
      const double its = double(window.session().simulation().iteration() - iterations0);
      // Per frame: simulation, drawing update (vertex buffers), painting the four views (CPU side),
      // and the rest (Qt composing the window, presenting it, events).
      const double frameMs = 1e3 * t / std::max(frames, 1.0);
      const double simMs = 1e3 * (window.simulationSeconds() - sim0) / std::max(frames, 1.0);
      const double updateMs = 1e3 * (window.updateSeconds() - update0) / std::max(frames, 1.0);
      const double paintMs = 1e3 * (paintSeconds() - paint0) / std::max(frames, 1.0);
      std::printf("{\"frames_per_second\": %.2f, \"iterations_per_second\": %.1f, \"vertices\": %ld, "
                  "\"level\": %d, \"drawing\": \"%s\", \"backend\": \"%s\", \"device\": \"%s\", \"seconds\": %.2f, "
                  "\"ms_per_frame\": {\"simulate\": %.2f, \"update\": %.2f, \"paint\": %.2f, \"rest\": %.2f}, "
                  "\"autosaves\": %d, \"autosave_copy_ms_max\": %.2f}\n",
                  frames / t, its / t, long(window.session().simulation().store().vertexCount()),
                  window.session().level(), window.drawingPath().c_str(), window.session().backendName().c_str(),
                  window.session().deviceName().c_str(), t, simMs, updateMs, paintMs,
                  frameMs - simMs - updateMs - paintMs, window.recovery() ? window.recovery()->savesCompleted() : 0,
                  window.recovery() ? 1e3 * window.recovery()->maxCopySeconds() : 0.0);
      std::fflush(stdout);
      window.setRunning(false);
      if (!screenshot.empty()) window.grab().save(QString::fromStdString(screenshot));
      app.quit();
    }
  });
  poll.start(50);
  return app.exec();
}
