// The host's view of a TriangleBvh (surface_distance.h): the binary tree collapsed into nodes of up
// to four children, whose boxes are tested against the query point in one vector operation, and
// leaves whose four triangles are tested at once. A walk is then about half as deep, with one load
// of a node's children's boxes, where the binary walk's chain of dependent loads and branches was
// most of its time (docs/benchmarks.md).
// The distances are those of trianglebvh::closestSquaredDistance (the same triangles, the same
// leaf test); the device keeps the binary tree (its walks are one lane's, and its kernels share
// triangle_bvh.h with the host's tests).
#pragma once

#include "sinew/core/triangle_bvh.h"

namespace sinew::trianglebvh {

constexpr int kWideChildren = 4;
// A walk's stack grows by at most three a level, and a wide tree is no deeper than its binary one,
// which stays under kStackDepth (TriangleBvh::build's medians from depth 32 down).
constexpr int kWideStackDepth = 3 * kStackDepth + 4;

// Four floats in one register (GCC's and Clang's vector extension: SSE on x86-64, NEON on arm64).
using Lanes = float __attribute__((vector_size(kWideChildren * sizeof(float))));

// A child is another wide node (child >= 0) or a leaf, child = -1 - (its index in the leaves). An
// unused slot has an empty box (lo above hi), which no point is near.
struct WideNode {
  Lanes loX, loY, loZ, hiX, hiY, hiZ;
  int child[kWideChildren];
};

// A leaf's triangles (first .. first + count, count <= kLeafTriangles) corner by corner, one per
// lane, so that the four are tested against a point at once; lanes past `count` repeat the first.
struct WideLeaf {
  Lanes ax, ay, az, bx, by, bz, cx, cy, cz;
  int first, count;
};

struct WideView {
  const WideNode* nodes = nullptr;
  const WideLeaf* leaves = nullptr;
  const P3* corners = nullptr;
};

// collision::squaredDistance to each child's box, the same value in each lane.
[[gnu::always_inline]] inline Lanes childDistances(const WideNode& n, P3 p) {
  const Lanes zero = {0.0f, 0.0f, 0.0f, 0.0f};
  Lanes dx = n.loX - p.x, dy = n.loY - p.y, dz = n.loZ - p.z;
  const Lanes ex = p.x - n.hiX, ey = p.y - n.hiY, ez = p.z - n.hiZ;
  dx = dx > ex ? dx : ex, dy = dy > ey ? dy : ey, dz = dz > ez ? dz : ez;
  dx = dx > zero ? dx : zero, dy = dy > zero ? dy : zero, dz = dz > zero ? dz : zero;
  return dx * dx + (dy * dy + dz * dz);
}

// closestSquaredDistance's leaf test on the leaf's triangles at once, with the same arithmetic
// lane by lane (so the same distances): a triangle no nearer than its plane is dropped, then
// collision::closestOnTriangle, its regions selected instead of branched to. The first triangle,
// in order, of the least distance below `best` is taken.
[[gnu::always_inline]] inline void testLeaf(const WideLeaf& l, P3 p, float& best, P3* closest, int* triangle) {
  const Lanes abx = l.bx - l.ax, aby = l.by - l.ay, abz = l.bz - l.az;
  const Lanes acx = l.cx - l.ax, acy = l.cy - l.ay, acz = l.cz - l.az;
  const Lanes apx = p.x - l.ax, apy = p.y - l.ay, apz = p.z - l.az;
  const Lanes nx = aby * acz - abz * acy, ny = abz * acx - abx * acz, nz = abx * acy - aby * acx;
  const Lanes height = nx * apx + (ny * apy + nz * apz), normal2 = nx * nx + (ny * ny + nz * nz);
  const Lanes zero = {};
  const auto used = Lanes{0.0f, 1.0f, 2.0f, 3.0f} < float(l.count);
  const auto open = used & ((normal2 > zero) ? (height * height < best * normal2) : (normal2 == normal2));
  if ((open[0] | open[1] | open[2] | open[3]) == 0) return;
  // collision::closestOnTriangle, every region's point, the first region that holds taken.
  const Lanes d1 = abx * apx + (aby * apy + abz * apz), d2 = acx * apx + (acy * apy + acz * apz);
  const Lanes bpx = p.x - l.bx, bpy = p.y - l.by, bpz = p.z - l.bz;
  const Lanes d3 = abx * bpx + (aby * bpy + abz * bpz), d4 = acx * bpx + (acy * bpy + acz * bpz);
  const Lanes vc = d1 * d4 - d3 * d2;
  const Lanes cpx = p.x - l.cx, cpy = p.y - l.cy, cpz = p.z - l.cz;
  const Lanes d5 = abx * cpx + (aby * cpy + abz * cpz), d6 = acx * cpx + (acy * cpy + acz * cpz);
  const Lanes vb = d5 * d2 - d1 * d6;
  const Lanes va = d3 * d6 - d5 * d4;
  const Lanes denom = 1.0f / (va + vb + vc);
  Lanes qx = l.ax + (abx * (vb * denom) + acx * (vc * denom));
  Lanes qy = l.ay + (aby * (vb * denom) + acy * (vc * denom));
  Lanes qz = l.az + (abz * (vb * denom) + acz * (vc * denom));
  const Lanes e43 = d4 - d3, e56 = d5 - d6;
  const auto inBC = (va <= zero) & (e43 >= zero) & (e56 >= zero);
  const Lanes tBC = e43 / (e43 + e56);
  qx = inBC ? l.bx + (l.cx - l.bx) * tBC : qx;
  qy = inBC ? l.by + (l.cy - l.by) * tBC : qy;
  qz = inBC ? l.bz + (l.cz - l.bz) * tBC : qz;
  const auto inAC = (vb <= zero) & (d2 >= zero) & (d6 <= zero);
  const Lanes tAC = d2 / (d2 - d6);
  qx = inAC ? l.ax + acx * tAC : qx, qy = inAC ? l.ay + acy * tAC : qy, qz = inAC ? l.az + acz * tAC : qz;
  const auto inC = (d6 >= zero) & (d5 <= d6);
  qx = inC ? l.cx : qx, qy = inC ? l.cy : qy, qz = inC ? l.cz : qz;
  const auto inAB = (vc <= zero) & (d1 >= zero) & (d3 <= zero);
  const Lanes tAB = d1 / (d1 - d3);
  qx = inAB ? l.ax + abx * tAB : qx, qy = inAB ? l.ay + aby * tAB : qy, qz = inAB ? l.az + abz * tAB : qz;
  const auto inB = (d3 >= zero) & (d4 <= d3);
  qx = inB ? l.bx : qx, qy = inB ? l.by : qy, qz = inB ? l.bz : qz;
  const auto inA = (d1 <= zero) & (d2 <= zero);
  qx = inA ? l.ax : qx, qy = inA ? l.ay : qy, qz = inA ? l.az : qz;
  const Lanes dx = p.x - qx, dy = p.y - qy, dz = p.z - qz;
  const Lanes dist2 = dx * dx + (dy * dy + dz * dz);
  for (int k = 0; k < kWideChildren; ++k)
    if (open[k] && dist2[k] < best) {
      best = dist2[k];
      if (closest) *closest = {qx[k], qy[k], qz[k]};
      if (triangle) *triangle = l.first + k;
    }
}

// closestSquaredDistance over the wide nodes from `wideRoot` (nearer children first): the squared
// distance from p to the closest point of the mesh, or maxD2 when it is farther; `closest` and
// `triangle` as there. The walk itself, inlined into closestSquaredDistance (below).
[[gnu::always_inline]] inline float walk(const WideView& v, int wideRoot, P3 p, float maxD2, P3* closest, int* triangle) {
  float best = maxD2;
  int stack[kWideStackDepth];
  float near[kWideStackDepth];
  int top = 0;
  stack[top] = wideRoot, near[top++] = 0.0f;
  while (top > 0) {
    --top;
    if (near[top] >= best) continue;
    const int code = stack[top];
    if (code < 0) {
      testLeaf(v.leaves[-1 - code], p, best, closest, triangle);
      continue;
    }
    const WideNode& n = v.nodes[code];
    const Lanes d = childDistances(n, p);
    // The open children, sorted far to near, pushed so that the nearest is walked first.
    int open[kWideChildren];
    int count = 0;
    for (int k = 0; k < kWideChildren; ++k) {
      if (!(d[k] < best)) continue;
      int i = count++;
      for (; i > 0 && d[open[i - 1]] < d[k]; --i) open[i] = open[i - 1];
      open[i] = k;
    }
    if (top + count > kWideStackDepth) continue;  // unreachable for TriangleBvh::build's trees; never overrun
    for (int i = 0; i < count; ++i) stack[top] = n.child[open[i]], near[top++] = d[open[i]];
  }
  return best;
}

// `walk`, compiled once in surface_distance.cpp. (An AVX2 clone beside it, chosen at load time, left
// the searches as fast and made the start's exact evaluation on the 2-core Xeon 0.107 -> 0.168 s:
// docs/benchmarks.md.)
float closestSquaredDistance(const WideView& v, int wideRoot, P3 p, float maxD2, P3* closest = nullptr,
                             int* triangle = nullptr);

// closestSquaredDistance bounded from the start by the distance to triangle `hint` (when >= 0: one
// under the root), so that it only looks for nearer ones; `hint` becomes the nearest triangle. The
// distance is the same as without the hint; the walk is shorter when the hint is near (the sampled
// error's searches from points that moved little: 8 % of its time on the demo when it came).
inline float closestSquaredDistanceFrom(const WideView& v, int wideRoot, P3 p, int& hint) {
  P3 q;
  const float bound = hint >= 0 ? squaredDistanceToTriangle(v.corners, hint, p, q) : 3.0e38f;
  int nearest = -1;
  const float d2 = closestSquaredDistance(v, wideRoot, p, bound, nullptr, &nearest);
  if (nearest >= 0) hint = nearest;
  return d2;
}

}  // namespace sinew::trianglebvh
