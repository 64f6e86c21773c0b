// The workstation's main window: four views (axial, coronal, sagittal, 3D) in a 2x2 layout with
// one-view maximise, the scene / parameters / schedule / plot panels, Run / Pause / Step / Next
// level, file operations, recent files and settings. The simulation runs in the GUI thread under a
// per-frame time budget (paper 000 section 4.4): edits happen between steps, never during one.
#pragma once

#include "display_scene.h"
#include "interaction_tool.h"
#include "segmentation_session.h"
#include "session_recovery.h"

#include <QElapsedTimer>
#include <QMainWindow>
#include <QTimer>

#include <array>
#include <memory>

class QAction;
class QActionGroup;
class QLabel;
class QMenu;

class QProgressDialog;

namespace sinew {

class ParametersPanel;
class PlotWidget;
class ScenePanel;
class SchedulePanel;
class SliceView;
class SurfaceDrawing;
class VolumeView;

struct WorkstationOptions {
  std::string backend = "auto";  // auto | cuda | cpu
  std::string drawing = "auto";  // auto | interop | host: how the 3D view gets the surfaces
  int threads = 0;
  bool persistSettings = true;   // tests run with false
  // Crash recovery: where every workstation keeps its autosave slot (empty: no autosave), and the
  // most seconds of changes an autosave may lose (docs/workstation.md).
  std::string recoveryRoot;
  double autosaveSeconds = 30.0;
  // Loads a plugin a scene names (PluginLoader::load); see SessionOpenOptions.
  std::function<void(const std::string& plugin)> requirePlugin;
};

class MainWindow : public QMainWindow {
  Q_OBJECT
public:
  MainWindow(const Registry& registry, const ToolRegistry& tools, WorkstationOptions options = {},
             QWidget* parent = nullptr);
  ~MainWindow() override;

  // Opens a scene; on failure shows the error (and returns false) and keeps the current state.
  bool openScene(const QString& file);
  bool openImage(const QString& file);

  SegmentationSession& session() { return session_; }
  DisplayScene& display() { return display_; }
  SliceView* sliceView(int axis) const { return slices_[axis]; }
  VolumeView* volumeView() const { return volume_; }
  void setRunning(bool running);
  bool isRunning() const { return timer_.isActive(); }
  void stepOnce();
  // Off: Run keeps stepping past the schedule's iterations (benchmarks); on by default.
  void setFollowSchedule(bool follow) { followSchedule_ = follow; }
  void setFrameBudgetMs(double ms);
  // Off: no timeline samples while running (benchmarks: the error evaluation would stall frames).
  void setSampling(bool on) { sampling_ = on; }
  void selectTool(const std::string& name);
  // Brings every view up to date with the session now (the frame loop does it while running).
  void refreshViews();
  double framesPerSecond() const { return fps_; }
  // Frames of the run loop so far: each stepped the simulation and repainted every visible view.
  long framesDrawn() const { return framesDrawn_; }
  // Where the frame loop's time went so far: simulation steps, and bringing the drawing up to date
  // (vertex buffers, plots); painting is counted by each view.
  double simulationSeconds() const { return simulationSeconds_; }
  double updateSeconds() const { return updateSeconds_; }
  std::string drawingPath() const;
  // Maximises one view (0..2 slices by axis, 3 the 3D view), or restores the 2x2 layout (-1).
  void maximiseView(int view);

  // Crash recovery (main_window_recovery.cpp): this window's autosave (null when off), and the
  // restore of a slot a dead workstation left (SessionRecovery::orphans). On success the slot is
  // removed; on failure the error is shown and the slot kept.
  SessionRecovery* recovery() const { return recovery_.get(); }
  bool restoreRecovered(const QString& folder);
  // Asks whether to restore what a workstation that died left behind (the newest), if anything.
  void offerRecovery();

protected:
  void closeEvent(QCloseEvent* e) override;

private:
  void buildViews();
  void buildActions();
  void buildPanels();
  void tick();
  void sessionChanged();  // after open, undo, level change
  void afterEdit();
  void updateActions();
  void updateStatus();
  void addRecent(const QString& file);
  void rebuildRecentMenu();
  void showError(const QString& what, const QString& message);
  void saveScene(bool askName);
  void saveMeshes();
  void exportLabelMap();
  void nextLevel();
  void initialiseFromLandmarks();
  void sessionReplaced();  // the views, panels and plot rebuilt for a newly loaded session
  void startAutosave();
  void autosave();
  std::vector<std::pair<Vec3, Vec3>> landmarkPairs();
  // What the views draw in colours of their own (main_window_markers.cpp): include (green) and
  // exclude (red) points, with View > Show Thickness or Show Image Fit every vertex in its thickness
  // or fit colour, and with View > Show Contacts the vertices in contact regions (orange).
  std::vector<Marker> markers(Index structure);
  SessionOpenOptions sessionOptions(QProgressDialog& progress);
  ToolContext toolContext();
  void invalidateViews();  // every view draws again (surfaces and markers)

  const Registry& registry_;
  const ToolRegistry& tools_;
  WorkstationOptions options_;
  SegmentationSession session_;
  DisplayScene display_;
  std::shared_ptr<Image3D> imageOnly_;
  std::unique_ptr<SurfaceDrawing> drawing_;
  std::unique_ptr<InteractionTool> tool_;
  std::array<SliceView*, 3> slices_{};
  VolumeView* volume_ = nullptr;
  std::array<QWidget*, 4> frames_{};
  int maximised_ = -1;
  ScenePanel* scenePanel_ = nullptr;
  ParametersPanel* paramsPanel_ = nullptr;
  SchedulePanel* schedulePanel_ = nullptr;
  PlotWidget* plot_ = nullptr;
  QLabel* statusRate_ = nullptr;
  QLabel* statusBackend_ = nullptr;
  QTimer timer_;
  QTimer autosaveTimer_;
  std::unique_ptr<SessionRecovery> recovery_;
  bool autosaveFailed_ = false;
  QElapsedTimer fpsClock_, sampleClock_;
  long fpsFrames_ = 0, framesDrawn_ = 0;
  double fps_ = 0.0, itPerSecond_ = 0.0, sampleCost_ = 0.0, budgetCredit_ = 0.0;
  double simulationSeconds_ = 0.0, updateSeconds_ = 0.0;
  long fpsIterations_ = 0;
  std::uint64_t shownRevision_ = 0;
  std::size_t plottedSamples_ = 0;
  bool followSchedule_ = true, sampling_ = true;
  QString sceneFile_;
  QAction *openScene_, *openImage_, *saveScene_, *saveSceneAs_, *saveMeshes_, *exportLabels_, *quit_;
  QAction *undo_, *redo_, *deletePoint_, *run_, *step_, *nextLevel_, *initialiseLandmarks_, *resetViews_, *maximise_;
  QAction* showContacts_ = nullptr;
  QAction* showThickness_ = nullptr;
  QAction* showFit_ = nullptr;
  bool thicknessPoll_ = false;  // a redraw is due once the thickness job may have ended
  QMenu* recentMenu_ = nullptr;
  QActionGroup* toolGroup_ = nullptr;
};

}  // namespace sinew
