// Runs a scene end to end: loads only what it names (images, label maps, meshes, plugins' forces),
// builds the reference shapes at every level, places the initial meshes, runs the schedule coarse
// to fine and measures error against run time.
#pragma once

#include "sinew/core/execution_backend.h"
#include "sinew/core/io.h"
#include "sinew/core/medial_axis.h"
#include "sinew/core/scene.h"
#include "sinew/core/shape_guard.h"
#include "sinew/core/simulation.h"
#include "sinew/core/stage_clock.h"
#include "sinew/core/surface_distance.h"

#include <chrono>
#include <functional>
#include <limits>
#include <memory>
#include <optional>

namespace sinew {

struct RunProgress {
  int level = 0, levelCount = 0;
  int iteration = 0, levelIterations = 0;  // within the level
  long done = 0, total = 0;                // over the whole schedule
  double seconds = 0.0;                    // simulation time so far
  // The timeline's sample just taken, averaged over the structures with a ground truth; NaN without
  // any, and at the last sample (which the end's exact evaluation fills after the last report).
  double meanAssdMm = std::numeric_limits<double>::quiet_NaN();
  double meanDice = std::numeric_limits<double>::quiet_NaN();
};

struct TimelineSample {
  double seconds = 0.0;  // simulation time (evaluation excluded)
  long iteration = 0;
  int level = 0;
  int structure = 0;
  double assdMm = std::numeric_limits<double>::quiet_NaN();  // NaN without ground truth (sampled_error.h)
  double hd95Mm = std::numeric_limits<double>::quiet_NaN();
  // Exact: the final result's Dice (voxelize.h's diceOfMesh) of the surface at this sample.
  double dice = std::numeric_limits<double>::quiet_NaN();
  double meanDisplacementMm = 0.0;  // mean |x - x_prev| over the structure's vertices
  double meanForce = 0.0;           // mean |f|
};

struct StructureResult {
  std::string name;
  int label = 0;
  Index vertices = 0;  // at the final level
  // Where the model puts the structure, before the initialisation (equal to the initial values
  // when the scene has no "initialise" stage).
  double assdModelMm = std::numeric_limits<double>::quiet_NaN();
  double diceModel = std::numeric_limits<double>::quiet_NaN();
  double assdInitialMm = std::numeric_limits<double>::quiet_NaN();
  double assdFinalMm = std::numeric_limits<double>::quiet_NaN();
  double hd95Mm = std::numeric_limits<double>::quiet_NaN();
  double diceInitial = std::numeric_limits<double>::quiet_NaN();
  double dice = std::numeric_limits<double>::quiet_NaN();
  double seconds = 0.0;  // simulation time; all structures are simulated together
  // The share of its vertices outside the target image: a structure that a small field of view
  // cuts, whose shape past the image comes from the model alone.
  double outsideImageShare = 0.0;
  // How well the image agrees with what was trained where the structure ended (image_fit.h's
  // StructureImageFit: fit, match, agreement; NaN when no force offers one): 1 where the image
  // looks as trained; below kPoorImageFit the run says "check".
  double imageFit = std::numeric_limits<double>::quiet_NaN();
  double profileMatch = std::numeric_limits<double>::quiet_NaN(), selfAgreement = std::numeric_limits<double>::quiet_NaN();
  TriangleMesh surface;  // final Fig. 1b tessellation, world mm
  std::optional<RadiusSummary> medialRadius;  // with "outputs.thickness" (addThickness)
};

// One stage of a run with its error per structure: "model" (where the model puts the structures),
// "initialisation", then "level 0", "level 1", ... (the error at the end of each level).
// Where a level's simulation time went: its set-up (not in StageResult::seconds), then its
// seconds' parts. The rest of those is copying the state a chunk may be undone to, and putting it
// back after a rollback.
struct LevelSeconds {
  double enter = 0.0;   // the level's set-up: prolongation, the forces' preparation, the upload
  double steps = 0.0;   // the steps, undone ones included, and bringing their state to the host
  double checks = 0.0;  // the stability and shape guards' checks after each chunk
  int rollbacks = 0;    // the stability guard's recoveries (chunks, or on the CPU single steps, undone)
};

struct StageResult {
  std::string name;
  double seconds = 0.0;        // wall time the stage took (for levels: simulation time)
  std::vector<double> assdMm;  // per structure; NaN without ground truth
  std::optional<LevelSeconds> level;  // levels only
};

// Where two structures overlap, measured by rasterising both meshes on a 0.5 mm grid
// (overlapVolume): at the start of the run and at its end.
struct OverlapResult {
  int a = 0, b = 0;  // structure indices, a < b
  double beforeMm3 = 0.0, afterMm3 = 0.0;
};
inline constexpr double kOverlapSpacingMm = 0.5;

struct InitialisationResult {
  std::string method = "none";  // "registration (affine)", "transform FILE [(affine, then B-spline)]", "landmarks: ..."
  double seconds = 0.0;
  std::vector<RegistrationStage> registration;  // metric per registration stage
  bool hasAffine = false;       // transform is meaningful (registration, transform, affine landmarks)
  RegistrationTransform transform;  // ITK convention; with a B-spline after a registration or from a file
};

struct RunReport {
  std::string backend = "cpu";
  std::string device;
  int threads = 0;
  double totalSeconds = 0.0;       // wall time of load + run + evaluation (stageClock.total())
  double simulationSeconds = 0.0;  // time spent in simulation steps
  std::vector<double> levelStartSeconds;
  std::vector<StructureResult> structures;
  std::vector<TimelineSample> timeline;
  std::vector<StabilityEvent> stability;  // the stability guard's rollbacks
  std::vector<StageResult> stages;
  InitialisationResult initialisation;
  // Every stage's wall time, in order: laps of one clock from the run's start (RunOptions::start),
  // so they add up to totalSeconds. A caller with work of its own after run() (writing the outputs)
  // laps it here and sets totalSeconds to stageClock.total().
  StageClock stageClock;
  // Work that ran beside the stages (each input file's read, the start's evaluation), with its own
  // wall time; the stages count only the waits for it.
  std::vector<std::pair<std::string, double>> backgroundSeconds;
  std::vector<OverlapResult> overlaps;  // every pair that overlaps before or after (two structures or more)
  // Why the run stopped early (the guard could not recover; the meshes are the last good ones);
  // empty when it ran its schedule.
  std::string numericalFailure;
  bool shapeFailure = false;  // the failure is the shape guard's (status "degraded")
  bool hasGroundTruth() const;
};

struct RunOptions {
  int threads = 0;  // 0: all hardware threads
  std::function<void(const RunProgress&)> progress;
  std::function<void(const std::string&)> log;  // what is being loaded, for long set-ups
  // Creates the backend that runs the steps (after load); null or returning null: the CPU.
  std::function<std::unique_ptr<ExecutionBackend>(Simulation&)> backend;
  // When the run's clock starts (default: the runner's creation); the time to load() is the stage
  // "startup". sinew-run passes its process's start.
  std::optional<std::chrono::steady_clock::time_point> start;
};

// "outputs.thickness": every final surface's medial radius per point (point data
// "medial_radius_mm", written with the meshes) and its summary (docs/medial.md).
void addThickness(RunReport& report, const Executor& executor);

class SceneRunner {
public:
  SceneRunner(const Registry& registry, SceneDesc scene, RunOptions options = {});
  ~SceneRunner();

  // Reads every input and sets the simulation up. Throws InputError naming the file and problem.
  void load();
  // Runs the schedule. When the stability guard cannot recover, the run stops with the last good
  // meshes and says why in numericalFailure. Throws NumericalError when a backend without the guard
  // produced a non-finite state (nothing usable is left then).
  RunReport run();
  // The final meshes rasterised on the target image grid with the scene's label values.
  LabelVolume labelMap(const RunReport& report) const;

  Simulation& simulation();
  const SceneDesc& scene() const { return scene_; }

  // For interactive use (the workstation), step by step instead of run():
  // Applies the next level's schedule values and refines every structure; false at the finest.
  bool enterNextLevel();
  // The structure's current surface from the host store, with ASSD/HD95 against its ground truth
  // (NaN without one) and, when final, Dice.
  StructureResult evaluate(Index structure, bool final);
  bool hasGroundTruth(Index structure) const;
  // Every structure's error as the timeline samples it (sampled_error.h; nullopt without a ground
  // truth): by the backend where it can measure on its device, else from the host store, which
  // must then be current.
  std::vector<std::optional<SurfaceDistanceStats>> sampledError(ExecutionBackend* backend = nullptr);
  // Every structure's Dice against its ground truth at the store's current positions, as the
  // timeline records it (NaN without a ground truth): exact, the final result's (evaluate(i, true)).
  std::vector<double> timelineDice();
  const InitialisationResult& initialisation() const;
  // One chunk of steps under both guards (numerical and shape), as run() steps; the workstation
  // steps through this on either backend. Returns why the guard gave up ("" when the chunk ran or
  // was recovered); the host store is then current and holds the last good state. A backend's own
  // failure (device memory, a lost device) is thrown as it comes. checkShape false: the numerical
  // guard only (the shape check costs a pass over every cell: an interactive caller spaces it out).
  std::string runGuardedChunk(ExecutionBackend* backend, int chunk, bool checkShape = true);
  // The shape guard measures from the state at the next chunk instead of the simulation's start
  // (the workstation: after the user's edits, a structure is where the user wants it).
  void restartShapeGuard() { shapeGuard_ = ShapeGuard{}; }

private:
  // The state a guarded chunk starts from, to undo it: copied once per chunk for both guards, into
  // buffers kept from chunk to chunk (31 MB at 1.3 M vertices).
  struct ChunkStart {
    std::vector<Vec3> positions, previous;
  };
  ChunkStart chunkStart_;
  // Copies the host store (which must be current) into chunkStart_; the two guards below undo to it.
  void holdChunkStart();
  // The image the forces train on (the scene's, else the model's atlas), and letting it go once the
  // finest level is trained (run() only: the workstation may train again).
  std::optional<std::filesystem::path> trainingImagePath() const;
  void releaseTrainingImage();
  void runGuarded(ExecutionBackend& backend, int chunk, RunReport& report);
  // reload: brings the backend (if any) the host state after a rollback.
  void runShapeGuarded(const std::function<void()>& runChunk, int chunk, RunReport& report,
                       const std::function<void()>& reload);
  struct Loaded;
  // backend: where the state is (may be null: the host); the host store must be current.
  // withError false: the sample's ASSD and HD95 are left NaN, for the run's exact evaluation of
  // the same positions to fill in (the first and the last sample).
  void sample(RunReport& report, double seconds, ExecutionBackend* backend, bool withError = true);
  void initialise(std::vector<StructureSpec>& specs, const std::function<void(const std::string&)>& log);
  // The exact evaluation in two parts: the surface (reads the store's topology), then its scores
  // against the truth (reads only what load() left, so it may run beside the simulation).
  StructureResult surfaceOf(Index structure, const std::vector<Vec3>& positions) const;
  void score(Index structure, StructureResult& result, bool final) const;
  // ASSD and HD95 from distances computed elsewhere; Dice when final.
  void setScores(Index structure, StructureResult& result, const SurfaceDistanceStats& distances, bool final) const;
  // Every structure's final surface, scored exactly: the distances on the backend's device where it
  // has one (the same values), else on the host.
  std::vector<StructureResult> evaluateEnd(ExecutionBackend* backend);
  // Each structure's mean image fit (StructureResult::imageFit) at the current positions.
  void setImageFit(std::vector<StructureResult>& out);

  const Registry& registry_;
  SceneDesc scene_;
  RunOptions options_;
  std::unique_ptr<Loaded> loaded_;
  ShapeGuard shapeGuard_;  // each structure at the start of the simulation
  LevelSeconds levelSeconds_;  // the current level's, filled by run() and the guards
};

// A one-line description of the CPU, e.g. "AMD EPYC (2 threads)".
std::string cpuDescription(int threads);

}  // namespace sinew
