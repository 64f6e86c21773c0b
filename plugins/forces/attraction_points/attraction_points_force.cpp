// Points the user places on a structure.
// - Attraction points (paper 000 section 4.5, equations 2-3): for each point C, the closest vertex
//   P0 and its p-ring P1..PN are pulled along C - P0 with weights w_i = 1 / |C - P_i| normalised to
//   sum 1. The activation alpha scales the whole force (in equation 3 it would cancel in the
//   normalisation).
// - Include / exclude points (paper 001 section 4: models "forced to include or exclude these
//   constraint points"): C must lie at least `margin_mm` inside (include) or outside (exclude) the
//   surface. Inside or outside is the winding number of the Fig. 1b tessellation about C (above
//   one half: inside); the closest vertex's normal alone was wrong beside a bulge (measured). While
//   C is on the wrong side, or on the right side but closer than the margin to P0, P0 and its
//   p-ring are pushed along P0's normal n0 by d = |C - P0| + margin on the wrong side, margin -
//   |C - P0| on the right one (outward for include, inward for exclude), each vertex by
//   alpha m_i (w_i / w_0) d: P0 by the whole shift, as a collision contact is, so that the shape
//   forces cannot hold the point on the wrong side (normalised to sum 1, as for attraction, they
//   did: measured). Otherwise no force.
#include "sinew/core/registry.h"
#include "sinew/core/collision_tree.h"  // asP3
#include "sinew/core/winding.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

namespace sinew {

namespace {
struct Closest {
  float d2 = std::numeric_limits<float>::max();
  Index v = -1;
  // Ties go to the lower index, so the result does not depend on how the search is split.
  static Closest better(const Closest& a, const Closest& b) {
    if (a.d2 != b.d2) return a.d2 < b.d2 ? a : b;
    return a.v < b.v ? a : b;
  }
};

class AttractionPointsForce final : public Force {
public:
  Requirements requirements() const override { return {.attributes = {Attribute::Normal, Attribute::Mass, Attribute::CellCentre}}; }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    const auto x = s.positions();
    const auto normals = s.normals();
    const int kRing = ctx.params.indexOf("ring");
    const int kMargin = ctx.params.indexOf("margin_mm");
    const auto& attraction = ctx.scene.attractionPoints();
    const auto& constraints = ctx.scene.constraintPoints();
    const auto count = [](const auto& lists, Index m) { return m < Index(lists.size()) ? lists[m].size() : 0; };
    for (Index m = 0; m < s.meshCount(); ++m) {
      const float alpha = ctx.params.getf(m, 0);
      if (alpha <= 0.0f || count(attraction, m) + count(constraints, m) == 0) continue;
      const MeshRange& r = s.range(m);
      const int ring = static_cast<int>(ctx.params.get(m, kRing));
      const auto closest = [&](const Vec3& c) {
        return ctx.executor
            .reduce(
                r.vertexBegin, r.vertexEnd, Closest{},
                [&](Index begin, Index end, Closest best) {
                  for (Index v = begin; v < end; ++v) best = Closest::better(best, {(x[v] - c).squaredNorm(), v});
                  return best;
                },
                Closest::better)
            .v;
      };
      for (size_t i = 0; i < count(attraction, m); ++i) {
        const Vec3& c = attraction[m][i];
        const Index p0 = closest(c);
        pullRing(s, p0, ring, c, alpha * (c - x[p0]), false, forces);
      }
      const float margin = ctx.params.getf(m, kMargin);
      const collision::P3* px = asP3(std::span<const Vec3>(x));
      const collision::P3* centres = asP3(s.cellCentres());
      const Index* offsets = s.cellOffsets().data();
      const Index* cellVertices = s.cellVertices().data();
      for (size_t i = 0; i < count(constraints, m); ++i) {
        const ConstraintPoint& cp = constraints[m][i];
        const float winding = ctx.executor.reduce(
            r.cellBegin, r.cellEnd, 0.0f,
            [&](Index begin, Index end, float sum) {
              for (Index c = begin; c < end; ++c) sum += cellSolidAngle(px, centres, offsets, cellVertices, c, asP3(cp.at));
              return sum;
            },
            std::plus<float>()) / (4.0f * float(M_PI));
        const Index p0 = closest(cp.at);
        const float shift = constraintShift(cp.include, winding > 0.5f, (cp.at - x[p0]).norm(), margin);
        if (shift != 0.0f) pullRing(s, p0, ring, cp.at, (alpha * shift) * normals[p0], true, forces);
      }
    }
  }

private:
  // Adds w_i / sum(w) * pull (constraint: m_i w_i / w_0 * pull) to P0 and every vertex within `ring`
  // edges of it (breadth-first order), w_i = 1 / |c - P_i|.
  static void pullRing(MeshStore& s, Index p0, int ring, const Vec3& c, const Vec3& pull, bool constraint,
                       std::span<Vec3> forces) {
    const auto x = s.positions();
    const auto nb = s.neighbours();
    std::vector<Index> group{p0};
    size_t frontier = 0;
    for (int level = 0; level < ring; ++level) {
      const size_t end = group.size();
      for (size_t i = frontier; i < end; ++i)
        for (Index n : nb[group[i]])
          if (std::find(group.begin(), group.end(), n) == group.end()) group.push_back(n);
      frontier = end;
    }
    std::vector<float> w(group.size());
    float total = 0.0f;
    for (size_t i = 0; i < group.size(); ++i) {
      w[i] = 1.0f / std::max((c - x[group[i]]).norm(), 1e-6f);
      total += w[i];
    }
    if (constraint) {
      const auto mass = s.masses();
      for (size_t i = 0; i < group.size(); ++i) forces[group[i]] += (mass[group[i]] * w[i] / w[0]) * pull;
    } else {
      for (size_t i = 0; i < group.size(); ++i) forces[group[i]] += (w[i] / total) * pull;
    }
  }
};
}  // namespace

void registerAttractionPointsForce(Registry& registry) {
  registry.addForce({"attraction_points",
                     "user-placed points: pulls the vertex closest to each attraction point, and its p-ring, toward "
                     "it; pushes the same group until each include point lies inside the structure and each exclude "
                     "point outside",
                     {{"ring", 2, 0, 10, "", "neighbourhood order p pulled with the closest vertex"},
                      {"margin_mm", 0.5, 0.0, 5.0, "mm",
                       "how far inside (include points) or outside (exclude points) the surface a point is held"}},
                     [] { return std::make_unique<AttractionPointsForce>(); }});
}

}  // namespace sinew
