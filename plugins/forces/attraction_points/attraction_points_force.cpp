// Attraction points (paper 000 section 4.5, equations 2-3): for each point C the user placed on a
// structure, the closest vertex P0 and its p-ring P1..PN are pulled along C - P0 with weights
// w_i = 1 / |C - P_i| normalised to sum 1. The activation alpha scales the whole force (in
// equation 3 it would cancel in the normalisation).
#include "sinew/core/registry.h"

#include <algorithm>
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
  Requirements requirements() const override { return {{}, false}; }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    const auto x = s.positions();
    const auto nb = s.neighbours();
    const int kRing = ctx.params.indexOf("ring");
    const auto& points = ctx.scene.attractionPoints();
    for (Index m = 0; m < s.meshCount() && m < static_cast<Index>(points.size()); ++m) {
      const float alpha = ctx.params.getf(m, 0);
      if (alpha <= 0.0f || points[m].empty()) continue;
      const MeshRange& r = s.range(m);
      const int ring = static_cast<int>(ctx.params.get(m, kRing));
      for (const Vec3& c : points[m]) {
        const Closest p0 = ctx.executor.reduce(
            r.vertexBegin, r.vertexEnd, Closest{},
            [&](Index begin, Index end, Closest best) {
              for (Index v = begin; v < end; ++v) best = Closest::better(best, {(x[v] - c).squaredNorm(), v});
              return best;
            },
            Closest::better);
        const std::vector<Index> group = ringAround(nb, p0.v, ring);
        std::vector<float> w(group.size());
        float total = 0.0f;
        for (size_t i = 0; i < group.size(); ++i) {
          w[i] = 1.0f / std::max((c - x[group[i]]).norm(), 1e-6f);
          total += w[i];
        }
        const Vec3 pull = c - x[p0.v];
        for (size_t i = 0; i < group.size(); ++i) forces[group[i]] += (alpha * w[i] / total) * pull;
      }
    }
  }

private:
  // P0 and every vertex within `ring` edges of it, in breadth-first order.
  static std::vector<Index> ringAround(std::span<const std::array<Index, 3>> nb, Index v0, int ring) {
    std::vector<Index> out{v0};
    size_t frontier = 0;
    for (int level = 0; level < ring; ++level) {
      const size_t end = out.size();
      for (size_t i = frontier; i < end; ++i)
        for (Index n : nb[out[i]])
          if (std::find(out.begin(), out.end(), n) == out.end()) out.push_back(n);
      frontier = end;
    }
    return out;
  }
};
}  // namespace

void registerAttractionPointsForce(Registry& registry) {
  registry.addForce({"attraction_points",
                     "pulls the vertex closest to each user-placed point, and its p-ring, toward it",
                     {{"ring", 2, 0, 10, "", "neighbourhood order p pulled with the closest vertex"}},
                     [] { return std::make_unique<AttractionPointsForce>(); }});
}

}  // namespace sinew
