// Forces and integrators are separate plugins: a force only adds to the force array, an
// integrator only moves vertices. Each declares the store attributes it needs, so only those are
// allocated.
#pragma once

#include "sinew/core/jacobian.h"
#include "sinew/core/mesh_store.h"
#include "sinew/core/parameters.h"
#include "sinew/core/scene_data.h"

#include <span>
#include <vector>

namespace sinew {

namespace cuda {
class DeviceForce;  // sinew/cuda/device_force.h: a force's CUDA path
}

struct Requirements {
  std::vector<Attribute> attributes;
  bool referenceShape = false;  // every structure where the force is active needs one
  bool jacobian = false;        // an integrator: it needs the forces' Jacobian blocks each step
  // A force driven by the image (gradient, intensity profile): its field is what the affine
  // regularisation (Simulation::setAffineRegularisation) replaces in part by its closest affine field.
  bool imageForce = false;
  // A shape force (smoothing, shape prior): it depends only on the mesh and its reference, so it can
  // also be evaluated on the coarser levels and carried to the current one (Simulation::setCoarseForceWeight).
  bool shapeForce = false;
};

struct ForceContext {
  MeshStore& store;
  const ParamTable& params;  // one row per structure; column 0 is the weight alpha
  SceneData& scene;
  const Executor& executor;
};

class Force {
public:
  virtual ~Force() = default;
  virtual Requirements requirements() const = 0;
  // Called when the store is built and after every change of level (e.g. to train profiles).
  virtual void prepare(ForceContext&) {}
  // Adds alpha * f to forces[v] for every vertex of every structure whose alpha is positive.
  virtual void accumulate(ForceContext& ctx, std::span<Vec3> forces) = 0;
  // For implicit integrators: adds alpha * df/dx to the blocks, with the geometry that depends on
  // positions nonlinearly (normals, frames, areas) held fixed over the step. The contribution must
  // be symmetric (block (v, u) = block (u, v) transposed) and negative semi-definite. Returns false
  // when the force has none; it is then integrated explicitly.
  virtual bool addJacobian(ForceContext&, JacobianBlocks&) { return false; }
  // After the integrator's step: moves positions the force constrains (a projection, paper 002's
  // constraint correction). Most forces have none.
  virtual void constrain(ForceContext&) {}
  // The force's CUDA path, for the CUDA backend (a run-time plugin's force provides one by also
  // deriving from cuda::DeviceForce). Null: the force runs on the CPU backend only.
  virtual cuda::DeviceForce* deviceForce() { return nullptr; }
  // The stability guard put back an earlier state (positions and previous positions; Simulation::
  // recover): a force that carries state from step to step forgets what the undone steps taught it.
  virtual void restored(ForceContext&) {}
};

struct IntegratorContext {
  MeshStore& store;
  const ParamTable& params;  // a single row
  const Executor& executor;
  const JacobianBlocks* jacobian = nullptr;  // when the integrator's requirements ask for it
};

class Integrator {
public:
  virtual ~Integrator() = default;
  virtual Requirements requirements() const = 0;
  // Called when the store is built (not after a level change: state is carried then).
  virtual void start(IntegratorContext&) {}
  virtual void step(IntegratorContext& ctx) = 0;
  // The stability guard changed the "time_step" parameter by `factor` (after restoring the last good
  // state): keep the velocity, which integrators storing x - x_prev must rescale.
  virtual void timeStepScaled(IntegratorContext&, float /*factor*/) {}
};

// An integrator whose velocity is (x - x_prev) / dt (both built-ins): it starts at rest, and when
// the guard changes dt, x - x_prev is scaled with it so the velocity is kept.
class PreviousPositionIntegrator : public Integrator {
public:
  void start(IntegratorContext& ctx) override;
  void timeStepScaled(IntegratorContext& ctx, float factor) override;
};

// Calls body(v, alpha) for every vertex whose structure has a positive weight, in parallel.
template <class Body>
void forActiveVertices(const ForceContext& ctx, Body&& body) {
  const auto meshOf = ctx.store.meshOfVertex();
  ctx.executor.forEach(ctx.store.vertexCount(), [&](Index v) {
    const float alpha = ctx.params.getf(meshOf[v], 0);
    if (alpha > 0.0f) body(v, alpha);
  });
}

// The Jacobian of a force pulling each vertex toward a combination of its three neighbours,
// f_v = alpha (target(neighbours) - x_v), approximated with equal neighbour weights: self block
// -alpha I, neighbour blocks alpha/3 I. Symmetric and negative semi-definite, because alpha is one
// value per structure and neighbourhood is mutual (smoothing and the shape prior use it).
void addNeighbourPullJacobian(const ForceContext& ctx, JacobianBlocks& jacobian);
// The Jacobian of a pull along the normal toward a point found for the step (the image forces):
// self block -alpha n n^T.
void addNormalPullJacobian(const ForceContext& ctx, JacobianBlocks& jacobian);
// The Jacobian of per-vertex pulls toward points held fixed over the step (collision contacts,
// deforming contacts), f_v = k_v (p - x_v): self block -k_v I. Nothing while `stiffness` does not
// match the store (no step evaluated yet at this level).
void addFixedPointPullJacobian(const ForceContext& ctx, std::span<const float> stiffness, JacobianBlocks& jacobian);

}  // namespace sinew
