// Somewhere other than the host that runs a simulation's steps (the CUDA backend). The host
// Simulation stays the model: structures, parameters, levels of detail. A backend mirrors its
// store, runs batches of steps, and hands the state back only when asked.
#pragma once

#include "sinew/core/sampled_error.h"

#include <optional>
#include <span>
#include <string>
#include <vector>

namespace sinew {

class ExecutionBackend {
public:
  virtual ~ExecutionBackend() = default;
  virtual std::string name() const = 0;    // "cuda"
  virtual std::string device() const = 0;  // e.g. the GPU's name
  virtual void run(int iterations) = 0;
  // Copies positions, previous positions and forces back into the host store.
  virtual void download() = 0;
  // Uploads the host store again after the host changed it (an edit).
  virtual void reload() = 0;
  // Uploads only the host's positions and previous positions (a guard's rollback: the host put the
  // chunk's start state back and halved the step; nothing else changed). By default, reload().
  virtual void restoreState() { reload(); }
  // After Simulation::advanceLevel(): carry the backend's own state to the new level (the host's
  // copy may be older); by default the host's state is uploaded.
  virtual void levelChanged() { reload(); }
  // The timeline's error (sampled_error.h) measured where the state is, into `out`; false where
  // this backend cannot (the host then measures it from the downloaded state).
  virtual bool measureError(SampledError& error, std::vector<std::optional<SurfaceDistanceStats>>& out) {
    (void)error, (void)out;
    return false;
  }
  // Exact distances (triangle_bvh.h) from each point to the mesh of `meshes` whose root is
  // roots[k], into out[k] (the same values as the host's query); false where this backend cannot.
  virtual bool closestDistances(const TriangleBvh& meshes, std::span<const collision::P3> points, std::span<const int> roots,
                                std::span<float> out) {
    (void)meshes, (void)points, (void)roots, (void)out;
    return false;
  }
};

}  // namespace sinew
