// Helpers for a plugin's own tests (header only, no Qt): load the plugin file the way Sinew does,
// and probe a force on a sphere. sinew_add_plugin_test() (SinewPlugin.cmake) builds a Qt Test
// program around them and passes the plugin's file as SINEW_PLUGIN_FILE.
#pragma once

#include "sinew/core/force.h"
#include "sinew/core/plugin_loader.h"
#include "sinew/core/simplex_mesh.h"

#include <cmath>
#include <filesystem>
#include <memory>
#include <string_view>
#include <vector>

namespace sinew::testing {

// The plugin file loaded through Sinew's own loader (ABI check, declared kind, registration) into
// a registry of its own. Throws InputError with the loader's message when it is refused. The
// registry holds no built-in plugin, so a name clash with one shows only when Sinew loads it.
struct LoadedPlugin {
  explicit LoadedPlugin(const std::filesystem::path& file) : loader(registry) { record = loader.loadFile(file); }
  LoadedPlugin(const LoadedPlugin&) = delete;  // the loader refers to this object's registry
  LoadedPlugin& operator=(const LoadedPlugin&) = delete;
  Registry registry;
  PluginLoader loader;
  PluginRecord record;
};

// One force acting on one sphere (the dual of an icosphere: 20 * 4^level vertices), with its
// declared parameters at their defaults and weight 1. The reference shape, when the force asks
// for one, is the starting sphere.
class ForceProbe {
public:
  ForceProbe(const Registry& registry, std::string_view forceName, int level = 2, float radius = 10.0f,
             const Vec3& centre = Vec3::Zero())
      : mesh_(SimplexMesh::sphere(level, radius, centre)), centre_(centre) {
    const ForceDescriptor& d = registry.force(forceName);
    force_ = d.create();
    const SimplexTopology* topology = &mesh_.topology;
    store_ = MeshStore(std::span<const SimplexTopology* const>(&topology, 1));
    store_.setExecutor(&executor_);
    const Requirements req = force_->requirements();
    store_.require(Attribute::Force);
    for (Attribute a : req.attributes) store_.require(a);
    if (req.referenceShape) store_.require(Attribute::ReferencePosition);
    std::copy(mesh_.positions.begin(), mesh_.positions.end(), store_.positionsForWrite().begin());
    if (req.referenceShape)
      std::copy(mesh_.positions.begin(), mesh_.positions.end(), store_.referencePositionsForWrite().begin());
    params_ = ParamTable(d.params, 1);
    params_.set(0, 0, 1.0);
    ForceContext ctx{store_, params_, scene_, executor_};
    force_->prepare(ctx);
  }

  ForceProbe(const ForceProbe&) = delete;  // the store refers to this object's executor
  ForceProbe& operator=(const ForceProbe&) = delete;

  MeshStore& store() { return store_; }
  ParamTable& params() { return params_; }
  SceneData& scene() { return scene_; }
  Force& force() { return *force_; }

  // The force on every vertex (alpha * f) at the current positions.
  std::vector<Vec3> evaluate() {
    auto out = store_.forces();
    std::fill(out.begin(), out.end(), Vec3::Zero());
    ForceContext ctx{store_, params_, scene_, executor_};
    force_->accumulate(ctx, out);
    return {out.begin(), out.end()};
  }

  // `steps` explicit Euler steps x += dt * f: enough to see which way a force moves a mesh.
  void advance(int steps, float dt) {
    for (int i = 0; i < steps; ++i) {
      const std::vector<Vec3> f = evaluate();
      auto x = store_.positionsForWrite();
      for (std::size_t v = 0; v < x.size(); ++v) x[v] += dt * f[v];
    }
  }

  // Mean distance of the vertices to the sphere's centre.
  double meanRadius() const {
    double sum = 0.0;
    for (const Vec3& p : store_.positions()) sum += (p - centre_).norm();
    return sum / static_cast<double>(store_.positions().size());
  }

private:
  SimplexMesh mesh_;
  Vec3 centre_;
  Executor executor_{1};
  MeshStore store_;
  ParamTable params_;
  SceneData scene_;
  std::unique_ptr<Force> force_;
};

}  // namespace sinew::testing
