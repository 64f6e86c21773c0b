// A bounding-volume hierarchy over a fixed triangle mesh (a ground-truth surface), for exact
// point-to-surface distances; built on the host (TriangleBvh, surface_distance.h). The query is inline and compiles for the host and the device (like
// collision_bvh.h, whose closest-point routine it uses), so the exact evaluation, the sampled error
// on the CPU and its CUDA kernel find the same distances.
#pragma once

#include "sinew/core/collision_bvh.h"

namespace sinew::trianglebvh {
using collision::Box;
using collision::P3;

constexpr int kLeafTriangles = 4;
constexpr int kStackDepth = 64;

// Leaves have left == -1 and hold the triangles first .. first + count (corners 3 t .. 3 t + 2).
struct Node {
  Box box;
  int left, right, first, count;
};

// Several meshes' hierarchies may share the arrays (node and triangle indices absolute); a query
// starts at one mesh's root.
struct View {
  const Node* nodes = nullptr;
  const P3* corners = nullptr;
};

// The squared distance from p to the closest point of the mesh under `root`, or maxD2 when it is
// farther (branch and bound, nearer child first). `closest` receives the point and `triangle` its
// triangle (in leaf order) when not null. `facing` (not null): only the triangles whose normal
// (corners counter-clockwise) has a non-negative dot product with it.
SINEW_HD float closestSquaredDistance(const View& v, int root, P3 p, float maxD2, P3* closest = nullptr,
                                      int* triangle = nullptr, const P3* facing = nullptr) {
  float best = maxD2;
  // A node is kept with its box's distance, so that one no longer nearer than the best is dropped
  // without loading it.
  int stack[kStackDepth];
  float near[kStackDepth];
  int top = 0;
  stack[top] = root, near[top++] = collision::squaredDistance(v.nodes[root].box, p);
  while (top > 0) {
    --top;
    if (near[top] >= best) continue;
    const Node& n = v.nodes[stack[top]];
    if (n.left < 0) {
      for (int t = n.first; t < n.first + n.count; ++t) {
        const P3 a = v.corners[3 * t], b = v.corners[3 * t + 1], c = v.corners[3 * t + 2];
        // A triangle is no nearer than its plane: one dot product drops most of a leaf's triangles
        // before the closest-point test and its branches (the sampled error's searches start with
        // a tight bound). Equal distances only to rounding, which can change the pick between two
        // triangles equally near; degenerate triangles (no plane) are always tested.
        const P3 normal = collision::cross3(collision::sub(b, a), collision::sub(c, a));
        if (facing && collision::dot3(normal, *facing) < 0.0f) continue;
        const float height = collision::dot3(normal, collision::sub(p, a)), normal2 = collision::dot3(normal, normal);
        if (normal2 > 0.0f && height * height >= best * normal2) continue;
        const P3 q = collision::closestOnTriangle(p, a, b, c);
        const P3 d = collision::sub(p, q);
        const float d2 = collision::dot3(d, d);
        if (d2 < best) {
          best = d2;
          if (closest) *closest = q;
          if (triangle) *triangle = t;
        }
      }
      continue;
    }
    const float dl = collision::squaredDistance(v.nodes[n.left].box, p);
    const float dr = collision::squaredDistance(v.nodes[n.right].box, p);
    if (top + 2 > kStackDepth) continue;  // unreachable for TriangleBvh::build's trees; never overrun
    const bool leftFirst = dl < dr;
    if ((leftFirst ? dr : dl) < best) stack[top] = leftFirst ? n.right : n.left, near[top++] = leftFirst ? dr : dl;
    if ((leftFirst ? dl : dr) < best) stack[top] = leftFirst ? n.left : n.right, near[top++] = leftFirst ? dl : dr;
  }
  return best;
}

// The squared distance from p to triangle t (of `corners`, three per triangle), its closest point
// in q: a search's starting bound.
SINEW_HD float squaredDistanceToTriangle(const P3* corners, int t, P3 p, P3& q) {
  q = collision::closestOnTriangle(p, corners[3 * t], corners[3 * t + 1], corners[3 * t + 2]);
  const P3 d = collision::sub(p, q);
  return collision::dot3(d, d);
}

// The surface under `root` near c, to first order: the plane through c's closest point, normal to
// the direction from that point to c (its triangle's normal where c lies on the surface), and c's
// distance to it. A point s near c is about |d + n . (s - c)| from the surface (planeDistance): exact
// where the surface is flat there, off by about |s - c|^2 / 2R on a surface of curvature radius R.
struct TangentPlane {
  P3 n;
  float d;
};
// `hint` (when not null): the triangle nearest to c last time (-1: none), replaced by this time's;
// the search starts bounded by the distance to it (the sampled error's patches, whose meshes move
// little between samples). `Tree`: View (the device's) or WideView (the host's, triangle_bvh_wide.h),
// each with its closestSquaredDistance.
template <class Tree>
SINEW_HD TangentPlane closestTangentPlane(const Tree& v, int root, P3 c, int* hint = nullptr) {
  P3 q = c;
  int t = 0;
  float bound = 3.0e38f;
  if (hint && *hint >= 0) bound = squaredDistanceToTriangle(v.corners, t = *hint, c, q);
  const float d = sqrtf(closestSquaredDistance(v, root, c, bound, &q, &t));
  if (hint) *hint = t;
  if (d > 1.0e-4f) return {collision::scale(collision::sub(c, q), 1.0f / d), d};
  return {collision::unitNormal(v.corners[3 * t], v.corners[3 * t + 1], v.corners[3 * t + 2]), d};
}
SINEW_HD float planeDistance(const TangentPlane& plane, P3 c, P3 s) {
  const float signedDistance = plane.d + collision::dot3(plane.n, collision::sub(s, c));
  return signedDistance < 0.0f ? -signedDistance : signedDistance;
}
}  // namespace sinew::trianglebvh

namespace sinew {
// A distance with the area it stands for.
struct WeightedDistance {
  float d, w;
};

// The sampled error's (sampled_error.h) samples of a triangle: one, its centroid, for a triangle
// small beside the sampling spacing; otherwise kSubTriangles, the centroids of its four midpoint
// sub-triangles (the corner ones, then the middle one). Sample q of `count`.
inline constexpr int kSubTriangles = 4;
SINEW_HD collision::P3 subTriangleCentroid(collision::P3 a, collision::P3 b, collision::P3 c, int q, int count) {
  using namespace collision;
  const P3 centroid = scale(add(a, add(b, c)), 1.0f / 3.0f);
  if (count == 1 || q == 3) return centroid;
  const P3 corner = q == 0 ? a : q == 1 ? b : c;
  return scale(add(corner, centroid), 0.5f);  // halfway from a corner to the centroid
}
// The corners of the sub-triangle whose centroid subTriangleCentroid gives (the area sample q
// stands for), into out[0..2].
inline void subTriangleCorners(collision::P3 a, collision::P3 b, collision::P3 c, int q, int count, collision::P3* out) {
  using namespace collision;
  const P3 ab = scale(add(a, b), 0.5f), bc = scale(add(b, c), 0.5f), ca = scale(add(c, a), 0.5f);
  const P3 corners[4][3] = {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}};
  const P3* k = count == 1 ? nullptr : corners[q];
  out[0] = k ? k[0] : a, out[1] = k ? k[1] : b, out[2] = k ? k[2] : c;
}
}  // namespace sinew
