// Forces and integrators are separate plugins: a force only adds to the force array, an
// integrator only moves vertices. Each declares the store attributes it needs, so only those are
// allocated.
#pragma once

#include "sinew/core/mesh_store.h"
#include "sinew/core/parameters.h"
#include "sinew/core/scene_data.h"

#include <span>
#include <vector>

namespace sinew {

struct Requirements {
  std::vector<Attribute> attributes;
  bool referenceShape = false;  // every structure where the force is active needs one
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
};

struct IntegratorContext {
  MeshStore& store;
  const ParamTable& params;  // a single row
  const Executor& executor;
};

class Integrator {
public:
  virtual ~Integrator() = default;
  virtual Requirements requirements() const = 0;
  // Called when the store is built (not after a level change: state is carried then).
  virtual void start(IntegratorContext&) {}
  virtual void step(IntegratorContext& ctx) = 0;
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

}  // namespace sinew
