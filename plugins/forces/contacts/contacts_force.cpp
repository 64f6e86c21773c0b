// Deforming contacts (paper 001 section 2.2): the proximities between the structures of the
// scene's `contact_pairs`, found on the reference shapes at each level (core/contact_links.h), are
// kept by springs. A linked vertex i is pulled toward its partner j plus their reference offset:
// f_i = alpha m_i (x_j + o_ij - x_i), scaled by the mass like a collision contact, so that every
// vertex moves alike. The paper applies them at the coarse levels and releases them at the finest,
// where collisions let surfaces slide: set the weight to 0 in the last level of the schedule.
// sinew-make-scene's subject scenes keep a third of the weight there instead, which new subjects
// segmented better (docs/collisions.md, "The deforming contacts kept at the finest level").
#include "sinew/core/contact_links.h"
#include "sinew/core/registry.h"

namespace sinew {

namespace {
class ContactsForce final : public Force {
public:
  Requirements requirements() const override {
    return {.attributes = {Attribute::Mass, Attribute::ReferencePosition}, .referenceShape = true};
  }

  void prepare(ForceContext& ctx) override {
    links_ = findContactLinks(ctx.store, ctx.scene.contactPairs(), ctx.params.getf(0, ctx.params.indexOf("distance_mm")));
    builtFor_ = ctx.store.vertexCount();
  }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    if (builtFor_ != s.vertexCount()) prepare(ctx);
    stiffness_.assign(s.vertexCount(), 0.0f);
    if (links_.linked == 0) return;
    const auto x = s.positions();
    const auto mass = s.masses();
    forActiveVertices(ctx, [&](Index v, float alpha) {
      const Index j = links_.partner[v];
      if (j < 0) return;
      stiffness_[v] = alpha * mass[v];
      forces[v] += stiffness_[v] * ((x[j] + links_.offset[v]) - x[v]);
    });
  }

  // The partner is held fixed over the step (as on the device).
  bool addJacobian(ForceContext& ctx, JacobianBlocks& jacobian) override {
    addFixedPointPullJacobian(ctx, stiffness_, jacobian);
    return true;
  }

private:
  ContactLinks links_;
  Index builtFor_ = -1;
  std::vector<float> stiffness_;
};
}  // namespace

void registerContactsForce(Registry& registry) {
  registry.addForce({"contacts",
                     "deforming contacts: springs that keep the reference proximity of the scene's contact_pairs "
                     "(on at the coarse levels; released, or weaker, at the finest)",
                     {{"distance_mm", 2.0, 0.1, 20.0, "mm",
                       "vertex pairs of two paired structures closer than this in the reference shape are linked", false}},
                     [] { return std::make_unique<ContactsForce>(); }});
}

}  // namespace sinew
