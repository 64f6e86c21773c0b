// Non-penetration between structures (paper 001 section 2.2; the issue on collisions): a vertex of
// one structure that lies inside another, or closer than the margin to its surface, is pulled to
// the point `margin` outside that surface. Detection in two stages: each structure's box (broad
// phase), then the closest point on the other surface's Fig. 1b tessellation through its AABB tree
// (narrow phase), refitted every step rather than rebuilt; inside or outside by the side of the
// closest triangle. CPU only so far: the CUDA backend hands a scene with this force to the CPU.
#include "sinew/core/registry.h"
#include "sinew/core/surface_distance.h"

#include <memory>
#include <vector>

namespace sinew {

namespace {
class CollisionForce final : public Force {
public:
  Requirements requirements() const override { return {.attributes = {Attribute::PreviousPosition}}; }

  // Per structure: its tessellation's triangles (fixed for the level) and the tree over them.
  void prepare(ForceContext& ctx) override {
    MeshStore& s = ctx.store;
    topologies_.clear();
    surfaces_.clear();
    trees_.clear();
    if (s.meshCount() < 2) return;  // nothing to collide with: nothing is allocated
    for (Index m = 0; m < s.meshCount(); ++m) {
      topologies_.push_back(s.topologyOf(m));
      const auto x = s.mesh(s.positions(), m);
      surfaces_.push_back(tessellate(topologies_.back(), std::vector<Vec3>(x.begin(), x.end())));
      trees_.push_back(std::make_unique<SurfaceDistanceQuery>(surfaces_.back()));
    }
  }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    if (trees_.size() != size_t(s.meshCount())) prepare(ctx);
    if (trees_.empty()) return;
    const float margin = ctx.params.getf(0, ctx.params.indexOf("margin_mm"));
    std::vector<Eigen::AlignedBox3f> boxes(s.meshCount());
    ctx.executor.forEach(s.meshCount(), [&](Index m) {
      updatePoints(s, m);
      trees_[m]->refit(surfaces_[m]);
      for (const Vec3& p : s.mesh(s.positions(), m)) boxes[m].extend(p);
      boxes[m].min().array() -= margin;
      boxes[m].max().array() += margin;
    });
    const auto x = s.positions();
    const auto previous = s.previousPositions();
    const float damping = ctx.params.getf(0, ctx.params.indexOf("contact_damping"));
    const auto meshOf = s.meshOfVertex();
    contact_.assign(s.vertexCount(), 0);
    forActiveVertices(ctx, [&](Index v, float alpha) {
      const Index own = meshOf[v];
      for (Index other = 0; other < s.meshCount(); ++other) {
        if (other == own || !boxes[other].contains(x[v])) continue;
        const SurfaceDistanceQuery::Closest c = trees_[other]->closest(x[v]);
        const auto& t = surfaces_[other].triangles[c.triangle];
        const auto& q = surfaces_[other].points;
        const Vec3 n = (q[t[1]] - q[t[0]]).cross(q[t[2]] - q[t[0]]).normalized();  // outward
        if ((x[v] - c.point).dot(n) >= margin) continue;
        // Pushed out to the margin; the vertex's own motion is damped while it touches, so that
        // contacts switching on and off from step to step do not keep it trembling.
        forces[v] += alpha * (c.point + margin * n - x[v]) - alpha * damping * (x[v] - previous[v]);
        contact_[v] = 1;
      }
    });
  }

  // A colliding vertex is pulled toward a point held fixed over the step: self block -alpha I.
  bool addJacobian(ForceContext& ctx, JacobianBlocks& jacobian) override {
    if (contact_.size() != size_t(ctx.store.vertexCount())) return true;
    forActiveVertices(ctx, [&](Index v, float alpha) {
      if (contact_[v]) jacobian.self[v] -= alpha * Eigen::Matrix3f::Identity();
    });
    return true;
  }

private:
  // The tessellation's points at the current positions: the vertices, then the cell centres (its
  // triangles stay those of the level).
  void updatePoints(MeshStore& s, Index m) {
    const auto x = s.mesh(s.positions(), m);
    const SimplexTopology& t = topologies_[m];
    std::vector<Vec3>& p = surfaces_[m].points;
    std::copy(x.begin(), x.end(), p.begin());
    for (Index c = 0; c < t.cellCount(); ++c) {
      Vec3 sum = Vec3::Zero();
      for (Index i = t.cellOffsets[c]; i < t.cellOffsets[c + 1]; ++i) sum += x[t.cellVertices[i]];
      p[x.size() + c] = sum / float(t.cellOffsets[c + 1] - t.cellOffsets[c]);
    }
  }

  std::vector<SimplexTopology> topologies_;
  std::vector<TriangleMesh> surfaces_;
  std::vector<std::unique_ptr<SurfaceDistanceQuery>> trees_;
  std::vector<std::uint8_t> contact_;
};
}  // namespace

void registerCollisionForce(Registry& registry) {
  registry.addForce({"collision",
                     "keeps structures out of each other: a vertex inside another structure (or within the margin "
                     "of it) is pulled to the margin outside its surface",
                     {{"margin_mm", 0.25, 0.0, 5.0, "mm", "distance kept between the surfaces of two structures", false},
                      {"contact_damping", 1.0, 0.0, 2.0, "", "damping of a touching vertex's motion (per step), on top of the integrator's", false}},
                     [] { return std::make_unique<CollisionForce>(); }});
}

}  // namespace sinew
