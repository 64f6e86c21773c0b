// Smoothing (paper 000 section 3.2.1): toward the area-weighted barycentre of the three neighbours,
// lifted along the normal by the neighbours' mean elevation so that a curved surface is not shrunk.
#include "sinew/core/registry.h"

namespace sinew {

namespace {
class SmoothingForce final : public Force {
public:
  Requirements requirements() const override {
    return {.attributes = {Attribute::Normal, Attribute::Elevation, Attribute::Area}, .shapeForce = true};
  }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    const auto x = s.positions();
    const auto normal = s.normals();
    const auto elev = s.elevations();
    const auto area = s.areas();
    const auto nb = s.neighbours();
    const int kElevation = ctx.params.indexOf("elevation_term");
    forActiveVertices(ctx, [&](Index v, float alpha) {
      const auto& n = nb[v];
      const float a0 = area[n[0]], a1 = area[n[1]], a2 = area[n[2]];
      const float total = a0 + a1 + a2;
      const Vec3 centre = total > 0.0f ? Vec3((a0 * x[n[0]] + a1 * x[n[1]] + a2 * x[n[2]]) / total)
                                       : Vec3((x[n[0]] + x[n[1]] + x[n[2]]) / 3.0f);
      const float lift = ctx.params.getf(s.meshOfVertex()[v], kElevation) *
                         (elev[n[0]] + elev[n[1]] + elev[n[2]]) / 3.0f;
      forces[v] += alpha * (centre + lift * normal[v] - x[v]);
    });
  }

  bool addJacobian(ForceContext& ctx, JacobianBlocks& jacobian) override {
    addNeighbourPullJacobian(ctx, jacobian);
    return true;
  }
};
}  // namespace

void registerSmoothingForce(Registry& registry) {
  registry.addForce({"smoothing",
                     "area-weighted Laplacian smoothing plus the neighbours' mean elevation",
                     {{"elevation_term", 1.0, 0.0, 1.0, "",
                       "share of the neighbours' mean elevation added along the normal (1 keeps "
                       "curved surfaces from shrinking, 0 is plain Laplacian smoothing)"}},
                     [] { return std::make_unique<SmoothingForce>(); }});
}

}  // namespace sinew
