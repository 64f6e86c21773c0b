// The balloon force (Cohen's pressure force): every vertex is pushed along its outward normal,
// f = pressure * n, so a mesh grows (pressure > 0) or shrinks (pressure < 0). One class serves
// the CPU backend (accumulate) and, built with CUDA, the CUDA backend (enqueue).
#include "balloon_kernels.h"

#include <sinew/core/force.h>
#include <sinew/core/registry.h>

namespace sinew {
namespace {

class BalloonForce final : public Force
#ifdef BALLOON_WITH_CUDA
    , public cuda::DeviceForce
#endif
{
public:
  Requirements requirements() const override { return {{Attribute::Normal}, false, false}; }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    const auto normals = ctx.store.normals();
    const auto meshOf = ctx.store.meshOfVertex();
    const int pressure = ctx.params.indexOf("pressure");
    forActiveVertices(ctx, [&](Index v, float alpha) {
      const float s = alpha * ctx.params.getf(meshOf[v], pressure);  // the kernel rounds the same way
      forces[v] += s * normals[v];
    });
  }

#ifdef BALLOON_WITH_CUDA
  cuda::DeviceForce* deviceForce() override { return this; }
  cudaError_t enqueue(const cuda::DeviceForceContext& ctx) override {
    return launchBalloon(ctx.mesh, ctx.params, ctx.hostParams.indexOf("pressure"), ctx.stream);
  }
#endif
};

}  // namespace

// The plugin's registration function, named in sinew_add_plugin(... REGISTER registerBalloonForce).
void registerBalloonForce(Registry& registry) {
  registry.addForce({"balloon",
                     "pressure along the outward normal (grows a mesh; shrinks it when negative)",
                     {{"pressure", 0.5, -5.0, 5.0, "mm", "push per unit weight along the outward normal"}},
                     [] { return std::make_unique<BalloonForce>(); }});
}

}  // namespace sinew
