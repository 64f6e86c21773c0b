// Gradient force (paper 000 section 3.2.2): search along the normal for the sample with the lowest
// energy epsilon * grad(I) . n and pull the vertex toward it.
#include "sinew/core/registry.h"

#include <cmath>

namespace sinew {

namespace {
class GradientForce final : public Force {
public:
  Requirements requirements() const override { return {.attributes = {Attribute::Normal}, .imageForce = true}; }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    const ParamTable& p = ctx.params;
    const int kEps = p.indexOf("epsilon"), kDepth = p.indexOf("search_depth"),
              kStep = p.indexOf("sample_spacing"), kSigma = p.indexOf("sigma");
    const VectorVolume& grad = ctx.scene.targetGradient(p.getf(0, kSigma));
    const auto x = s.positions();
    const auto normal = s.normals();
    const auto meshOf = s.meshOfVertex();
    forActiveVertices(ctx, [&](Index v, float alpha) {
      const Index m = meshOf[v];
      const float eps = p.getf(m, kEps), step = p.getf(m, kStep);
      const int reach = static_cast<int>(std::floor(p.getf(m, kDepth) / step));
      const Vec3& n = normal[v];
      float best = std::numeric_limits<float>::max();
      int bestJ = 0;
      for (int j = -reach; j <= reach; ++j) {
        const float e = eps * grad.sample(x[v] + (static_cast<float>(j) * step) * n).dot(n);
        // Ties go to the smaller displacement, so a flat image leaves the vertex where it is.
        if (e < best || (e == best && std::abs(j) < std::abs(bestJ))) {
          best = e;
          bestJ = j;
        }
      }
      forces[v] += alpha * (static_cast<float>(bestJ) * step) * n;
    });
  }

  // The found point is held for the step: a pull toward it along the normal.
  bool addJacobian(ForceContext& ctx, JacobianBlocks& jacobian) override {
    addNormalPullJacobian(ctx, jacobian);
    return true;
  }
};
}  // namespace

void registerGradientForce(Registry& registry) {
  registry.addForce(
      {"gradient",
       "toward the lowest epsilon * grad(I) . n found along the normal",
       {{"epsilon", 1.0, -1.0, 1.0, "",
         "+1 when the intensity falls going outward (the gradient opposes the normal), -1 when it "
         "rises"},
        {"search_depth", 3.0, 0.0, 50.0, "mm", "how far to search on each side of the surface"},
        {"sample_spacing", 0.5, 0.05, 10.0, "mm", "distance between search samples"},
        {"sigma", 1.0, 0.0, 10.0, "mm", "Gaussian smoothing of the image before the gradient",
         false}},
       [] { return std::make_unique<GradientForce>(); }});
}

}  // namespace sinew
