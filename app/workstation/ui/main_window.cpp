#include "main_window.h"

#include "panels.h"
#include "plot_widget.h"
#include "slice_view.h"
#include "structure_colour.h"
#include "surface_drawing.h"
#include "volume_view.h"
#ifdef SINEW_WITH_CUDA
#include "interop_drawing.h"
#endif

#include <QActionGroup>
#include <QApplication>
#include <QCloseEvent>
#include <QDockWidget>
#include <QFileDialog>
#include <QFileInfo>
#include <QGridLayout>
#include <QKeyEvent>
#include <QLabel>
#include <QMenuBar>
#include <QMessageBox>
#include <QPointer>
#include <QProgressDialog>
#include <QSettings>
#include <QStatusBar>
#include <QToolBar>
#include <QToolButton>
#include <QVBoxLayout>

#include <cmath>
#include <cstdio>

namespace sinew {

namespace {
constexpr int kMaxRecent = 8;
// Samples evaluate ASSD against the ground truth, which costs; while running they are spaced so
// that evaluation takes at most a tenth of the time (and at least every kMinSampleSeconds).
constexpr double kMinSampleSeconds = 0.5;

std::unique_ptr<SurfaceDrawing> chooseDrawing(const WorkstationOptions& o, SegmentationSession& session);
}  // namespace

MainWindow::MainWindow(const Registry& registry, const ToolRegistry& tools, WorkstationOptions options, QWidget* parent)
    : QMainWindow(parent), registry_(registry), tools_(tools), options_(std::move(options)), session_(registry) {
  setWindowTitle("Sinew");
  drawing_ = makeHostDrawing();
  buildViews();
  buildPanels();
  buildActions();
  statusRate_ = new QLabel(this);
  statusBackend_ = new QLabel(this);
  statusBar()->addPermanentWidget(statusRate_);
  statusBar()->addPermanentWidget(statusBackend_);
  timer_.setInterval(0);
  connect(&timer_, &QTimer::timeout, this, &MainWindow::tick);
  if (options_.persistSettings) {
    QSettings s;
    restoreGeometry(s.value("window/geometry").toByteArray());
    restoreState(s.value("window/state").toByteArray());
  }
  selectTool("navigate");
  startAutosave();
  updateActions();
  updateStatus();
}

MainWindow::~MainWindow() {
  timer_.stop();
  tool_.reset();
}

// --- layout --------------------------------------------------------------------------------------

void MainWindow::buildViews() {
  auto* central = new QWidget(this);
  auto* grid = new QGridLayout(central);
  grid->setContentsMargins(0, 0, 0, 0);
  grid->setSpacing(2);
  auto frame = [&](QWidget* view, const QString& title, int index) {
    auto* f = new QWidget(central);
    auto* v = new QVBoxLayout(f);
    v->setContentsMargins(0, 0, 0, 0);
    v->setSpacing(0);
    auto* bar = new QHBoxLayout;
    auto* label = new QLabel(title, f);
    auto* max = new QToolButton(f);
    max->setText("⛶");
    max->setToolTip(tr("Maximise this view / back to four views (double-click the title does the same)"));
    max->setAutoRaise(true);
    connect(max, &QToolButton::clicked, this, [this, index] { maximiseView(maximised_ == index ? -1 : index); });
    bar->addWidget(label, 1);
    bar->addWidget(max);
    v->addLayout(bar);
    v->addWidget(view, 1);
    frames_[index] = f;
    return f;
  };
  const int axes[3] = {2, 1, 0};  // axial top-left, coronal top-right, sagittal bottom-left
  for (int i = 0; i < 3; ++i) {
    const int axis = axes[i];
    auto* view = new SliceView(axis, display_, central);
    slices_[axis] = view;
    grid->addWidget(frame(view, tr(SliceView::axisName(axis)), axis), i / 2, i % 2);
    view->setProviders(
        [this](const SlicePlane& plane) { return drawing_->contours(session_, plane); },
        [this](Index s) { return session_.isOpen() ? session_.attractionPoints(s) : std::vector<Vec3>{}; });
    view->setLandmarksProvider([this] { return landmarkPairs(); });
    view->setMarkersProvider([this](Index s) { return markers(s); });
    connect(view, &SliceView::toolPressed, this, [this](const ViewPointerEvent& e) {
      if (!tool_) return;
      auto ctx = toolContext();
      try {
        tool_->press(ctx, e);
      } catch (const std::exception& ex) {
        showError(tr("Edit"), QString::fromUtf8(ex.what()));
      }
      afterEdit();
    });
    connect(view, &SliceView::toolDragged, this, [this](const ViewPointerEvent& e) {
      if (!tool_) return;
      auto ctx = toolContext();
      tool_->drag(ctx, e);
      afterEdit();
    });
    connect(view, &SliceView::toolReleased, this, [this](const ViewPointerEvent& e) {
      if (!tool_) return;
      auto ctx = toolContext();
      tool_->release(ctx, e);
      afterEdit();
    });
    connect(view, &SliceView::cursorMoved, this, [this] { invalidateViews(); });
    connect(view, &SliceView::windowLevelChanged, this, [this] {
      for (auto* v : slices_) v->update();
      volume_->update();
    });
  }
  volume_ = new VolumeView(display_, central);
  volume_->setPointsProvider(
      [this](Index s) { return session_.isOpen() ? session_.attractionPoints(s) : std::vector<Vec3>{}; });
  volume_->setLandmarksProvider([this] { return landmarkPairs(); });
  volume_->setMarkersProvider([this](Index s) { return markers(s); });
  volume_->setMapperFactory([this](Index s) { return drawing_->makeMapper(s); });
  volume_->beforeRender = [this] {
    if (session_.isOpen()) drawing_->beforeRender(session_, display_);
  };
  grid->addWidget(frame(volume_, tr("3D"), 3), 1, 1);
  setCentralWidget(central);
}

void MainWindow::maximiseView(int view) {
  maximised_ = view;
  for (int i = 0; i < 4; ++i) frames_[i]->setVisible(view < 0 || i == view);
}

void MainWindow::buildPanels() {
  auto dock = [&](QWidget* w, const QString& title, const char* name, Qt::DockWidgetArea area) {
    auto* d = new QDockWidget(title, this);
    d->setObjectName(name);
    d->setWidget(w);
    addDockWidget(area, d);
    return d;
  };
  scenePanel_ = new ScenePanel(session_, display_, this);
  paramsPanel_ = new ParametersPanel(session_, display_, this);
  schedulePanel_ = new SchedulePanel(session_, this);
  plot_ = new PlotWidget(this);
  dock(scenePanel_, tr("Scene"), "scene", Qt::LeftDockWidgetArea);
  dock(schedulePanel_, tr("Integrator and schedule"), "schedule", Qt::LeftDockWidgetArea);
  dock(paramsPanel_, tr("Forces"), "forces", Qt::RightDockWidgetArea);
  dock(plot_, tr("Error against time"), "plot", Qt::RightDockWidgetArea);
  connect(scenePanel_, &ScenePanel::selectionChanged, this, [this] { paramsPanel_->refresh(); });
  connect(scenePanel_, &ScenePanel::lookChanged, this, [this] { invalidateViews(); });
  connect(paramsPanel_, &ParametersPanel::edited, this, &MainWindow::afterEdit);
  connect(paramsPanel_, &ParametersPanel::failed, this, [this](const QString& m) { showError(tr("Parameter"), m); });
}

void MainWindow::buildActions() {
  QMenu* file = menuBar()->addMenu(tr("&File"));
  openScene_ = file->addAction(tr("&Open Scene..."), QKeySequence::Open, this, [this] {
    QSettings s;
    const QString f = QFileDialog::getOpenFileName(this, tr("Open scene"), s.value("dirs/scene").toString(),
                                                   tr("Sinew scenes (*.json *.sinew.json);;All files (*)"));
    if (!f.isEmpty()) openScene(f);
  });
  openImage_ = file->addAction(tr("Open &Image..."), QKeySequence(tr("Ctrl+I")), this, [this] {
    QSettings s;
    const QString f = QFileDialog::getOpenFileName(this, tr("Open image"), s.value("dirs/image").toString(),
                                                   tr("Images (*.nii *.nii.gz *.nrrd *.nhdr *.mha *.mhd);;All files (*)"));
    if (!f.isEmpty()) openImage(f);
  });
  recentMenu_ = file->addMenu(tr("Open &Recent"));
  file->addSeparator();
  saveScene_ = file->addAction(tr("&Save Scene"), QKeySequence::Save, this, [this] { saveScene(false); });
  saveSceneAs_ = file->addAction(tr("Save Scene &As..."), QKeySequence::SaveAs, this, [this] { saveScene(true); });
  saveMeshes_ = file->addAction(tr("Save &Meshes..."), this, &MainWindow::saveMeshes);
  exportLabels_ = file->addAction(tr("&Export Label Map..."), this, &MainWindow::exportLabelMap);
  file->addSeparator();
  quit_ = file->addAction(tr("&Quit"), QKeySequence::Quit, this, &QWidget::close);
  rebuildRecentMenu();

  QMenu* edit = menuBar()->addMenu(tr("&Edit"));
  undo_ = edit->addAction(tr("&Undo"), QKeySequence::Undo, this, [this] {
    session_.undo();
    sessionChanged();
  });
  redo_ = edit->addAction(tr("&Redo"), QKeySequence::Redo, this, [this] {
    session_.redo();
    sessionChanged();
  });
  deletePoint_ = edit->addAction(tr("&Delete Selected Point"), QKeySequence::Delete, this, [this] {
    if (!tool_ || !session_.isOpen()) return;
    auto ctx = toolContext();
    tool_->deleteSelection(ctx);
    afterEdit();
  });

  QMenu* sim = menuBar()->addMenu(tr("&Simulation"));
  run_ = sim->addAction(tr("&Run"), QKeySequence(tr("Space")), this, [this] { setRunning(!isRunning()); });
  step_ = sim->addAction(tr("&Step"), QKeySequence(tr("S")), this, &MainWindow::stepOnce);
  nextLevel_ = sim->addAction(tr("&Next Level"), QKeySequence(tr("L")), this, &MainWindow::nextLevel);
  initialiseLandmarks_ = sim->addAction(tr("&Initialise from Landmarks"), this, &MainWindow::initialiseFromLandmarks);

  QMenu* view = menuBar()->addMenu(tr("&View"));
  resetViews_ = view->addAction(tr("&Reset Views"), QKeySequence(tr("R")), this, [this] {
    for (auto* v : slices_) v->resetCamera(), v->update();
    volume_->resetCamera();
    volume_->update();
  });
  maximise_ = view->addAction(tr("&Maximise View"), QKeySequence(tr("Ctrl+M")), this, [this] {
    int focused = -1;
    for (int a = 0; a < 3; ++a)
      if (slices_[a]->hasFocus()) focused = a;
    if (volume_->hasFocus()) focused = 3;
    maximiseView(maximised_ >= 0 ? -1 : std::max(focused, 2));
  });
  // The markers are drawn anew when the views are invalidated, not only when the state moves.
  const auto redrawMarkers = [this] { invalidateViews(); };
  showContacts_ = view->addAction(tr("Show &Contacts"), QKeySequence(tr("C")), this, redrawMarkers);
  showContacts_->setCheckable(true);
  showContacts_->setToolTip(tr("Mark, in orange, the vertices inside another structure or within the collision "
                               "margin of it"));
  showThickness_ = view->addAction(tr("Show &Thickness"), QKeySequence(tr("T")), this, redrawMarkers);
  showThickness_->setCheckable(true);
  showThickness_->setToolTip(tr("Colour every vertex by its structure's medial radius there (half the local "
                                "thickness): red 1 mm or less, through yellow and green, to blue 6 mm or more"));
  showFit_ = view->addAction(tr("Show Image &Fit"), QKeySequence(tr("F")), this, redrawMarkers);
  showFit_->setCheckable(true);
  showFit_->setToolTip(tr("Colour every vertex by how well the image around it looks as the profiles were "
                          "trained: red 0.3 or less, yellow 0.6 (check), green 0.9 or more"));
  // Both colour every vertex: one at a time, or none.
  auto* colourings = new QActionGroup(this);
  colourings->setExclusionPolicy(QActionGroup::ExclusionPolicy::ExclusiveOptional);
  colourings->addAction(showThickness_);
  colourings->addAction(showFit_);

  QToolBar* bar = addToolBar(tr("Main"));
  bar->setObjectName("main");
  bar->addAction(openScene_);
  bar->addAction(saveScene_);
  bar->addSeparator();
  bar->addAction(run_);
  bar->addAction(step_);
  bar->addAction(nextLevel_);
  bar->addSeparator();
  bar->addAction(undo_);
  bar->addAction(redo_);
  bar->addSeparator();
  QMenu* toolsMenu = menuBar()->addMenu(tr("&Tools"));
  toolGroup_ = new QActionGroup(this);
  for (const ToolDescriptor& t : tools_.tools()) {
    QAction* a = toolsMenu->addAction(QString::fromStdString(t.label));
    a->setCheckable(true);
    a->setToolTip(QString::fromStdString(t.summary));
    a->setShortcut(QKeySequence(QString::fromStdString(t.shortcut)));
    a->setData(QString::fromStdString(t.name));
    toolGroup_->addAction(a);
    bar->addAction(a);
    connect(a, &QAction::triggered, this, [this, name = t.name] { selectTool(name); });
  }
}

// --- files ---------------------------------------------------------------------------------------

bool MainWindow::openScene(const QString& file) {
  setRunning(false);
  // Opening replaces the session's backend; the interop path is bound to the old one, and the
  // progress dialog repaints the views while the new scene loads.
  drawing_ = makeHostDrawing();
  QProgressDialog progress(tr("Opening %1...").arg(QFileInfo(file).fileName()), QString(), 0, 0, this);
  progress.setWindowModality(Qt::WindowModal);
  progress.setMinimumDuration(300);
  try {
    session_.open(file.toStdString(), sessionOptions(progress));
  } catch (const std::exception& e) {
    progress.close();
    showError(tr("Open scene"), QString::fromUtf8(e.what()));
    return false;
  }
  progress.close();
  imageOnly_.reset();
  sceneFile_ = file;
  sessionReplaced();
  addRecent(file);
  if (options_.persistSettings) QSettings().setValue("dirs/scene", QFileInfo(file).absolutePath());
  setWindowTitle(QString("Sinew - %1").arg(QFileInfo(file).fileName()));
  statusBar()->showMessage(tr("Opened %1").arg(file), 5000);
  refreshViews();
  updateActions();
  updateStatus();
  return true;
}

bool MainWindow::openImage(const QString& file) {
  setRunning(false);
  try {
    const std::filesystem::path p = file.toStdString();
    imageOnly_ = std::make_shared<Image3D>(registry_.imageIOFor(p).readImage(p));
  } catch (const std::exception& e) {
    showError(tr("Open image"), QString::fromUtf8(e.what()));
    return false;
  }
  drawing_ = makeHostDrawing();
  session_.close();
  if (recovery_) recovery_->clear();
  sceneFile_.clear();
  display_.resetImage(*imageOnly_);
  for (auto* v : slices_) v->resetScene();
  volume_->resetScene();
  scenePanel_->rebuild();
  paramsPanel_->rebuild();
  schedulePanel_->rebuild();
  plot_->setSamples({}, false);
  addRecent(file);
  if (options_.persistSettings) QSettings().setValue("dirs/image", QFileInfo(file).absolutePath());
  setWindowTitle(QString("Sinew - %1").arg(QFileInfo(file).fileName()));
  updateActions();
  updateStatus();
  return true;
}

void MainWindow::saveScene(bool askName) {
  if (!session_.isOpen()) return;
  QString file = sceneFile_;
  if (askName || file.isEmpty())
    file = QFileDialog::getSaveFileName(this, tr("Save scene"), sceneFile_, tr("Sinew scenes (*.json)"));
  if (file.isEmpty()) return;
  try {
    session_.saveScene(file.toStdString());
    sceneFile_ = file;
    addRecent(file);
    statusBar()->showMessage(tr("Saved %1").arg(file), 5000);
  } catch (const std::exception& e) {
    showError(tr("Save scene"), QString::fromUtf8(e.what()));
  }
}

void MainWindow::saveMeshes() {
  if (!session_.isOpen()) return;
  const QString dir = QFileDialog::getExistingDirectory(this, tr("Save meshes into"));
  if (dir.isEmpty()) return;
  try {
    const auto files = session_.saveMeshes(dir.toStdString(), session_.scene().meshFormat);
    statusBar()->showMessage(tr("Wrote %1 meshes into %2").arg(files.size()).arg(dir), 5000);
  } catch (const std::exception& e) {
    showError(tr("Save meshes"), QString::fromUtf8(e.what()));
  }
}

void MainWindow::exportLabelMap() {
  if (!session_.isOpen()) return;
  const QString file = QFileDialog::getSaveFileName(this, tr("Export label map"), "segmentation.nii.gz",
                                                    tr("Label maps (*.nii.gz *.nii *.nrrd *.mha)"));
  if (file.isEmpty()) return;
  try {
    session_.exportLabelMap(file.toStdString());
    statusBar()->showMessage(tr("Wrote %1").arg(file), 5000);
  } catch (const std::exception& e) {
    showError(tr("Export label map"), QString::fromUtf8(e.what()));
  }
}

void MainWindow::addRecent(const QString& file) {
  if (!options_.persistSettings) return;
  QSettings s;
  QStringList list = s.value("recent").toStringList();
  list.removeAll(QFileInfo(file).absoluteFilePath());
  list.prepend(QFileInfo(file).absoluteFilePath());
  while (list.size() > kMaxRecent) list.removeLast();
  s.setValue("recent", list);
  rebuildRecentMenu();
}

void MainWindow::rebuildRecentMenu() {
  recentMenu_->clear();
  const QStringList list = options_.persistSettings ? QSettings().value("recent").toStringList() : QStringList();
  for (const QString& f : list)
    recentMenu_->addAction(f, this, [this, f] {
      if (f.endsWith(".json")) openScene(f);
      else openImage(f);
    });
  recentMenu_->setEnabled(!list.isEmpty());
}

void MainWindow::showError(const QString& what, const QString& message) {
  statusBar()->showMessage(what + ": " + message, 10000);
  if (QApplication::platformName() != "offscreen" && isVisible()) QMessageBox::warning(this, what, message);
}

// --- simulation ----------------------------------------------------------------------------------

void MainWindow::setRunning(bool running) {
  if (running && !session_.isOpen()) return;
  if (running == timer_.isActive()) return;
  if (running) {
    timer_.start();
    fpsClock_.start();
    sampleClock_.start();
    fpsFrames_ = 0;
    fpsIterations_ = 0;
    budgetCredit_ = 0.0;
  } else {
    timer_.stop();
  }
  updateActions();
}

void MainWindow::stepOnce() {
  if (!session_.isOpen()) return;
  try {
    session_.step(1);
  } catch (const NumericalError& e) {
    setRunning(false);
    showError(tr("Numerical failure"), QString::fromUtf8(e.what()));
  }
  session_.sample();
  refreshViews();
}

// How sessions open: the window's threads, backend and plugins, loading steps shown in `progress`.
SessionOpenOptions MainWindow::sessionOptions(QProgressDialog& progress) {
  SessionOpenOptions o;
  o.threads = options_.threads;
  o.backend = options_.backend;
  o.requirePlugin = options_.requirePlugin;
  // The session keeps this log for later messages (a backend that fails, the stability guard): by
  // then the dialog is gone.
  o.log = [this, dialog = QPointer<QProgressDialog>(&progress)](const std::string& m) {
    statusBar()->showMessage(QString::fromStdString(m), 10000);
    if (!dialog) return;
    dialog->setLabelText(QString::fromStdString(m));
    QCoreApplication::processEvents(QEventLoop::ExcludeUserInputEvents);
  };
  return o;
}

void MainWindow::sessionReplaced() {
  drawing_ = chooseDrawing(options_, session_);
  display_.reset(session_);
  for (auto* v : slices_) v->resetScene();
  volume_->resetScene();
  scenePanel_->rebuild();
  paramsPanel_->rebuild();
  schedulePanel_->rebuild();
  shownRevision_ = 0;
  plottedSamples_ = 0;
}

std::vector<std::pair<Vec3, Vec3>> MainWindow::landmarkPairs() {
  std::vector<std::pair<Vec3, Vec3>> out;
  if (session_.isOpen())
    for (const PlacedLandmark& l : session_.landmarks()) out.emplace_back(l.from, l.to);
  return out;
}

// The model mapped through the landmark pairs; the segmentation starts again from there.
void MainWindow::initialiseFromLandmarks() {
  if (!session_.isOpen()) return;
  setRunning(false);
  drawing_ = makeHostDrawing();  // the interop path is bound to the backend being replaced
  QProgressDialog progress(tr("Initialising from landmarks..."), QString(), 0, 0, this);
  progress.setWindowModality(Qt::WindowModal);
  progress.setMinimumDuration(300);
  try {
    session_.initialiseFromLandmarks(sessionOptions(progress));
  } catch (const std::exception& e) {
    progress.close();
    drawing_ = chooseDrawing(options_, session_);
    showError(tr("Initialise from landmarks"), QString::fromUtf8(e.what()));
    return;
  }
  progress.close();
  sessionReplaced();
  statusBar()->showMessage(tr("Initialised from %1 landmark pairs").arg(session_.scene().initialise.landmarks.size()), 5000);
  refreshViews();
  updateActions();
  updateStatus();
}

void MainWindow::nextLevel() {
  if (!session_.isOpen()) return;
  if (!session_.nextLevel()) {
    statusBar()->showMessage(tr("Already at the finest level"), 3000);
    return;
  }
  sessionChanged();
}

void MainWindow::tick() {
  // The budget is simulation time per frame on average: a step that costs more than one frame's
  // budget runs every few frames, so the views stay responsive on large meshes.
  const double budget = schedulePanel_->budgetMs() * 1e-3;
  budgetCredit_ = std::min(budgetCredit_ + budget, 2.0 * std::max(budget, session_.secondsPerStep()));
  int steps = -1;  // -1: no step this frame
  if (budgetCredit_ >= session_.secondsPerStep()) {
    QElapsedTimer spent;
    spent.start();
    try {
      steps = session_.stepFor(budgetCredit_, followSchedule_);
    } catch (const std::exception& e) {
      setRunning(false);
      showError(tr("Simulation stopped"), QString::fromUtf8(e.what()));
      return;
    }
    budgetCredit_ -= spent.nsecsElapsed() * 1e-9;
    simulationSeconds_ += spent.nsecsElapsed() * 1e-9;
  }
  if (steps == 0) {  // the level's iterations are done: the next level, or the end of the schedule
    if (session_.level() + 1 < session_.levelCount()) {
      session_.nextLevel();
      sessionChanged();
    } else {
      setRunning(false);
      session_.sample();
      const QString poor = scenePanel_->showImageFit();
      if (poor.isEmpty()) statusBar()->showMessage(tr("Schedule finished"), 5000);
      else statusBar()->showMessage(tr("Schedule finished; check %1: the image does not look as trained there").arg(poor));
    }
  }
  fpsIterations_ += std::max(steps, 0);
  if (sampling_ && sampleClock_.elapsed() > 1000 * std::max(kMinSampleSeconds, 10 * sampleCost_)) {
    QElapsedTimer cost;
    cost.start();
    session_.sample();
    sampleCost_ = cost.elapsed() * 1e-3;
    sampleClock_.restart();
  }
  QElapsedTimer updating;
  updating.start();
  refreshViews();
  updateSeconds_ += updating.nsecsElapsed() * 1e-9;
  // One paint of the whole window per frame (every view composed once), before the next tick.
  for (auto* v : slices_) v->update();
  volume_->update();
  ++fpsFrames_;
  ++framesDrawn_;
  const double elapsed = fpsClock_.elapsed() * 1e-3;
  if (elapsed > 1.0) {
    fps_ = fpsFrames_ / elapsed;
    itPerSecond_ = fpsIterations_ / elapsed;
    fpsFrames_ = 0;
    fpsIterations_ = 0;
    fpsClock_.restart();
    updateStatus();
  }
}

void MainWindow::refreshViews() {
  if (!session_.isOpen()) {
    invalidateViews();
    return;
  }
  if (session_.revision() != shownRevision_) {
    drawing_->updateSurfaces(session_, display_);
    shownRevision_ = session_.revision();
    invalidateViews();
    scenePanel_->refresh();
    schedulePanel_->refresh();
    if (session_.timeline().size() != plottedSamples_) {
      plot_->setSamples(session_.timeline(), session_.hasGroundTruth());
      plottedSamples_ = session_.timeline().size();
    }
    updateActions();
  }
}

void MainWindow::sessionChanged() {
  paramsPanel_->refresh();
  refreshViews();
}

void MainWindow::afterEdit() {
  refreshViews();
  updateActions();
}

void MainWindow::invalidateViews() {
  for (auto* v : slices_) v->invalidate();
  volume_->invalidate();
}

ToolContext MainWindow::toolContext() {
  return {session_, display_, [this] { invalidateViews(); }};
}

void MainWindow::selectTool(const std::string& name) {
  const ToolDescriptor* d = tools_.find(name);
  if (!d) return;
  tool_ = d->create();
  for (QAction* a : toolGroup_->actions()) a->setChecked(a->data().toString().toStdString() == name);
}

void MainWindow::updateActions() {
  const bool open = session_.isOpen();
  for (QAction* a : {saveScene_, saveSceneAs_, saveMeshes_, exportLabels_, run_, step_, nextLevel_}) a->setEnabled(open);
  initialiseLandmarks_->setEnabled(open && session_.landmarks().size() >= 4);
  run_->setText(isRunning() ? tr("Pause") : tr("Run"));
  undo_->setEnabled(open && session_.canUndo());
  redo_->setEnabled(open && session_.canRedo());
  undo_->setText(session_.canUndo() ? tr("Undo %1").arg(QString::fromStdString(session_.undoLabel())) : tr("Undo"));
  redo_->setText(session_.canRedo() ? tr("Redo %1").arg(QString::fromStdString(session_.redoLabel())) : tr("Redo"));
}

void MainWindow::updateStatus() {
  if (!session_.isOpen()) {
    statusRate_->setText(imageOnly_ ? tr("image only: open a scene to segment") : tr("no scene"));
    statusBackend_->clear();
    return;
  }
  statusRate_->setText(tr("level %1/%2 · iteration %3 · %4 it/s · %5 frames/s")
                           .arg(session_.level())
                           .arg(session_.levelCount() - 1)
                           .arg(session_.simulation().iteration())
                           .arg(itPerSecond_, 0, 'f', 0)
                           .arg(fps_, 0, 'f', 1));
  statusBackend_->setText(tr("backend %1 (%2) · drawing %3")
                              .arg(QString::fromStdString(session_.backendName()))
                              .arg(QString::fromStdString(session_.deviceName()))
                              .arg(QString::fromStdString(drawing_->name())));
}

void MainWindow::setFrameBudgetMs(double ms) { schedulePanel_->setBudgetMs(ms); }

std::string MainWindow::drawingPath() const { return drawing_->name(); }

void MainWindow::closeEvent(QCloseEvent* e) {
  // Stop stepping first: nothing runs while the window and its GL contexts go away.
  setRunning(false);
  if (options_.persistSettings) {
    QSettings s;
    s.setValue("window/geometry", saveGeometry());
    s.setValue("window/state", saveState());
  }
  e->accept();
}

namespace {
// interop when the CUDA engine runs the steps (unless the host path was asked for); the host path
// otherwise, with a note when interop was asked for and is not possible.
std::unique_ptr<SurfaceDrawing> chooseDrawing(const WorkstationOptions& o, SegmentationSession& session) {
  if (o.drawing != "host") {
#ifdef SINEW_WITH_CUDA
    if (auto interop = makeInteropDrawing(session)) return interop;
#endif
    if (o.drawing == "interop")
      std::fprintf(stderr, "sinew: interop drawing needs the CUDA backend (backend: %s); drawing from the host\n",
                   session.backendName().c_str());
  }
  return makeHostDrawing();
}
}  // namespace

}  // namespace sinew
