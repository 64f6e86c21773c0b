// Collision detection between structures (the issue on collisions; paper 001 section 2.1, paper
// 002's two stages), shared by the CPU force and the CUDA kernels: this header's inline functions
// compile for both, so the backends find the same contacts.
//
// Two stages. The hierarchy's leaves are groups of at most four vertices close in space (median
// splits down to four): at a refined level about the four children of one coarser vertex, so the
// leaves are a coarse proxy (001 2.1) and the tree above them a hierarchy over it. A leaf holds its
// vertices' triangles of the paper-000 Fig. 1b tessellation (three per vertex: vertex, its
// successor in the cell, the cell centre), so the fine test is exact on the surface the outputs are made of. The tree is built once
// per level on the host (median splits) and refitted every step (bottom up; on the device by the
// last child to arrive), never rebuilt.
#pragma once

#include <cmath>

#if defined(__CUDACC__)
#define SINEW_HD __host__ __device__ __forceinline__
#else
#define SINEW_HD inline
#endif

namespace sinew::collision {

constexpr int kLeafVertices = 4;
constexpr int kStackDepth = 64;  // a median-split tree over 2^31 leaves is 32 deep

struct P3 {  // the layout of Vec3 and float3
  float x, y, z;
};
struct Box {
  P3 lo, hi;
};
// Leaves have left == -1 and hold the vertices order[first .. first + count); an inner node's
// range is all its subtree's vertices.
struct Node {
  int left, right, parent, first, count;
};
// A tessellation triangle: vertex a, its successor b in the cell, the cell (whose centre is the
// third corner). Vertex v's three are tris[3 v .. 3 v + 2].
struct Tri {
  int a, b, cell;
};

// All structures' trees in one array; roots[m] is structure m's. Host or device pointers.
struct BvhView {
  const Node* nodes = nullptr;
  Box* boxes = nullptr;
  const Tri* tris = nullptr;
  const int* order = nullptr;  // vertices, leaf by leaf
  const int* roots = nullptr;
  const unsigned char* exempt = nullptr;  // meshes x meshes: 1 where a pair is left out; may be null
  int meshes = 0;
  int nodeCount = 0;
  const float* share = nullptr;  // meshes x meshes: the share of a contact's correction (shareOf); null: all
  // Per vertex: its depth (contactResponse) as the full search began, for shareAt; null with no
  // share table. A copy: the search writes the depths it reads here.
  const float* lastDepth = nullptr;
  // With the reaction (ContactSettings::reaction) the other side is pushed back by what a vertex
  // does not take: shareAt then keeps only its rule for one-sided contacts.
  bool reacts = false;
};

// The share of a contact's correction that a vertex of `own` takes against `other`
// (CollisionTree::setShares: the larger structure gives way more); 1 without a table.
SINEW_HD float shareOf(const BvhView& v, int own, int other) { return v.share ? v.share[own * v.meshes + other] : 1.0f; }

SINEW_HD P3 sub(P3 a, P3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
SINEW_HD P3 add(P3 a, P3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
SINEW_HD P3 scale(P3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
SINEW_HD float dot3(P3 a, P3 b) { return a.x * b.x + (a.y * b.y + a.z * b.z); }
SINEW_HD P3 cross3(P3 a, P3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
SINEW_HD float fmin3(float a, float b) { return a < b ? a : b; }
SINEW_HD float fmax3(float a, float b) { return a > b ? a : b; }
// The share of a contact on triangle `tri` (BvhView::tris) of `other`, `side` the vertex's side of
// it: shareOf, or more where that triangle's two vertices will not give way enough. They were
// `lastDepth` below the margin as the search began (against whatever they touched).
// - Where both touched nothing, all of it (inside or within the margin): the other surface passes
//   through this structure between its vertices, which feel nothing and do not move.
// - Otherwise, where this vertex is inside: the pair parts by this vertex's share of its depth
//   inside plus the other side's share of theirs, so it takes at least 1 - (their mean depth
//   inside, times their share) / its depth inside; all of it where they were only within the margin.
// - Within the margin but outside: its share by size.
// With its share by size alone a vertex came to rest inside: mixed right 6109, 30 of Amygdala_R's
// vertices up to 0.86 mm inside ParaHippocampal_R, whose vertices there touched nothing; and on the
// mixed right subjects 2.3-3.0 mm^3 of overlap was left where they touched, less deep
// (docs/collisions.md, "One-sided contacts" and "Where the other side gives way less").
// With the reaction (v.reacts) the other side gives way where it touched: the first rule only
// (docs/collisions.md, "The reaction").
SINEW_HD float shareAt(const BvhView& v, int own, int other, int tri, float side, float margin) {
  const float s = shareOf(v, own, other);
  if (!(s < 1.0f) || !v.lastDepth || tri < 0) return s;
  const Tri t = v.tris[tri];
  const float a = v.lastDepth[t.a], b = v.lastDepth[t.b];
  if (a == 0.0f && b == 0.0f) return 1.0f;
  if (v.reacts) return s;
  const float mine = -side;
  if (!(mine > 0.0f)) return s;
  const float theirs = fmax3(0.5f * (a + b) - margin, 0.0f) * shareOf(v, other, own);
  return fmin3(fmax3(s, 1.0f - theirs / mine), 1.0f);
}

SINEW_HD Box emptyBox() { return {{3.0e38f, 3.0e38f, 3.0e38f}, {-3.0e38f, -3.0e38f, -3.0e38f}}; }
SINEW_HD void extend(Box& b, P3 p) {
  b.lo = {fmin3(b.lo.x, p.x), fmin3(b.lo.y, p.y), fmin3(b.lo.z, p.z)};
  b.hi = {fmax3(b.hi.x, p.x), fmax3(b.hi.y, p.y), fmax3(b.hi.z, p.z)};
}
// The union of two boxes, either of which may be empty (extending by b's corners would make an
// empty b's corners, +-3e38, the union's).
SINEW_HD Box merge(const Box& a, const Box& b) {
  return {{fmin3(a.lo.x, b.lo.x), fmin3(a.lo.y, b.lo.y), fmin3(a.lo.z, b.lo.z)},
          {fmax3(a.hi.x, b.hi.x), fmax3(a.hi.y, b.hi.y), fmax3(a.hi.z, b.hi.z)}};
}
// max(m, 0). On the host as (m + |m|) / 2, the same value without a branch: GCC turns max(m, 0)
// followed by squaring into a jump per axis, which mispredicts in half the box tests of a search.
SINEW_HD float positivePart(float m) {
#ifdef __CUDA_ARCH__
  return fmax3(m, 0.0f);
#else
  return (m + std::fabs(m)) * 0.5f;
#endif
}
SINEW_HD float squaredDistance(const Box& b, P3 p) {
  const float dx = positivePart(fmax3(b.lo.x - p.x, p.x - b.hi.x));
  const float dy = positivePart(fmax3(b.lo.y - p.y, p.y - b.hi.y));
  const float dz = positivePart(fmax3(b.lo.z - p.z, p.z - b.hi.z));
  return dx * dx + (dy * dy + dz * dz);
}

// The box of the vertex at tree position i (order[i]): its three triangles' corners (the vertex,
// its successors, the cell centres). A node's box is the union of its vertices' (a node's vertices
// are contiguous in tree order).
SINEW_HD Box vertexBox(const BvhView& v, int i, const P3* x, const P3* centres) {
  Box b = emptyBox();
  for (int k = 0; k < 3; ++k) {
    const Tri t = v.tris[3 * v.order[i] + k];
    extend(b, x[t.a]);
    extend(b, x[t.b]);
    extend(b, centres[t.cell]);
  }
  return b;
}
SINEW_HD Box leafBox(const BvhView& v, const Node& n, const P3* x, const P3* centres) {
  Box b = emptyBox();
  for (int i = n.first; i < n.first + n.count; ++i) b = merge(b, vertexBox(v, i, x, centres));
  return b;
}

// Closest point on triangle (Ericson, Real-Time Collision Detection, 5.1.5).
SINEW_HD P3 closestOnTriangle(P3 p, P3 a, P3 b, P3 c) {
  const P3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const float d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const P3 bp = sub(p, b);
  const float d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return add(a, scale(ab, d1 / (d1 - d3)));
  const P3 cp = sub(p, c);
  const float d5 = dot3(ab, cp), d6 = dot3(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return add(a, scale(ac, d2 / (d2 - d6)));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return add(b, scale(sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
  const float denom = 1.0f / (va + vb + vc);
  return add(a, add(scale(ab, vb * denom), scale(ac, vc * denom)));
}

struct Hit {
  float d2;       // squared distance to the closest point
  P3 point;       // the closest point
  P3 normal;      // its triangle's outward unit normal
  float side;     // (p - point) . normal: negative inside
  int leaf;       // the leaf node of its triangle
  int tri = -1;   // its triangle (BvhView::tris)
};

SINEW_HD P3 unitNormal(P3 a, P3 b, P3 c) {
  const P3 n = cross3(sub(b, a), sub(c, a));
  const float len2 = dot3(n, n);
  return len2 > 0.0f ? scale(n, 1.0f / sqrtf(len2)) : P3{0, 0, 0};
}

// Squared distances this close to the best count as the same point (an edge or corner shared by
// several triangles, computed from each).
SINEW_HD float tieBound(float d2) { return d2 * (1.0f + 1e-4f) + 1e-12f; }

// Whether a triangle whose closest point to p is d2 away, on the side `side` of its plane,
// replaces the best so far, taking the triangles one after another. Where the closest point is
// shared by several triangles (an edge or a corner), the triangle facing p most squarely gives the
// side: one face's normal alone can put a point outside a sharp edge inside. Only triangles within
// tieBound(best.d2) can replace it.
SINEW_HD bool replacesBest(const Hit& best, bool found, float d2, float side) {
  const bool better = found ? d2 < best.d2 * (1.0f - 1e-4f) : d2 < best.d2;
  const bool tie = found && !better && d2 <= tieBound(best.d2);
  return better || (tie && fabsf(side) > fabsf(best.side));
}

// A node's triangles (a leaf's; under an inner node, all its vertices') against the best so far.
SINEW_HD void testLeaf(const BvhView& v, int id, P3 p, const P3* x, const P3* centres, Hit& best, bool& found) {
  const Node n = v.nodes[id];
  for (int i = n.first; i < n.first + n.count; ++i)
    for (int k = 0; k < 3; ++k) {
      const Tri t = v.tris[3 * v.order[i] + k];
      const P3 a = x[t.a], b = x[t.b], c = centres[t.cell];
      const P3 q = closestOnTriangle(p, a, b, c);
      const P3 d = sub(p, q);
      const float d2 = dot3(d, d);
      if (d2 > tieBound(best.d2)) continue;  // cheaper than the normal
      const P3 normal = unitNormal(a, b, c);
      const float side = dot3(d, normal);
      if (!replacesBest(best, found, d2, side)) continue;
      best = {d2, q, normal, side, id, 3 * v.order[i] + k};
      found = true;
    }
}

// The closest point on structure `mesh`'s tessellation to p within sqrt(maxD2) (branch and bound,
// nearer child first); d2 stays maxD2 when there is none. `hint`: a leaf found near p before (the
// last step's), tested first so that the bound is tight from the start; any other value is ignored.
SINEW_HD Hit closestPoint(const BvhView& v, int mesh, P3 p, const P3* x, const P3* centres, float maxD2, int hint = -1) {
  Hit best{maxD2, p, {0, 0, 0}, 0.0f, -1};
  bool found = false;
  const int end = mesh + 1 < v.meshes ? v.roots[mesh + 1] : v.nodeCount;  // the structure's nodes
  if (hint >= v.roots[mesh] && hint < end && v.nodes[hint].left < 0) testLeaf(v, hint, p, x, centres, best, found);
  // Each entry keeps its box's distance, computed when its parent was opened: no box is read twice.
  struct Entry {
    int id;
    float d2;
  };
  Entry stack[kStackDepth];
  int top = 0;
  stack[top++] = {v.roots[mesh], squaredDistance(v.boxes[v.roots[mesh]], p)};
  while (top > 0) {
    const Entry e = stack[--top];
    const float bound = found ? tieBound(best.d2) : best.d2;
    if (e.d2 > bound) continue;
    const Node n = v.nodes[e.id];
    if (n.left < 0) {
      if (e.id != hint) testLeaf(v, e.id, p, x, centres, best, found);
      continue;
    }
    const float dl = squaredDistance(v.boxes[n.left], p), dr = squaredDistance(v.boxes[n.right], p);
    const Entry nearer = dl < dr ? Entry{n.left, dl} : Entry{n.right, dr};
    const Entry farther = dl < dr ? Entry{n.right, dr} : Entry{n.left, dl};
    if (top + 2 > kStackDepth) continue;  // unreachable for median-split trees; never overrun
    if (farther.d2 <= bound) stack[top++] = farther;
    if (nearer.d2 <= bound) stack[top++] = nearer;
  }
  return best;
}

// Marks a vertex whose contacts are not known yet (the first step of a level): its search is
// unbounded, so that deep penetrations are seen.
constexpr float kUnknownDepth = 1.0e30f;

// The collision force's settings that shape the response (its parameters, docs/collisions.md).
struct ContactSettings {
  float margin = 0.0f;   // distance kept from the other surface
  float damping = 0.0f;  // extra damping of a touching vertex's own motion
  float reach = 0.0f;    // how far beyond its last penetration a full search looks
  float retreat = 0.0f;  // a vertex past another structure's middle is pushed back as if pulled this far
  float hold = -1.0f;    // how far outside its contact's plane a pulled vertex is held after the step; < 0: no hold
  float ahead = 3.0e38f; // how far past twice its own last step a full search looks for what comes before the next
  float holdStep = 3.0e38f;  // the most the hold moves a vertex in one step, in its spacings (respondTo)
  float reaction = 0.0f;     // the gain of the other surface's push back (reactionPush); 0: none
};

// The pull of one contact found by the search (h within the search radius) into force, deepest
// and the returned stiffness: when the vertex is inside or closer than the margin.
// A contact whose surface faces the way the vertex's own does (normals at less than 90 degrees) is
// taken for the other structure's far side: the vertex has gone past that structure's middle, and
// the pull to the nearest point would push it on through, dragging its surface along (demo seed 6:
// Caudate_L/Putamen_L went from 136 to 941 mm^3 of overlap over the last two levels). Such a vertex
// is instead pushed back into its own structure, as the pull would push it toward a point its depth
// behind it, at most `retreat`; outside, it is left alone. The push is constant in the position (no
// stiffness). Between a contact facing the vertex and one at kFacingBlend (cosine) the same way,
// the pull gives way to the push gradually: a switch at 90 degrees made the result jump with the
// last bits of a normal (CPU and CUDA 0.25 mm apart after 20 implicit Euler steps). (The angle also
// passes next to where two surfaces cross at more than 90 degrees; there too the push takes over.)
constexpr float kFacingBlend = 0.25f;
// The plane a touching vertex is held out of after the step (the collision force's hold): of the
// contacts that pull it, the one it is deepest in, moved `hold` outside along its normal. `weight`
// is the pull's share (1 - passed, below): a contact turning past 90 degrees gives way to the
// retreat gradually in the hold too, so that no last bit of a normal switches a jump on or off.
// `share` (shareOf) scales the pull, the retreat and the hold's weight: the vertex takes that part of
// the correction, the other structure the rest.
struct HoldPlane {
  P3 normal{0, 0, 0};
  float offset = 0.0f;   // x is held to dot(normal, x) >= offset
  float side = 3.0e38f;  // the vertex's side of the contact when found; 3e38: no plane
  float weight = 0.0f;   // the share of the way back to the plane that the hold moves x
};
// 24 bytes: the limit a step (holdLimit) is not stored with the plane but computed where the hold is
// applied. Stored, it made every vertex's plane 28 bytes, set or not, and the 100 AAL regions' step
// with collisions 13 us longer (docs/benchmarks.md, "The 100 regions' 1.83").
SINEW_HD float respondTo(const Hit& h, P3 p, P3 previous, P3 ownNormal, float alpha, const ContactSettings& s,
                         float& deepest, P3& force, HoldPlane* hold = nullptr, float share = 1.0f) {
  if (h.side >= s.margin) return 0.0f;
  deepest = fmax3(deepest, s.margin - h.side);
  const float passed = fmin3(fmax3(dot3(h.normal, ownNormal) / kFacingBlend, 0.0f), 1.0f);
  alpha *= share;  // the pull, the retreat and (below) the hold alike
  const float pull = alpha * (1.0f - passed);
  if (hold && pull > 0.0f && h.side < hold->side)
    *hold = {h.normal, dot3(h.normal, h.point) + s.hold, h.side, share * (1.0f - passed)};
  if (pull > 0.0f) {
    const P3 target = add(h.point, scale(h.normal, s.margin));
    force = add(force, sub(scale(sub(target, p), pull), scale(sub(p, previous), pull * s.damping)));
  }
  if (passed > 0.0f && h.side < 0.0f) force = add(force, scale(ownNormal, -alpha * passed * fmin3(s.retreat, -h.side)));
  return pull;
}

// How far the hold may move vertex i in one step: ContactSettings::holdStep times its spacing on its
// own surface (the square root of its area, the same within a step wherever the hold is applied).
// The area is read only when there is a limit.
SINEW_HD float holdLimit(const ContactSettings& s, const float* area, long i) {
  return s.holdStep < 3.0e38f ? s.holdStep * sqrtf(area[i]) : 3.0e38f;
}

// The hold itself: x moves out along the plane's normal onto it (the weight's share of the way, of
// at most `limit`, holdLimit's, a step).
// The previous position moves by as much, less the step's motion into the plane (the normal part
// of x - previous, when negative), in the same share: the hold takes the motion inward out of the
// velocity and adds none outward (the new normal velocity is max(v.n, 0) at weight 1). With the
// previous position left where it was, a vertex moved out of a deep contact at once kept that jump
// as velocity, and a small sphere half inside another trembled by 0.1 mm a step.
SINEW_HD void holdOut(const HoldPlane& h, P3& x, P3& previous, float limit = 3.0e38f) {
  if (!(h.side < 3.0e38f)) return;
  const float gap = h.offset - dot3(h.normal, x);
  if (!(gap > 0.0f)) return;
  const float below = fmin3(gap, limit);
  const float inward = fmin3(dot3(h.normal, sub(x, previous)), 0.0f);
  x = add(x, scale(h.normal, h.weight * below));
  previous = add(previous, scale(h.normal, h.weight * (below + inward)));
}

// The full search's squared radius. Twice the vertex's own last step stands for how far it and the
// other surface may close in by the next step: pushes of tenths of a millimetre a step would outrun
// a fixed reach. With full searches every few steps, twice that step again for each further step
// until the next one, but at most s.ahead more: the few trembling light vertices, whose steps are
// the longest, had radii of several millimetres, and the walks of the warps holding them set the
// search's time (docs/collisions.md, "A bounded look ahead"). Unbounded while the depth is unknown.
SINEW_HD float fullSearchBound(float depth, const ContactSettings& s, int every, P3 p, P3 previous) {
  if (depth >= kUnknownDepth) return 3.0e38f;
  const P3 moved = sub(p, previous);
  const float step = 2.0f * sqrtf(dot3(moved, moved));
  const float radius = depth + s.margin + s.reach + step + fmin3(float(every - 1) * step, s.ahead);
  return radius * radius;
}

// One other structure in the full search: whether its box (grown by the margin) holds p and its
// surface lies within sqrt(maxD2); h is then the closest point. clearance2 is lowered to what the
// search learnt of that surface's distance from p (squared): the box's distance where the box test
// left it out, else the nearest point found or, with none, the search radius.
SINEW_HD bool contactWith(const BvhView& v, int own, int other, P3 p, float margin, float maxD2, int hint, const P3* x,
                          const P3* centres, Hit& h, float& clearance2) {
  if (other == own || (v.exempt && v.exempt[own * v.meshes + other])) return false;
  const float box2 = squaredDistance(v.boxes[v.roots[other]], p);
  if (box2 > margin * margin) {  // outside the box grown by the margin
    clearance2 = fmin3(clearance2, box2);
    return false;
  }
  h = closestPoint(v, other, p, x, centres, maxD2, hint);
  clearance2 = fmin3(clearance2, h.d2);  // maxD2 where nothing was nearer
  return h.d2 < maxD2;
}

// The contact a full search found deepest (the least side, touching or not, within its radius),
// kept until the next full search: its normal then, and its point as a point of the other
// surface's triangle (barycentric weights u, w of its corners a, b; the cell centre takes the
// rest), so that it moves with that surface. Between full searches the vertex meets the plane
// through that point now, along the normal found (contactHit), not the surface. share < 0: none.
// The triangle's corners are kept, not its index: between full searches each touching vertex then
// reads the plane and the corners' positions, a round trip fewer than through the triangles.
struct ContactPlane {
  P3 normal{0, 0, 0};
  Tri corners{-1, -1, -1};
  float u = 0.0f, w = 0.0f;
  float share = -1.0f;  // shareOf the two structures
};
SINEW_HD ContactPlane contactOn(const BvhView& v, const Hit& h, float share, const P3* x, const P3* centres) {
  const Tri t = v.tris[h.tri];
  const P3 a = x[t.a], b = x[t.b], c = centres[t.cell];
  // Barycentric weights of h.point (on the triangle) by Cramer's rule on the edges from c, held
  // to the triangle: a sliver's weights are ill-conditioned.
  const P3 e0 = sub(a, c), e1 = sub(b, c), d = sub(h.point, c);
  const float d00 = dot3(e0, e0), d01 = dot3(e0, e1), d11 = dot3(e1, e1), d20 = dot3(d, e0), d21 = dot3(d, e1);
  const float det = d00 * d11 - d01 * d01;
  float u = 1.0f / 3.0f, w = 1.0f / 3.0f;  // a degenerate triangle: its centroid
  if (det > 1e-12f * d00 * d11) {
    u = fmin3(fmax3((d11 * d20 - d01 * d21) / det, 0.0f), 1.0f);
    w = fmin3(fmax3((d00 * d21 - d01 * d20) / det, 0.0f), 1.0f - u);
  }
  return {h.normal, t, u, w, share};
}
// The contact's hit for a vertex now at p: the foot of p on the plane through the contact's point,
// where its triangle is now, along the normal found.
// (contactHitAt: the same with the triangle's corners a, b and cell centre c given.)
SINEW_HD Hit contactHitAt(const ContactPlane& k, P3 p, P3 a, P3 b, P3 c) {
  const P3 q = add(c, add(scale(sub(a, c), k.u), scale(sub(b, c), k.w)));
  const float side = dot3(k.normal, sub(p, q));
  return {side * side, sub(p, scale(k.normal, side)), k.normal, side, -1, -1};
}
SINEW_HD Hit contactHit(const ContactPlane& k, P3 p, const P3* x, const P3* centres) {
  return contactHitAt(k, p, x[k.corners.a], x[k.corners.b], centres[k.corners.cell]);
}

// The reaction: a vertex inside another structure that takes `share` < 1 of the correction back
// to the margin (shareOf) pushes that structure's surface the other way by the rest, times
// ContactSettings::reaction. Returns false where there is none: no plane, a share of all of it,
// the vertex outside, or the contact facing the way of the vertex's own normal (the retreat,
// respondTo). `push` is then what each vertex of the contact's triangle gets, per unit of its part
// (reactionPart) and of its weight times its mass: alpha m, as the vertex's own pull (summed per
// vertex over the pushes times part times weight, then times its mass). a, b, c: the contact
// triangle's corners and cell centre now (contactHitAt). Where the other side touched, the smaller
// structure took about an eighth of each correction by size, and took more where the other side
// gave way less (shareAt); this moves the other side instead (docs/collisions.md, "The reaction").
SINEW_HD bool reactionPush(const ContactPlane& k, P3 p, P3 ownNormal, const ContactSettings& s, P3 a, P3 b, P3 c,
                           P3& push) {
  if (!(s.reaction > 0.0f) || !(k.share >= 0.0f && k.share < 1.0f) || dot3(k.normal, ownNormal) > 0.0f) return false;
  const Hit h = contactHitAt(k, p, a, b, c);
  if (!(h.side < 0.0f)) return false;
  push = scale(sub(p, add(h.point, scale(k.normal, s.margin))), s.reaction * (1.0f - k.share));
  return true;
}
// The part of the push on the contact triangle's j-th vertex, j < 2 + cellSize (the cell's
// vertices after the two corners, each with an equal part of the cell centre's weight).
SINEW_HD float reactionPart(const ContactPlane& k, int j, int cellSize) {
  return j == 0 ? k.u : j == 1 ? k.w : (1.0f - k.u - k.w) / float(cellSize);
}
// That vertex: the two corners, then the cell's vertices (`cell`: the cell's list of them).
SINEW_HD int reactionPartner(const ContactPlane& k, int j, const int* cell) {
  return j == 0 ? k.corners.a : j == 1 ? k.corners.b : cell[j - 2];
}

// What the full search gathers over the structures, in structure order.
struct ContactSum {
  float deepest = 0.0f, stiffness = 0.0f, nearest = 3.0e38f, clearance2 = 3.0e38f;
  int nearestLeaf = -1;
  P3 force{0, 0, 0};
  Hit deepestHit{3.0e38f, {0, 0, 0}, {0, 0, 0}, 3.0e38f, -1};  // the least side (ContactPlane)
  float deepestShare = -1.0f;
};
SINEW_HD void addContact(const Hit& h, P3 p, P3 previous, P3 ownNormal, float alpha, const ContactSettings& s,
                         ContactSum& sum, HoldPlane* hold = nullptr, float share = 1.0f) {
  if (h.d2 < sum.nearest) sum.nearest = h.d2, sum.nearestLeaf = h.leaf;
  if (h.side < sum.deepestHit.side) sum.deepestHit = h, sum.deepestShare = share;
  sum.stiffness += respondTo(h, p, previous, ownNormal, alpha, s, sum.deepest, sum.force, hold, share);
}

// Clearance. A vertex that touched nothing at its last search knows how far every other surface
// was then (ContactSum::clearance2), less the margin: its slack. Every full search takes from it
// the vertex's own displacement since the last full search and `motion`, the largest displacement
// of any vertex since then (a point of the tessellation, a convex combination of vertices and cell
// centres, moves no farther). While slack is left, no surface can have come within the margin: the
// search is skipped, and its result would have been the same (no force, no penetration); the
// bound holds whatever moved the vertices. It pays for the largest move anywhere, so a few fast
// vertices shorten every vertex's slack: on the demo a quarter of the searches are skipped with a
// full search every step (docs/collisions.md).
constexpr float kSlackGuard = 1e-3f;  // mm kept back for rounding
SINEW_HD bool clearOfContacts(float depth, float ownMotion, float motion, float& slack) {
  slack -= ownMotion + motion;
  return depth == 0.0f && slack > 0.0f;
}
SINEW_HD float slackAfterSearch(float depth, float clearance2, float margin) {
  return depth > 0.0f ? 0.0f : sqrtf(clearance2) - margin - kSlackGuard;
}

// The response at one vertex of structure `own`. For every other structure whose box (grown by the
// margin) holds the vertex: if the vertex is inside that structure or closer than the margin to it
// (by the side of the closest triangle), a pull to the point `margin` outside its surface, plus
// `damping` (0 by default) of the vertex's own motion while it touches; a vertex past the other
// structure's middle (its nearest surface facing the way of `ownNormal`) retreats instead
// (respondTo). `alpha` is the weight times the vertex's mass, so every vertex moves alike: under
// the weight alone a light vertex overshot.
// Adds to `force`; returns the summed pull stiffness (the implicit integrator's self block is
// minus that times I).
// A full search reaches `reach` plus twice the vertex's last step for each of the `every` steps
// until the next full search, beyond its last penetration `depth` (in/out: the deepest penetration
// below the margin found now, 0 without contact): a bounded search is what keeps the narrow phase
// cheap. `hint` (in/out): the leaf of the vertex's nearest contact, where the search starts.
// Between full searches (`full` false) the vertex meets only the plane of the deepest contact the
// last full search found (`plane`, in/out: written by each full search), moved with the other
// surface: no traversal, and the boxes need no refit. Measured against testing the patch of
// triangles around the last contact's leaf (the code until 2026-11-29) on the CPU, 18 new subjects
// and demo seeds 1-8, full searches every 8 steps (docs/collisions.md). The first step of a level
// (depth kUnknownDepth) is always a full search, without bound. `ownMotion`, `motion`, `slack`
// (in/out): the clearance above, paid at full searches (the displacements since the last one); a
// vertex still clear of every other structure returns at once and keeps no plane. `hold` (may be
// null): the plane the contacts hold the vertex out of (HoldPlane).
SINEW_HD float contactResponse(const BvhView& v, int own, P3 p, P3 previous, P3 ownNormal, float alpha,
                               const ContactSettings& s, bool full, int every, float ownMotion, float motion,
                               float& depth, int& hint, float& slack, ContactPlane& plane, const P3* x,
                               const P3* centres, P3& force, HoldPlane* hold = nullptr) {
  if (!full && depth < kUnknownDepth) {
    float deepest = 0.0f, stiffness = 0.0f;
    if (plane.share >= 0.0f)
      stiffness = respondTo(contactHit(plane, p, x, centres), p, previous, ownNormal, alpha, s, deepest, force, hold,
                            plane.share);
    depth = deepest;
    return stiffness;
  }
  if (clearOfContacts(depth, ownMotion, motion, slack)) {
    plane.share = -1.0f;
    return 0.0f;
  }
  ContactSum sum;
  sum.force = force;
  const float maxD2 = fullSearchBound(depth, s, every, p, previous);
  for (int other = 0; other < v.meshes; ++other) {
    Hit h{};
    if (contactWith(v, own, other, p, s.margin, maxD2, hint, x, centres, h, sum.clearance2))
      addContact(h, p, previous, ownNormal, alpha, s, sum, hold, shareAt(v, own, other, h.tri, h.side, s.margin));
  }
  depth = sum.deepest;
  hint = sum.nearestLeaf;
  slack = slackAfterSearch(depth, sum.clearance2, s.margin);
  plane = sum.deepestShare >= 0.0f ? contactOn(v, sum.deepestHit, sum.deepestShare, x, centres) : ContactPlane{};
  force = sum.force;
  return sum.stiffness;
}

}  // namespace sinew::collision
