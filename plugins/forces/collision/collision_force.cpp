// Non-penetration between structures (paper 001 section 2.2; the issue on collisions). Detection
// and response are core/collision_bvh.h, the code the CUDA backend runs too: each structure's box
// (broad phase), then its hierarchy over the coarse proxy down to the Fig. 1b triangles (narrow
// phase), refitted at each full search. A vertex inside another structure, or closer than the margin, is
// pulled to the point `margin` outside that surface (optionally with extra damping while it touches);
// one that has gone past that structure's middle moves back into its own (collision::respondTo).
#include "sinew/core/collision_tree.h"
#include "sinew/core/registry.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace sinew {

namespace {
class CollisionForce final : public Force {
public:
  Requirements requirements() const override {
    return {.attributes = {Attribute::PreviousPosition, Attribute::CellCentre, Attribute::Area, Attribute::Mass, Attribute::Normal}};
  }

  // The level's state is set up at its first step here (setUp): where a GPU backend runs the
  // steps, the host builds no tree it would not use (130 ms at 325,632 vertices on 16 threads).
  void prepare(ForceContext&) override {
    tree_ = {};
    builtFor_ = -1;
    stiffness_.clear();
    hold_.clear();
  }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    if (s.meshCount() < 2) return;
    if (tree_.roots.empty() || builtFor_ != s.vertexCount()) setUp(ctx);
    const float margin = ctx.params.getf(0, ctx.params.indexOf("margin_mm"));
    // Once per level: a structure inside another stops the run with the reason.
    if (!checked_) {
      checked_ = true;
      tree_.handleEnclosures(s, ctx.scene, margin, ctx.params.getf(0, ctx.params.indexOf("ignore_enclosed")) > 0.5f);
    }
    const int every = fullSearchEveryOf(ctx.params);
    const bool full = step_++ % every == 0 || levelStep_ < fullSearchFirstOf(ctx.params);
    ++levelStep_;
    if (full) tree_.refit(s.positions(), s.cellCentres(), ctx.executor);  // only full searches read the boxes
    const collision::ContactSettings settings = contactSettingsOf(ctx.params);
    collision::BvhView view = tree_.view();
    view.reacts = settings.reaction > 0.0f;
    if (full && view.share) {  // the depths as the search begins (collision::shareAt)
      lastDepth_ = depth_;
      view.lastDepth = lastDepth_.data();
    }
    const collision::P3* x = asP3(s.positions());
    const collision::P3* centres = asP3(s.cellCentres());
    const auto previous = s.previousPositions();
    const auto meshOf = s.meshOfVertex();
    const auto mass = s.masses();
    const auto area = s.areas();
    const auto normals = s.normals();
    const float motion = full ? trackMotion(s.positions(), ctx.executor) : 0.0f;  // paid at full searches
    stiffness_.assign(s.vertexCount(), 0.0f);
    const bool holding = settings.hold >= 0.0f;
    hold_.assign(holding ? s.vertexCount() : 0, collision::HoldPlane{});
    // The hold's limit a step from the areas as the step found them (constrain comes after the move;
    // only active vertices get a hold plane, so only theirs is needed).
    holdLimit_.assign(holding && settings.holdStep < 3.0e38f ? s.vertexCount() : 0, 3.0e38f);
    forActiveVertices(ctx, [&](Index v, float alpha) {
      if (!holdLimit_.empty()) holdLimit_[v] = collision::holdLimit(settings, area.data(), v);
      collision::P3 f{0, 0, 0};
      stiffness_[v] = collision::contactResponse(view, int(meshOf[v]), x[v], asP3(previous[v]), asP3(normals[v]),
                                                 alpha * mass[v], settings, full, every, moved_[v], motion, depth_[v],
                                                 hint_[v], slack_[v], plane_[v], x, centres, f, holding ? &hold_[v] : nullptr);
      forces[v] += asVec3(f);
    });
    if (settings.reaction > 0.0f) addReaction(ctx, settings, forces);
  }

  // After a guard's rollback the planes are those of the undone steps' last full search, which may
  // lie where the other surface never was in the state put back: the next step searches in full
  // (5 levels, a full search every 16 steps: Pallidum_L had been pushed 2 mm off its place;
  // docs/collisions.md). The clearances need nothing: each vertex's move back from where that
  // search saw it is paid at the next one, as any move is. The depths and hints bound and start it.
  void restored(ForceContext&) override { step_ = 0; }

  // A touching vertex is pulled toward a point held fixed over the step (a retreating vertex's push
  // is constant: no stiffness).
  bool addJacobian(ForceContext& ctx, JacobianBlocks& jacobian) override {
    addFixedPointPullJacobian(ctx, stiffness_, jacobian);
    return true;
  }

  // The hold: a vertex the step's contacts pulled is moved out along the contact's normal to at least
  // hold_mm outside the plane of that contact (found before the step), whatever the other forces
  // did; its motion inward leaves the velocity (collision::holdOut).
  void constrain(ForceContext& ctx) override {
    if (hold_.size() != size_t(ctx.store.vertexCount())) return;
    auto x = ctx.store.positionsForWrite();
    auto previous = ctx.store.previousPositions();
    ctx.executor.forEach(ctx.store.vertexCount(), [&](Index v) {
      collision::P3 p = asP3(x[v]), q = asP3(previous[v]);
      collision::holdOut(hold_[v], p, q, holdLimit_.empty() ? 3.0e38f : holdLimit_[v]);
      x[v] = asVec3(p);
      previous[v] = asVec3(q);
    }, 4096);
  }

private:
  // Each touching vertex's reaction on the other surface (collision::reactionPush), summed per
  // vertex in vertex order: one vertex's triangle is another's, so the sums are serial (the
  // device's are exact, in fixed point). Then each vertex's sum times its mass. Only active
  // structures push or are pushed (their weight: column 0).
  void addReaction(ForceContext& ctx, const collision::ContactSettings& settings, std::span<Vec3> forces) {
    MeshStore& s = ctx.store;
    const collision::P3* x = asP3(s.positions());
    const collision::P3* centres = asP3(s.cellCentres());
    const auto meshOf = s.meshOfVertex();
    const auto mass = s.masses();
    const auto normals = s.normals();
    const auto cellOffsets = s.cellOffsets();
    const auto cellVertices = s.cellVertices();
    reaction_.assign(s.vertexCount(), collision::P3{0, 0, 0});
    for (Index v = 0; v < s.vertexCount(); ++v) {
      const collision::ContactPlane& k = plane_[v];
      collision::P3 push;
      if (!(k.share >= 0.0f) || !(ctx.params.getf(meshOf[v], 0) > 0.0f) ||
          !collision::reactionPush(k, x[v], asP3(normals[v]), settings, x[k.corners.a], x[k.corners.b],
                                   centres[k.corners.cell], push))
        continue;
      const Index first = cellOffsets[k.corners.cell], size = cellOffsets[k.corners.cell + 1] - first;
      for (Index j = 0; j < 2 + size; ++j) {
        const Index u = collision::reactionPartner(k, int(j), cellVertices.data() + first);
        const float alpha = ctx.params.getf(meshOf[u], 0);
        if (alpha > 0.0f)
          reaction_[u] = collision::add(reaction_[u], collision::scale(push, collision::reactionPart(k, int(j), int(size)) * alpha));
      }
    }
    ctx.executor.forEach(s.vertexCount(), [&](Index v) { forces[v] += asVec3(reaction_[v]) * mass[v]; }, 4096);
  }

  // The level's tree and per-vertex state, at its first step (or after a change of topology).
  void setUp(ForceContext& ctx) {
    const Index n = ctx.store.vertexCount();
    depth_.assign(n, collision::kUnknownDepth);
    hint_.assign(n, -1);
    slack_.assign(n, 0.0f);
    plane_.assign(n, collision::ContactPlane{});
    moved_.assign(n, 0.0f);
    const auto x = ctx.store.positions();
    last_.assign(x.begin(), x.end());
    step_ = 0;
    levelStep_ = 0;
    builtFor_ = n;
    checked_ = false;
    tree_ = CollisionTree::build(ctx.store);
    tree_.setShares(ctx.store, ctx.scene, ctx.params);
  }

  // Each vertex's distance from where the last full search saw it (moved_), and the largest: the
  // motion that the clearance of every vertex pays for (collision::clearOfContacts).
  float trackMotion(std::span<const Vec3> x, const Executor& executor) {
    return executor.reduce(
        Index(0), Index(x.size()), 0.0f,
        [&](Index b, Index e, float largest) {
          for (Index v = b; v < e; ++v) {
            moved_[v] = (x[v] - last_[v]).norm();
            last_[v] = x[v];
            largest = std::max(largest, moved_[v]);
          }
          return largest;
        },
        [](float a, float b) { return std::max(a, b); }, 4096);
  }

  CollisionTree tree_;
  Index builtFor_ = -1;
  bool checked_ = false;
  std::vector<float> stiffness_;
  std::vector<collision::HoldPlane> hold_;  // per vertex, from the last step's contacts (empty: no hold)
  std::vector<float> holdLimit_;             // per vertex, the hold's limit a step (empty: none)
  std::vector<float> depth_;  // each vertex's last penetration (collision::contactResponse)
  std::vector<float> lastDepth_;  // depth_ as a full search began (collision::BvhView::lastDepth)
  std::vector<int> hint_;     // each vertex's last nearest contact leaf
  std::vector<float> slack_;  // each vertex's clearance of the other structures beyond the margin
  std::vector<collision::ContactPlane> plane_;  // each vertex's deepest contact at the last full search
  std::vector<collision::P3> reaction_;         // each vertex's sum of pushes (addReaction)
  std::vector<float> moved_;
  std::vector<Vec3> last_;    // the positions the last full search saw
  long step_ = 0;       // steps since the level began or a rollback: every full_search_every-th one searches in full
  long levelStep_ = 0;  // steps since the level began, rollbacks or not (full_search_first)
};
}  // namespace

void registerCollisionForce(Registry& registry) {
  registry.addForce({"collision",
                     "keeps structures out of each other: a vertex inside another structure (or within the margin "
                     "of it) is pulled to the margin outside its surface; one past the middle of that structure moves back "
                     "into its own",
                     {{"margin_mm", 0.15, 0.0, 5.0, "mm", "distance outside the other structure's surface that a touching vertex is pulled to", false},
                      {"contact_damping", 0.0, 0.0, 2.0, "", "damping of a touching vertex's motion (per step), on top of the integrator's", false},
                      {"reach_mm", 0.25, 0.05, 5.0, "mm", "how far beyond its last penetration a vertex looks for contacts each step (on top of twice its last step)", false},
                      {"retreat_mm", 0.25, 0.0, 5.0, "mm", "a vertex that has gone past the middle of another structure (its nearest surface there faces the way its own does) is pushed back into its own structure, as if pulled toward a point this far behind it along its normal, instead of on through", false},
                      {"hold_mm", 0.1, -1.0, 5.0, "mm", "after each step, a vertex pulled by a contact is moved out to at least this far outside the plane of that contact; negative: no hold", false},
                      {"hold_step", 0.0, 0.0, 10.0, "", "the most the hold moves a vertex in one step, as a fraction of the vertex's spacing (the square root of its area); 0: no limit (sinew-make-scene writes 0.05 for schedules of 5 levels or more)", false},
                      {"size_share", 2.0, 0.0, 8.0, "", "how two structures in contact share the correction: a vertex takes min(1, 2 a^p / (a^p + b^p)) of it, a its structure's surface area, b the other's, p this; the larger gives way more; against a structure weighted 0 a vertex takes all, and more than its share where the other side's vertices are less deep inside than it is; 0: both take all of it", false},
                      {"full_search_every", 1, 1, 16, "steps", "a full contact search every this many steps; in between, each vertex meets only the plane of the deepest contact the last full search found, moved with that surface (sinew-make-scene writes 16)", false},
                      {"full_search_first", 0, 0, 1000, "steps", "with full_search_every above 1: a full search at each of a level's first this many steps as well, where the structures move the most (sinew-make-scene writes 8 for schedules of 5 levels or more)", false},
                      {"ahead_mm", 0.5, 0.0, 50.0, "mm", "with full_search_every above 1: how much farther, at most, a full search looks for the contacts a vertex may meet before the next one (twice its last step for each step until then, beyond the first)", false},
                      {"ignore_enclosed", 0.0, 0.0, 1.0, "", "1: a structure lying inside another by design (nested labels) is left out of collisions with it; 0: such a pair stops the run with the reason", false},
                      {"reaction", 0.0, 0.0, 8.0, "", "a vertex inside another structure that takes less than all of the correction (size_share) pushes that structure's contact triangle the other way by the rest, times this; a vertex then takes more than its share by size only where the other side touched nothing; 0: no push (sinew-make-scene writes 2)", false}},
                     [] { return std::make_unique<CollisionForce>(); }});
}

}  // namespace sinew
