// Shape prior (paper 000 section 3.2.1, Delingette 1999): toward the position that the reference
// shape's simplex parameters give over the current neighbours. The parameters are invariant under
// similarity, so the mesh may differ from the reference by a rotation, a translation and a scale.
#include "sinew/core/registry.h"

namespace sinew {

namespace {
class ShapePriorForce final : public Force {
public:
  Requirements requirements() const override { return {.attributes = {Attribute::ReferenceParams}, .referenceShape = true, .shapeForce = true}; }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    const auto x = s.positions();
    const auto ref = s.referenceParams();
    const auto nb = s.neighbours();
    forActiveVertices(ctx, [&](Index v, float alpha) {
      const auto& n = nb[v];
      const Vec3 &p1 = x[n[0]], &p2 = x[n[1]], &p3 = x[n[2]];
      const NeighbourFrame f = neighbourFrame(p1, p2, p3);
      forces[v] += alpha * limitedPriorPull(Vec3(positionFromParams(p1, p2, p3, f, ref[v], elevation(x[v], p1, f)) - x[v]), p1, p2, p3);
    });
  }

  bool addJacobian(ForceContext& ctx, JacobianBlocks& jacobian) override {
    addNeighbourPullJacobian(ctx, jacobian);
    return true;
  }
};
}  // namespace

void registerShapePriorForce(Registry& registry) {
  registry.addForce({"shape_prior",
                     "toward the position given by the reference shape's simplex parameters",
                     {},
                     [] { return std::make_unique<ShapePriorForce>(); }});
}

}  // namespace sinew
