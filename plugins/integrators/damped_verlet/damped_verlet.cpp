// Damped Verlet (paper 000 equation 1):
//   x(t + dt) = x(t) + (1 - gamma) (x(t) - x(t - dt)) + a(t) dt^2,  a = f / m.
#include "sinew/core/registry.h"

namespace sinew {

namespace {
class DampedVerlet final : public PreviousPositionIntegrator {
public:
  Requirements requirements() const override {
    return {{Attribute::PreviousPosition, Attribute::Force, Attribute::Mass}, false};
  }

  void step(IntegratorContext& ctx) override {
    MeshStore& s = ctx.store;
    const float dt = ctx.params.getf(0, ctx.params.indexOf("time_step"));
    const float keep = 1.0f - ctx.params.getf(0, ctx.params.indexOf("damping"));
    const auto mass = s.masses();  // read before positions are marked stale
    const auto f = s.forces();
    auto prev = s.previousPositions();
    auto x = s.positionsForWrite();
    ctx.executor.forEach(s.vertexCount(), [&](Index v) {
      const Vec3 current = x[v];
      x[v] = current + keep * (current - prev[v]) + (dt * dt / mass[v]) * f[v];
      prev[v] = current;
    }, 2048);
  }
};
}  // namespace

void registerDampedVerlet(Registry& registry) {
  registry.addIntegrator({"damped_verlet",
                          "explicit damped Verlet, x' = x + (1 - gamma)(x - x_prev) + f/m dt^2",
                          {{"time_step", 0.5, 1e-4, 100.0, "", "dt", false},
                           {"damping", 0.6, 0.0, 1.0, "", "gamma: share of the velocity lost per step", false}},
                          [] { return std::make_unique<DampedVerlet>(); }});
}

}  // namespace sinew
