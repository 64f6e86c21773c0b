#include "sinew/core/surface_distance.h"

#include "sinew/core/collision_bvh.h"
#include "sinew/core/executor.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sinew {

namespace {

// Closest point on triangle: the routine the collision detection uses (collision_bvh.h).
Vec3 closestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  using collision::P3;
  const P3 q = collision::closestOnTriangle(P3{p.x(), p.y(), p.z()}, P3{a.x(), a.y(), a.z()}, P3{b.x(), b.y(), b.z()},
                                            P3{c.x(), c.y(), c.z()});
  return {q.x, q.y, q.z};
}

using Box = Eigen::AlignedBox3f;

}  // namespace

struct SurfaceDistanceQuery::Impl {
  struct Node {
    Box box;
    int left = -1, right = -1;  // children, or -1 for a leaf
    int begin = 0, end = 0;     // triangle range in order
  };
  std::vector<Vec3> a, b, c;
  std::vector<int> order;
  std::vector<Node> nodes;

  int build(int begin, int end) {
    Node n;
    n.begin = begin;
    n.end = end;
    Box centroids;
    for (int i = begin; i < end; ++i) {
      const int t = order[i];
      n.box.extend(a[t]).extend(b[t]).extend(c[t]);
      centroids.extend((a[t] + b[t] + c[t]) / 3.0f);
    }
    const int id = static_cast<int>(nodes.size());
    nodes.push_back(n);
    if (end - begin <= 8) return id;
    int axis;
    centroids.sizes().maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](int s, int t) {
      return (a[s] + b[s] + c[s])[axis] < (a[t] + b[t] + c[t])[axis];
    });
    const int l = build(begin, mid);
    const int r = build(mid, end);
    nodes[id].left = l;
    nodes[id].right = r;
    return id;
  }

  Vec3 query(const Vec3& p) const {
    float best2 = std::numeric_limits<float>::max();
    Vec3 bestPoint = p;
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes[stack[--top]];
      if (n.box.squaredExteriorDistance(p) >= best2) continue;
      if (n.left < 0) {
        for (int i = n.begin; i < n.end; ++i) {
          const int t = order[i];
          const Vec3 q = closestOnTriangle(p, a[t], b[t], c[t]);
          const float d2 = (q - p).squaredNorm();
          if (d2 < best2) {
            best2 = d2;
            bestPoint = q;
          }
        }
        continue;
      }
      const float dl = nodes[n.left].box.squaredExteriorDistance(p);
      const float dr = nodes[n.right].box.squaredExteriorDistance(p);
      // Visit the nearer child first (pushed last).
      if (dl < dr) {
        stack[top++] = n.right;
        stack[top++] = n.left;
      } else {
        stack[top++] = n.left;
        stack[top++] = n.right;
      }
    }
    return bestPoint;
  }
};

SurfaceDistanceQuery::SurfaceDistanceQuery(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>()) {
  if (mesh.triangles.empty()) throw InputError("surface distance: the mesh has no triangles");
  for (const auto& t : mesh.triangles) {
    impl_->a.push_back(mesh.points[t[0]]);
    impl_->b.push_back(mesh.points[t[1]]);
    impl_->c.push_back(mesh.points[t[2]]);
  }
  impl_->order.resize(mesh.triangles.size());
  std::iota(impl_->order.begin(), impl_->order.end(), 0);
  impl_->build(0, static_cast<int>(mesh.triangles.size()));
}

SurfaceDistanceQuery::~SurfaceDistanceQuery() = default;
SurfaceDistanceQuery::SurfaceDistanceQuery(SurfaceDistanceQuery&&) noexcept = default;

float SurfaceDistanceQuery::distance(const Vec3& p) const { return (impl_->query(p) - p).norm(); }
Vec3 SurfaceDistanceQuery::closestPoint(const Vec3& p) const { return impl_->query(p); }

std::vector<SurfaceSample> sampleSurface(const TriangleMesh& mesh, float spacing) {
  std::vector<SurfaceSample> out;
  for (const auto& t : mesh.triangles) {
    const Vec3 &a = mesh.points[t[0]], &b = mesh.points[t[1]], &c = mesh.points[t[2]];
    const float longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    const int n = std::max(1, static_cast<int>(std::ceil(longest / spacing)));
    const float subArea = 0.5f * (b - a).cross(c - a).norm() / static_cast<float>(n * n);
    const Vec3 u = (b - a) / static_cast<float>(n), v = (c - a) / static_cast<float>(n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        const Vec3 o = a + static_cast<float>(i) * u + static_cast<float>(j) * v;
        out.push_back({o + (u + v) / 3.0f, subArea});  // upright sub-triangle
        if (i + j + 1 < n) out.push_back({o + 2.0f * (u + v) / 3.0f, subArea});  // inverted one
      }
  }
  return out;
}

namespace {
struct Weighted {
  float d, w;
};

SurfaceDistanceStats combine(std::vector<Weighted>& all, double sumAB, double areaA, double sumBA, double areaB) {
  SurfaceDistanceStats st;
  st.meanAtoB = areaA > 0 ? sumAB / areaA : 0.0;
  st.meanBtoA = areaB > 0 ? sumBA / areaB : 0.0;
  st.assd = (sumAB + sumBA) / std::max(areaA + areaB, 1e-30);
  std::sort(all.begin(), all.end(), [](const Weighted& x, const Weighted& y) { return x.d < y.d; });
  const double target = 0.95 * (areaA + areaB);
  double acc = 0;
  for (const Weighted& w : all) {
    acc += w.w;
    if (acc >= target) {
      st.hd95 = w.d;
      break;
    }
  }
  return st;
}

// Distances from samples of one surface to another, accumulated with their areas.
// Distances are computed in parallel and summed in order, so the result does not depend on threads.
void accumulate(const std::vector<SurfaceSample>& samples, const SurfaceDistanceQuery& to,
                std::vector<Weighted>& all, double& sum, double& area, const Executor& executor) {
  const size_t first = all.size();
  all.resize(first + samples.size());
  executor.forEach(static_cast<Index>(samples.size()), [&](Index i) {
    all[first + i] = {to.distance(samples[i].point), samples[i].area};
  });
  for (size_t i = first; i < all.size(); ++i) {
    sum += static_cast<double>(all[i].d) * all[i].w;
    area += all[i].w;
  }
}
}  // namespace

SurfaceDistanceStats surfaceDistance(const TriangleMesh& a, const TriangleMesh& b, float spacing,
                                     const Executor& executor) {
  return ReferenceSurface(b, spacing).compare(a, executor);
}

ReferenceSurface::ReferenceSurface(TriangleMesh surface, float spacing)
    : surface_(std::move(surface)), spacing_(spacing), query_(surface_), samples_(sampleSurface(surface_, spacing)) {}

SurfaceDistanceStats ReferenceSurface::compare(const TriangleMesh& other, const Executor& executor) const {
  const SurfaceDistanceQuery otherQuery(other);
  std::vector<Weighted> all;
  double sumAB = 0, areaA = 0, sumBA = 0, areaB = 0;
  accumulate(sampleSurface(other, spacing_), query_, all, sumAB, areaA, executor);
  accumulate(samples_, otherQuery, all, sumBA, areaB, executor);
  return combine(all, sumAB, areaA, sumBA, areaB);
}

}  // namespace sinew
