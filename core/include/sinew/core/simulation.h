// The simulation loop over all structures of a scene: geometry refresh, active forces accumulate,
// the integrator moves vertices; coarse-to-fine through the levels of detail.
#pragma once

#include "sinew/core/attachments.h"
#include "sinew/core/registry.h"
#include "sinew/core/stability.h"

#include <memory>
#include <string>
#include <vector>

namespace sinew {

struct StructureSpec {
  std::string name;
  LevelHierarchy levels;                 // level 0 = coarsest
  std::vector<Vec3> initialPositions;    // at level 0
  std::vector<Vec3> referencePositions;  // at level 0; empty when the structure has no reference
  // Optional reference positions for finer levels (index l - 1 for level l); a level without one
  // gets the coarser reference carried by the prolongation.
  std::vector<std::vector<Vec3>> finerReferences;
  float density = 0.0f;                  // 0: chosen per level so the mean vertex mass is 1
  // The least vertex mass, as a share of the structure's mean vertex mass at each level's start
  // (MeshStore::setMassFloor): 0 leaves mass = area x density.
  float massFloor = 0.0f;
};

class Simulation {
public:
  // threads <= 0: all hardware threads.
  explicit Simulation(const Registry& registry, int threads = 0);
  ~Simulation();

  // Scene set-up, before initialize().
  Index addStructure(StructureSpec spec);
  // Adds a force (in evaluation order) and returns its per-structure parameters.
  ParamTable& addForce(std::string_view name);
  ParamTable& setIntegrator(std::string_view name);
  SceneData& scene() { return scene_; }
  // Attachments between structures (docs/attachments.md), before initialize(); built at the start
  // of every level.
  void setAttachments(std::vector<AttachmentSpec> specs) { attachments_ = Attachments(std::move(specs)); }
  const Attachments& attachments() const { return attachments_; }

  // Builds the level-0 store, allocates what the forces and the integrator declared, prepares them.
  void initialize();
  void step();
  void run(int iterations);
  // Moves every structure to the next finer level; false when already at the finest.
  bool advanceLevel();

  int level() const { return level_; }
  int levelCount() const;
  long iteration() const { return iteration_; }
  // Where a restored session's count continues (the workstation's crash recovery).
  void setIteration(long iteration) { iteration_ = iteration; }
  // For backends that run this simulation's steps elsewhere (ExecutionBackend).
  void countExternalSteps(long steps) { iteration_ += steps; }
  MeshStore& store() { return store_; }
  const StructureSpec& structure(Index i) const { return structures_[i]; }
  Index structureCount() const { return static_cast<Index>(structures_.size()); }
  ParamTable& forceParams(std::string_view name);
  // The force object itself (for backends: a plugin force's device path).
  Force& force(std::string_view name);
  // The scene's forces in evaluation order (for backends that run them elsewhere).
  std::vector<std::string> forceNames() const;
  std::string integratorName() const { return integratorName_; }
  ParamTable& integratorParams() { return integratorParams_; }
  // Paper 001 section 3: per structure and step, the image forces' field f is replaced by
  // share * A(f) + (1 - share) * f, A(f) its closest affine field (least squares over the vertices).
  // 0 (the default) turns it off and allocates nothing.
  void setAffineRegularisation(float share);
  float affineRegularisation() const { return affineShare_; }
  // Paper 001 section 2.1, multi-resolution forces: at level L > 0 the shape forces are also
  // evaluated on every coarser level l (whose vertices are the current vertices 4^(L-l) t), carried
  // to level L by the prolongation and added with this weight. 0 (the default) turns it off and
  // allocates nothing.
  void setCoarseForceWeight(float weight);
  float coarseForceWeight() const { return coarseWeight_; }
  // The reference positions of every structure at a level (what the store holds there).
  std::vector<Vec3> referenceAt(Index structure, int level) const;
  // The store of a coarser level (< level()) that the multi-resolution forces run on: built on
  // first request for the current level, with only what the shape forces need and the references;
  // its positions are those of the last step that used it (for backends: topology and references).
  MeshStore& coarseStore(int level);
  void setStabilityGuard(const StabilityGuard& guard) { guard_ = guard; }
  const StabilityGuard& stabilityGuard() const { return guard_; }
  // Why the current positions are not an acceptable step from `before` (non-finite, or a vertex
  // farther than maxStepMm), or "" when they are. Also used for steps run elsewhere (a backend's
  // chunk of `steps` steps is held to the one-step limit; the reason says over how many steps).
  std::string checkStep(std::span<const Vec3> before, int steps = 1);
  // Restores the good state, halves "time_step" (rescaling goodPrevious with it, so the velocity is
  // kept) and records the event (attempt: how many recoveries in a row before this one). Throws
  // NumericalError, the good state restored, when the guard has no retry left. The halved step
  // holds for the rest of the level: advanceLevel() doubles it back, once per level, up to the step
  // before the first halving (unless the step was set by hand since).
  void recover(std::span<const Vec3> goodPositions, std::vector<Vec3>& goodPrevious, const std::string& problem,
               int attempt);
  // Puts the positions (and, where given, the previous positions) back and tells every force
  // (Force::restored), as a rollback does, without halving the step or recording an event
  // (bench_steps' rounds on the CPU).
  void restoreState(std::span<const Vec3> positions, std::span<const Vec3> previous);
  // The time step the last advanceLevel() doubled back to, or 0 when it changed none.
  double restoredTimeStep() const { return restoredTimeStep_; }
  // Every rollback so far, in order.
  const std::vector<StabilityEvent>& stabilityEvents() const { return events_; }
  // How often each force was evaluated (a force weighted 0 everywhere is skipped).
  long evaluations(std::string_view forceName) const;
  const Executor& executor() const { return executor_; }

private:
  struct ForceSlot;
  ForceSlot& slot(std::string_view name);
  const ForceSlot& slot(std::string_view name) const;
  void applyDensities();
  void prepareForces();
  void computeForces();
  void regulariseImageForces(std::span<Vec3> forces);
  void addCoarseForces(std::span<Vec3> forces);

  const Registry& registry_;
  Executor executor_;
  SceneData scene_;
  Attachments attachments_;
  std::vector<StructureSpec> structures_;
  std::vector<std::unique_ptr<ForceSlot>> forces_;
  std::unique_ptr<Integrator> integrator_;
  ParamTable integratorParams_;
  std::string integratorName_;
  MeshStore store_;
  int level_ = 0;
  long iteration_ = 0;
  bool initialized_ = false;
  StabilityGuard guard_;
  std::vector<StabilityEvent> events_;
  // The guard's time step: the step before its first halving (0 while none) and the value it set
  // last (a different value means the step was set by hand, which the guard then leaves alone).
  double unhalvedTimeStep_ = 0.0, guardTimeStep_ = 0.0;
  double restoredTimeStep_ = 0.0;  // what the last level change doubled back to, or 0
  JacobianBlocks jacobian_;
  float affineShare_ = 0.0f;
  std::vector<Vec3> imageForces_;  // the image forces alone, while the affine regularisation is on
  float coarseWeight_ = 0.0f;
  std::vector<std::unique_ptr<MeshStore>> coarse_;  // the coarser levels' stores, while multi-resolution forces are on
  std::vector<Vec3> goodPositions_, goodPrevious_;  // the last good state, for rollbacks
};

}  // namespace sinew
