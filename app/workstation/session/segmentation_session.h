// The workstation's model of one segmentation session (no Qt, no VTK): a loaded scene stepped
// under a time budget, the user's edits with bounded undo/redo, the timeline of error (or
// displacement) against time, and the exports. Widgets observe it; it knows nothing of them.
#pragma once

#include "sinew/core/image_fit.h"
#include "sinew/core/scene_runner.h"

#include <chrono>
#include <deque>
#include <filesystem>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <vector>

namespace sinew {

struct SessionSample {
  double seconds = 0.0;  // simulation time
  long iteration = 0;
  int level = 0;
  double assdMm = 0.0;           // mean over structures with ground truth; NaN without any
  double dice = std::numeric_limits<double>::quiet_NaN();  // the same way (exact: SceneRunner::timelineDice)
  double displacementMm = 0.0;   // mean |x - x_prev| of the last step over all vertices
};

// A landmark pair placed by the user (paper 000 section 5, paper 001 section 3): where the model
// has an anatomical point now (from) and where that point is in the image (to), world mm.
struct PlacedLandmark {
  Vec3 from = Vec3::Zero(), to = Vec3::Zero();
};

// Everything an edit can change, as it was at one moment: an undo step, or the state autosaved for
// crash recovery. Never changed once taken, so the history and an autosave in progress share them.
struct SessionSnapshot {
  std::string label;
  int level = 0;
  std::vector<Vec3> positions, previous;
  std::vector<std::vector<Vec3>> points;
  std::vector<std::vector<ConstraintPoint>> constraints;
  std::vector<PlacedLandmark> landmarks;
  std::vector<ParamTable> forceParams;  // the forces', then the integrator's
  std::uint64_t id = 0;                 // unique in the process: names it in a recovery folder
  std::size_t bytes() const;
};

// A whole session for crash recovery (session_recovery.h): the scene, where the schedule stands,
// the timeline, the current state and the undo and redo steps.
struct SessionState {
  SceneDesc scene;
  int levelIterationsDone = 0;
  long iteration = 0;
  double simulationSeconds = 0.0;
  std::vector<SessionSample> timeline;
  std::shared_ptr<const SessionSnapshot> current;
  std::vector<std::shared_ptr<const SessionSnapshot>> undo, redo;  // oldest first
};

struct SessionOpenOptions {
  int threads = 0;              // 0: all hardware threads
  std::string backend = "auto";  // auto | cuda | cpu
  std::function<void(const std::string&)> log;
  // Makes a run-time plugin the scene names available (throws InputError when it cannot); unset:
  // the registry must already hold what the scene uses.
  std::function<void(const std::string& plugin)> requirePlugin;
};

class SegmentationSession {
public:
  explicit SegmentationSession(const Registry& registry);
  ~SegmentationSession();

  // Loads a scene; the attraction-point force is added (weight 1) when the scene lacks it, so the
  // attraction tool always works. Throws InputError naming the file and problem.
  void open(const std::filesystem::path& sceneFile, const SessionOpenOptions& options = {});
  // The same from a scene description (relative paths resolved against scene.file).
  void open(SceneDesc scene, const SessionOpenOptions& options = {});
  bool isOpen() const { return runner_ != nullptr; }
  void close();
  const SceneDesc& scene() const;
  Simulation& simulation();
  const Image3D& image();
  Index structureCount();
  std::string backendName() const;
  std::string deviceName() const;
  ExecutionBackend* backend() const { return backend_.get(); }

  // The schedule: levels coarse to fine, each with its planned iterations.
  int level();
  int levelCount();
  int levelIterationsDone() const { return levelDone_; }
  int levelIterationsPlanned() const;
  bool levelScheduleDone() const { return levelDone_ >= levelIterationsPlanned(); }

  // step() and stepFor() run under the stability guard of sinew-run on either backend (each call
  // one chunk; each structure against itself after the last edit, undo or redo): a violation is undone and the step halved; when the guard gives up, NumericalError says
  // why and the last good state stays.
  // Steps until budgetSeconds of simulation time are spent (at least one step). Following the
  // schedule, it stops at the end of the level's iterations (returns 0 once there).
  int stepFor(double budgetSeconds, bool followSchedule = true);
  int step(int iterations);
  // Enters the next level (with its schedule values); clears the undo history, whose snapshots
  // belong to the coarser level. False at the finest level.
  bool nextLevel();
  double simulationSeconds() const { return simSeconds_; }
  double secondsPerStep() const { return secondsPerStep_; }

  // Makes the host store current (downloads from the backend when it ran since).
  void syncHost();
  // Appends a timeline sample (syncs the host; evaluates ASSD when ground truth exists).
  const SessionSample& sample();
  const std::vector<SessionSample>& timeline() const { return timeline_; }
  // Scores every structure's image fit where it now lies (syncs the host; core imageFitOf): what
  // sinew-run reports at the end of a run. Kept while the state does not change.
  const std::vector<StructureImageFit>& scoreImageFit();
  // The last scores while the state has not changed since (revision()), else empty: never stale.
  std::vector<StructureImageFit> imageFit() const { return fitRevision_ == revision_ ? fits_ : std::vector<StructureImageFit>(); }
  bool hasGroundTruth();
  // Changes on every edit, undo, redo, step and level change: views redraw when it moved.
  std::uint64_t revision() const { return revision_; }

  // Per vertex, 1 in a contact region: inside another structure or within the collision force's
  // margin of it (0.25 mm without the force; core contactMask). Recomputed (host store synced) when
  // the state changed, at most every minIntervalSeconds while it keeps changing (a run), so that it
  // never takes over the frame.
  const std::vector<unsigned char>& contactMask(double minIntervalSeconds = 0.25);
  // Per vertex, its structure's medial radius there in mm (the radius of the largest ball inside
  // the structure touching it: core medialRadii on the structure's tessellation), for the 3D view's
  // thickness colours (docs/medial.md). Recomputed like contactMask, at most every
  // minIntervalSeconds while the state keeps changing, but on a background thread (about 0.25 s
  // for 12 structures on 2 cores): the call starts the job on a copy of the surfaces and returns the
  // last radii that fit the store, empty until the first are ready; `wait` blocks for the job.
  const std::vector<float>& medialRadius(double minIntervalSeconds = 1.0, bool wait = false);
  // Per vertex, the image fit around it (core vertexImageFit: where the surface looks as the
  // profiles were trained, and where not), for View > Show Image Fit; NaN without a force that
  // scores the image. Recomputed (host store synced) when the state changed, at most every
  // minIntervalSeconds while it keeps changing, and never more often than every 20 times its own
  // last cost (about 20 ms for 20,000 vertices on 2 cores), so that it takes at most 5 % of a run.
  const std::vector<float>& vertexImageFit(double minIntervalSeconds = 0.5);
  // A medial-radius job is running (the view draws again when it ends).
  bool medialRadiusPending() const { return medialJob_.valid(); }

  // Edits. Each is undoable; its snapshot holds the mesh state too, so undo restores exactly the
  // state before the edit, however far the simulation moved since. A continuing edit (a drag, a
  // slider being moved) extends the previous one instead of adding a new undo step, also when the
  // simulation steps in between; endEdit() closes the gesture (a button press or release).
  const std::vector<Vec3>& attractionPoints(Index structure);
  void addAttractionPoint(Index structure, const Vec3& point);
  void moveAttractionPoint(Index structure, int index, const Vec3& point, bool continuing);
  void removeAttractionPoint(Index structure, int index);
  // Include / exclude points (the attraction_points force pushes the structure until each lies on
  // its side), undoable like the points above.
  const std::vector<ConstraintPoint>& constraintPoints(Index structure);
  void addConstraintPoint(Index structure, const ConstraintPoint& point);
  void moveConstraintPoint(Index structure, int index, const Vec3& point, bool continuing);
  void removeConstraintPoint(Index structure, int index);
  // Landmark pairs, undoable like the points above.
  const std::vector<PlacedLandmark>& landmarks() const { return landmarks_; }
  void addLandmark(const Vec3& from, const Vec3& to);
  void moveLandmark(int index, const Vec3& to, bool continuing);
  void removeLandmark(int index);
  // Starts the segmentation again from the model mapped by a thin-plate spline through the pairs
  // (at least 4, not coplanar): the scene's "initialise" becomes these landmarks (their model
  // points taken back through the current initialisation), and the scene is loaded anew, as
  // sinew-run would load it. Like a level change, it clears the undo history; the pairs are then
  // part of the scene (saved with it) and the list is empty. Throws InputError, leaving the
  // session as it was, when the pairs cannot determine a map.
  void initialiseFromLandmarks(const SessionOpenOptions& options = {});
  // force: a force's name, or the integrator's name for its parameters. structure -1: every
  // structure (shared parameters are always set on all).
  void setParameter(const std::string& force, Index structure, const std::string& param, double value,
                    bool continuing = false);
  double parameter(const std::string& force, Index structure, const std::string& param);
  void endEdit();
  bool canUndo() const { return !undo_.empty(); }
  bool canRedo() const { return !redo_.empty(); }
  std::string undoLabel() const { return undo_.empty() ? "" : undo_.back()->label; }
  std::string redoLabel() const { return redo_.empty() ? "" : redo_.back()->label; }
  bool undo();
  bool redo();
  // Oldest undo steps are dropped beyond this many bytes of snapshots (default 256 MiB).
  void setHistoryLimit(std::size_t bytes);
  std::size_t historyBytes() const;

  // Crash recovery. state(): the session as it stands (syncs the host; copies the mesh state, shares
  // the undo steps). restoreState(): opens the state's scene and puts everything back, undo and
  // redo included; throws InputError when the state does not fit its scene (the scene is then open
  // as loaded, without the state).
  SessionState state();
  void restoreState(const SessionState& state, const SessionOpenOptions& options = {});

  // The scene as it stands: current parameter values and placed points.
  SceneDesc currentScene();
  void saveScene(const std::filesystem::path& file);
  // One mesh per structure ("<name><ext>", ext e.g. ".vtp"); returns the files written.
  std::vector<std::filesystem::path> saveMeshes(const std::filesystem::path& dir, const std::string& ext);
  void exportLabelMap(const std::filesystem::path& file);

private:
  // Whether a view derived from the state (contact mask, image fit, medial radii) must be computed
  // again: it does not fit the store, or the state moved and minIntervalSeconds have passed since
  // `at`.
  bool due(std::size_t size, std::uint64_t revision, std::chrono::steady_clock::time_point at,
           std::chrono::steady_clock::time_point now, double minIntervalSeconds);
  std::vector<unsigned char> contactMask_;
  std::uint64_t contactRevision_ = 0;
  std::chrono::steady_clock::time_point contactTime_{};
  std::vector<float> vertexFit_;
  std::uint64_t vertexFitRevision_ = 0;
  std::chrono::steady_clock::time_point vertexFitTime_{};
  double vertexFitSeconds_ = 0.0;  // the last computation's cost
  std::vector<float> medialRadius_;
  std::uint64_t medialRevision_ = 0;
  std::chrono::steady_clock::time_point medialTime_{};
  std::future<std::vector<float>> medialJob_;
  std::uint64_t medialJobRevision_ = 0;
  std::chrono::steady_clock::time_point medialJobTime_{};

  using Snapshot = SessionSnapshot;
  using SnapshotPtr = std::shared_ptr<const SessionSnapshot>;
  ParamTable& params(const std::string& owner);
  Snapshot capture(std::string label);
  // Every structure's tessellated surface from the host store; throws NumericalError on NaN.
  std::vector<StructureResult> finalSurfaces();
  void restore(const Snapshot& s);
  bool travel(std::deque<SnapshotPtr>& from, std::deque<SnapshotPtr>& to);
  void beginEdit(const std::string& label, bool continuing);
  void trimHistory();
  void changed() { ++revision_; }
  void fallBackToCpu(const std::runtime_error& e);

  const Registry& registry_;
  std::unique_ptr<SceneRunner> runner_;
  std::unique_ptr<ExecutionBackend> backend_;
  std::function<void(const std::string&)> log_;
  std::vector<PlacedLandmark> landmarks_;
  bool hostCurrent_ = true;
  int levelDone_ = 0;
  double simSeconds_ = 0.0, secondsPerStep_ = 0.0;
  std::vector<SessionSample> timeline_;
  std::deque<SnapshotPtr> undo_, redo_;
  std::size_t historyLimit_ = std::size_t(256) << 20;
  std::string lastEdit_;  // label of the edit a continuing edit may extend
  std::uint64_t revision_ = 1;
  std::vector<StructureImageFit> fits_;
  std::uint64_t fitRevision_ = 0;  // the revision fits_ belong to (0: none)
};

}  // namespace sinew
