// The radial force (paper 001 section 2.3; docs/medial.md). At each level every active structure's
// medial surface is built from its reference shape (core/medial_axis.h): medial vertices Q_j, and
// per vertex i weights w_ij and a radius r_i. A vertex is pulled or pushed along P_i P_i_perp until
// it lies r_i from its medial point P_i_perp = sum_j w_ij Q_j:
//   f_i = alpha m_i (1 - r_i / |P_i P_i_perp|) P_i P_i_perp   (mass-scaled, as the contacts).
// The medial vertices are simulated with the surface as massless points: at the first evaluation of
// a level they start where the surface puts them (each vertex votes for x_i - r_i n_i), and at every
// evaluation they relax `medial_iterations` times under the paper's momentum-conserving reaction
// f_ij = -w_ij f_i, averaged per medial vertex (weights w_ij m_i) and divided by the stiffness
// (once per step by default: the paper moves them once per step with the surface). Over
// the steps they follow their equilibrium, where the forces on the surface sum to 0. They are not
// rolled back with the surface after a guard's rollback: they relax back to it.
#include "sinew/core/medial_axis.h"
#include "sinew/core/registry.h"

#include <vector>

namespace sinew {

namespace {
struct StructureMedial {
  MedialSurface medial;
  MedialVoters voters;  // the inverse of medial's weights (local surface vertices)
  std::vector<Vec3> q;  // the medial vertices now (empty until the level's first evaluation)
  MedialOptions options;  // what it was built with
};

class RadialForce final : public Force {
public:
  Requirements requirements() const override {
    return {.attributes = {Attribute::Mass, Attribute::Normal, Attribute::ReferencePosition, Attribute::ReferenceNormal},
            .referenceShape = true};
  }

  // At each level: nothing built yet. A structure's medial surface is built on its first evaluation
  // with a positive weight, and again when spacing_mm or neighbours change.
  void prepare(ForceContext& ctx) override {
    structures_.assign(ctx.store.meshCount(), {});
    builtFor_ = ctx.store.vertexCount();
  }

  void ensureBuilt(ForceContext& ctx, Index m) {
    const MedialOptions options{.spacingMm = ctx.params.getf(0, ctx.params.indexOf("spacing_mm")),
                                .neighbours = int(ctx.params.get(0, ctx.params.indexOf("neighbours")))};
    StructureMedial& t = structures_[m];
    if (t.medial.surfaceVertexCount() > 0 && t.options == options) return;
    MeshStore& s = ctx.store;
    t = {};
    t.options = options;
    t.medial = buildMedialSurface(s.mesh(s.referencePositions(), m), s.mesh(s.referenceNormals(), m), options, ctx.executor);
    t.voters = votersOf(t.medial);
  }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    if (builtFor_ != s.vertexCount()) prepare(ctx);
    const int iterations = int(ctx.params.get(0, ctx.params.indexOf("medial_iterations")));
    direction_.assign(s.vertexCount(), Vec3::Zero());
    stiffness_.assign(s.vertexCount(), 0.0f);
    slack_.assign(s.vertexCount(), 0.0f);
    for (Index m = 0; m < s.meshCount(); ++m)
      if (ctx.params.getf(m, 0) > 0.0f) ensureBuilt(ctx, m);
    const auto x = s.positions();
    const auto normals = s.normals();
    const auto mass = s.masses();
    for (Index m = 0; m < s.meshCount(); ++m) {
      const float alpha = ctx.params.getf(m, 0);
      if (!(alpha > 0.0f)) continue;
      StructureMedial& t = structures_[m];
      const MedialSurface& ms = t.medial;
      const Index begin = s.range(m).vertexBegin, n = ms.surfaceVertexCount();
      const Index medialCount = Index(ms.vertices.size());
      // First, the surface's votes: where each vertex's reference radius puts its medial point.
      std::vector<Vec3>& q = t.q;
      if (q.empty()) {
        q.resize(medialCount);
        ctx.executor.forEach(medialCount, [&](Index j) {
          Vec3 sum = Vec3::Zero();
          float weights = 0.0f;
          for (Index k = t.voters.offsets[j]; k < t.voters.offsets[j + 1]; ++k) {
            const Index i = t.voters.vertex[k];
            sum += t.voters.weight[k] * (x[begin + i] - ms.vertexRadius[i] * normals[begin + i]);
            weights += t.voters.weight[k];
          }
          q[j] = weights > 0.0f ? Vec3(sum / weights) : ms.vertices[j];
        });
      }
      // g_i = P_i_perp - (x_i + r_i u_i), u_i the unit vector toward P_i_perp: the force per stiffness.
      std::vector<Vec3>& g = springs_;  // reused from step to step
      g.resize(std::size_t(n));
      const auto springs = [&] {
        ctx.executor.forEach(n, [&](Index i) {
          const Vec3 v = ms.foot(i, q) - x[begin + i];
          const float d = v.norm();
          g[i] = d > 1e-6f ? Vec3((1.0f - ms.vertexRadius[i] / d) * v) : Vec3::Zero();
        });
      };
      springs();
      for (int it = 0; it < iterations; ++it) {
        ctx.executor.forEach(medialCount, [&](Index j) {
          Vec3 reaction = Vec3::Zero();
          float stiffness = 0.0f;
          for (Index k = t.voters.offsets[j]; k < t.voters.offsets[j + 1]; ++k) {
            const Index i = t.voters.vertex[k];
            reaction -= t.voters.weight[k] * mass[begin + i] * g[i];
            stiffness += t.voters.weight[k] * mass[begin + i];
          }
          if (stiffness > 0.0f) q[j] += reaction / stiffness;
        });
        springs();
      }
      ctx.executor.forEach(n, [&](Index i) {
        const Index v = begin + i;
        const Vec3 toFoot = ms.foot(i, q) - x[v];
        const float d = toFoot.norm();
        if (!(d > 1e-6f)) return;
        direction_[v] = toFoot / d;
        stiffness_[v] = alpha * mass[v];
        slack_[v] = std::max(0.0f, 1.0f - ms.vertexRadius[i] / d);
        forces[v] += stiffness_[v] * g[i];
      });
    }
  }

  // With the medial points held fixed over the step: d f_i / d x_i =
  // -alpha m_i [(1 - r_i/d_i)(I - u u^T) + u u^T]; the tangential part clamped at 0 where the vertex
  // is inside its radius (d_i < r_i), so that the block stays negative semi-definite.
  bool addJacobian(ForceContext& ctx, JacobianBlocks& jacobian) override {
    if (stiffness_.size() != std::size_t(ctx.store.vertexCount())) return true;
    ctx.executor.forEach(ctx.store.vertexCount(), [&](Index v) {
      if (!(stiffness_[v] > 0.0f)) return;
      const Vec3& u = direction_[v];
      const Mat3 along = u * u.transpose();
      jacobian.self[v] -= stiffness_[v] * (slack_[v] * (Mat3::Identity() - along) + along);
    });
    return true;
  }

private:
  std::vector<StructureMedial> structures_;
  Index builtFor_ = -1;
  std::vector<Vec3> direction_;
  std::vector<float> stiffness_, slack_;
  std::vector<Vec3> springs_;  // g_i of the structure being evaluated
};
}  // namespace

void registerRadialForce(Registry& registry) {
  registry.addForce({"radial",
                     "radial constraint: keeps each vertex at its reference radius from the structure's medial surface "
                     "(tubular and sheet-like structures; paper 001 section 2.3)",
                     {{"spacing_mm", 2.0, 0.5, 20.0, "mm", "the medial surface's resolution: one medial vertex per cube of this edge", false},
                      {"neighbours", 4, 1, 16, "", "medial vertices each surface vertex is interpolated from", false},
                      {"medial_iterations", 1, 0, 100, "",
                       "relaxations of the medial vertices under the surface's reaction per evaluation (0: they stay where the surface's votes put them at the level's start)",
                       false}},
                     [] { return std::make_unique<RadialForce>(); }});
}

}  // namespace sinew
