// SceneRunner's guards around a chunk of steps: the shape guard on either path and the numerical
// guard for a backend (scene_runner.cpp runs the schedule).
#include "sinew/core/scene_runner.h"

#include "scene_runner_loaded.h"

namespace sinew {

void SceneRunner::holdChunkStart() {
  MeshStore& store = simulation().store();  // previousPositions() has no const form
  chunkStart_.positions.assign(store.positions().begin(), store.positions().end());
  if (store.has(Attribute::PreviousPosition))
    chunkStart_.previous.assign(store.previousPositions().begin(), store.previousPositions().end());
  else chunkStart_.previous.clear();
}

// The shape guard (shape_guard.h) around one chunk, on either path: the chunk's end state is held
// against each structure at the start of the simulation; a violation undoes the chunk, halves the
// step like a numerical failure and runs it again, until the guard has no retry left.
void SceneRunner::runShapeGuarded(const std::function<void()>& runChunk, int chunk, RunReport& report,
                                  const std::function<void()>& reload) {
  Simulation& sim = simulation();
  MeshStore& store = sim.store();
  if (!shapeGuard_.captured()) shapeGuard_.capture(store, sim.scene().targetImage().geometry());
  shapeGuard_.followLevel(store);
  std::vector<std::string> names;
  for (const auto& s : scene_.structures) names.push_back(s.name);
  for (int attempt = 0;; ++attempt) {
    runChunk();
    if (!report.numericalFailure.empty()) return;
    // The swing check needs a few steps: over one or two, a vertex moving steadily also ends
    // within two steps of where it began.
    const std::span<const Vec3> swingFrom = chunk >= 4 ? std::span<const Vec3>(chunkStart_.positions) : std::span<const Vec3>();
    const auto t0 = Clock::now();
    const std::string problem =
        shapeGuard_.check(store, sim.scene().targetImage().geometry(), sim.stabilityGuard().shape, names, swingFrom);
    levelSeconds_.checks += since(t0);
    if (problem.empty()) return;
    if (options_.log) options_.log("stability guard: " + problem + "; the last " + std::to_string(chunk) + " steps undone");
    sim.countExternalSteps(-chunk);
    try {
      sim.recover(chunkStart_.positions, chunkStart_.previous, problem, attempt);
    } catch (const NumericalError& e) {
      report.numericalFailure = e.what();
      report.shapeFailure = true;
      if (options_.log) options_.log(std::string("stopped: ") + e.what());
      return;
    }
    reload();
  }
}

// The stability guard for a backend: the chunk's steps are checked together when they come back
// (the host store holds the state the chunk started from), against the one-step limit; a failed chunk is undone on the host,
// the step halved, and the backend reloaded to run it again.
void SceneRunner::runGuarded(ExecutionBackend& backend, int chunk, RunReport& report) {
  Simulation& sim = simulation();
  const auto steps = [&] {
    const auto t0 = Clock::now();
    backend.run(chunk);
    backend.download();
    levelSeconds_.steps += since(t0);
  };
  if (!sim.stabilityGuard().enabled) return steps();
  for (int attempt = 0;; ++attempt) {
    steps();
    // A whole chunk may move a vertex no farther than one step may on the CPU: legitimate motion is
    // far slower, and a looser bound would let oscillation just below the explosion through.
    const auto t0 = Clock::now();
    const std::string problem = sim.checkStep(chunkStart_.positions, chunk);
    levelSeconds_.checks += since(t0);
    if (problem.empty()) return;
    sim.countExternalSteps(-chunk);  // the chunk is undone
    try {
      sim.recover(chunkStart_.positions, chunkStart_.previous, problem, attempt);
    } catch (const NumericalError& e) {
      report.numericalFailure = e.what();
      if (options_.log) options_.log(std::string("numerical failure: ") + e.what());
      return;
    }
    backend.restoreState();
  }
}

std::string SceneRunner::runGuardedChunk(ExecutionBackend* backend, int chunk, bool checkShape) {
  Simulation& sim = simulation();
  RunReport report;
  const auto runChunk = [&] {
    if (backend) return runGuarded(*backend, chunk, report);
    try {
      sim.run(chunk);
    } catch (const NumericalError& e) {
      report.numericalFailure = e.what();  // the last good state stays in the store
    }
  };
  const bool guarded = sim.stabilityGuard().enabled;
  // Both guards undo to the chunk's start; the CPU's own step guard keeps its own copy.
  if (guarded && (checkShape || backend)) holdChunkStart();
  if (guarded && checkShape)
    runShapeGuarded(runChunk, chunk, report, [&] {
      if (backend) backend->restoreState();
    });
  else runChunk();
  return report.numericalFailure;
}

}  // namespace sinew
