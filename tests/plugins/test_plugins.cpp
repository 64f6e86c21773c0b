// Registration functions of the loader's test plugins (tests/plugins/CMakeLists.txt): each plugin
// compiles this file and names one of them.
#include "sinew/core/registry.h"

#include <stdexcept>

namespace sinew {
namespace {
class ConstantForce final : public Force {
public:
  Requirements requirements() const override { return {}; }
  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    const int k = ctx.params.indexOf("value");
    const auto meshOf = ctx.store.meshOfVertex();
    forActiveVertices(ctx, [&](Index v, float alpha) { forces[v] += alpha * ctx.params.getf(meshOf[v], k) * Vec3::UnitX(); });
  }
};
ForceDescriptor constantForce(const std::string& name) {
  return {name, "pushes along +x", {{"value", 1.0, 0.0, 10.0, "mm", "push along +x"}},
          [] { return std::make_unique<ConstantForce>(); }};
}
}  // namespace

void registerTestConstantForce(Registry& r) { r.addForce(constantForce("test_constant")); }
// Declared KIND integrator, registers a force.
void registerTestWrongKind(Registry& r) { r.addForce(constantForce("test_wrong_kind")); }
// Registers one force, then fails: nothing of it may reach the registry.
void registerTestThrows(Registry& r) {
  r.addForce(constantForce("test_throws"));
  throw std::runtime_error("the plugin's data file is missing");
}
// Takes a built-in's name.
void registerTestDuplicate(Registry& r) { r.addForce(constantForce("smoothing")); }
}  // namespace sinew
