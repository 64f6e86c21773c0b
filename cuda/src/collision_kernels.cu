// Collision detection and response on the device (core/collision_bvh.h holds the code the CPU
// force runs too): the hierarchies refitted (bottom up in large scenes; in smaller ones every
// node's box at once from its vertices'), then 1-16 threads per vertex finding its contacts.
#include "contact_planes.h"
#include "cuda_check.h"
#include "device_math.cuh"
#include "mesh_geometry.cuh"

#include "sinew/core/collision_bvh.h"

#include <algorithm>

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 128;
using namespace sinew::collision;

// Each vertex's move since the last full search, and the largest into motion (each full search:
// the clearance pays for it; collision::clearOfContacts). Grid-stride by vertex index (coalesced);
// one atomic per block (one per warp of a thread per vertex on the one address cost the climb 16 us
// at 325,632 vertices). Every thread of the block calls it. It also copies each vertex's depth as
// the search begins (lastDepth, null: none; collision::shareAt): a copy of its own cost 1.7 us a
// step at 20,352 vertices with a full search every step, 11.5 at 81,408 (H200).
__device__ void trackMotion(int vertices, const P3* x, float3* last, float* moved, unsigned* motion,
                            const float* depth, float* lastDepth) {
  __shared__ float warpLargest[kThreads / 32];
  float largest = 0.0f;
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < vertices; i += gridDim.x * blockDim.x) {
    if (lastDepth) lastDepth[i] = depth[i];
    const float3 now = make_float3(x[i].x, x[i].y, x[i].z);
    const float3 d = now - last[i];
    moved[i] = sqrtf(dot(d, d));
    last[i] = now;
    largest = fmaxf(largest, moved[i]);
  }
  for (int o = 16; o > 0; o /= 2) largest = fmaxf(largest, __shfl_xor_sync(0xffffffffu, largest, o));
  if (threadIdx.x % 32 == 0) warpLargest[threadIdx.x / 32] = largest;
  __syncthreads();
  if (threadIdx.x == 0) {
    for (int w = 1; w < int(blockDim.x / 32); ++w) largest = fmaxf(largest, warpLargest[w]);
    atomicMax(motion, __float_as_uint(largest));  // non-negative floats order as their bits
  }
}

// A box another block wrote this launch: read past L1 (not coherent between SMs).
__device__ Box coherentBox(const Box* boxes, int id) {
  const float* f = reinterpret_cast<const float*>(boxes + id);
  return {{__ldcg(f), __ldcg(f + 1), __ldcg(f + 2)}, {__ldcg(f + 3), __ldcg(f + 4), __ldcg(f + 5)}};
}

// The refit of large scenes (CollisionDevice::climb), launched on the steps of a full search only
// (the only ones to read the boxes): the motion, then the leaves' boxes
// and up the tree, the last child to arrive at a node merging both. (One block per structure
// merging its inner nodes height by height took longer: 19.6 against 32 us for the whole climb at
// 20,352 vertices, 120 against about 70 us at 325,632.)
__global__ void climbRefit(BvhView v, const int* leaves, int leafCount, int* visits, const P3* x, const P3* centres,
                           int vertices, float3* last, float* moved, unsigned* motion, const float* depth,
                           float* lastDepth) {
  const int l = blockIdx.x * blockDim.x + threadIdx.x;
  trackMotion(vertices, x, last, moved, motion, depth, lastDepth);
  if (l >= leafCount) return;
  int id = leaves[l];
  v.boxes[id] = leafBox(v, v.nodes[id], x, centres);
  // Up the tree: the first child to arrive stops, the second merges both (its sibling's box is
  // written and fenced before the counter moved), then resets the counter for the next refit.
  for (int parent = v.nodes[id].parent; parent >= 0; parent = v.nodes[parent].parent) {
    __threadfence();
    if (atomicAdd(&visits[parent], 1) == 0) return;
    const Node n = v.nodes[parent];
    v.boxes[parent] = merge(coherentBox(v.boxes, n.left), coherentBox(v.boxes, n.right));
    visits[parent] = 0;
  }
}

// The refit of smaller scenes, where the climb's chain of fenced atomics, one per level, set its
// time: the motion, then each vertex's box in tree order (thread i: vertex i's move, tree position
// i's box) ... Its cells' centres computed here, as the geometry kernel computes them (centreOf,
// the same values): so the refit does not wait for that kernel, and runs beside it.
__global__ void vertexBoxes(BvhView v, MeshView m, float3* last, float* moved, unsigned* motion, const float* depth,
                            float* lastDepth, Box* boxes) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const P3* x = reinterpret_cast<const P3*>(m.x);
  trackMotion(m.vertices, x, last, moved, motion, depth, lastDepth);
  if (i >= m.vertices) return;
  Box b = emptyBox();  // collision::vertexBox with the centres computed
  for (int k = 0; k < 3; ++k) {
    const Tri t = v.tris[3 * v.order[i] + k];
    const float3 c = centreOf(m, t.cell);
    extend(b, x[t.a]);
    extend(b, x[t.b]);
    extend(b, P3{c.x, c.y, c.z});
  }
  boxes[i] = b;
}

// ... then every node's box from its vertices' boxes, all nodes at once, none waiting for another:
// nodes of at most kThreadNode vertices (the leaves among them) a thread each, of at most kWarpNode
// a warp each, the larger ones (a structure's top few) a block each. Each vertex box is read once
// per level of the tree (L2-resident at these sizes), four loads in flight per lane. (Until
// 2026-11-26 the larger nodes were merged from their children height by height by the last block
// to finish: 12.6 us of nodeBoxes at 20,352 vertices; docs/benchmarks.md.)
constexpr unsigned kNodeThreads = 512;  // a larger node's block: a structure's root reads fewer boxes per thread
__device__ Box warpUnion(Box b) {
  for (int o = 16; o > 0; o /= 2) {
    const Box other{{__shfl_xor_sync(0xffffffffu, b.lo.x, o), __shfl_xor_sync(0xffffffffu, b.lo.y, o),
                     __shfl_xor_sync(0xffffffffu, b.lo.z, o)},
                    {__shfl_xor_sync(0xffffffffu, b.hi.x, o), __shfl_xor_sync(0xffffffffu, b.hi.y, o),
                     __shfl_xor_sync(0xffffffffu, b.hi.z, o)}};
    b = merge(b, other);
  }
  return b;
}
// The union of boxes[first + k * stride] for first + k * stride < end (empty where there is none).
__device__ Box unionStrided(const Box* boxes, int first, int end, int stride) {
  Box b[4] = {emptyBox(), emptyBox(), emptyBox(), emptyBox()};
  int j = first;
  for (; j + 3 * stride < end; j += 4 * stride) {
#pragma unroll
    for (int u = 0; u < 4; ++u) b[u] = merge(b[u], boxes[j + u * stride]);
  }
  for (; j < end; j += stride) b[0] = merge(b[0], boxes[j]);
  return merge(merge(b[0], b[1]), merge(b[2], b[3]));
}
__global__ void nodeBoxes(BvhView v, const Box* vertexBox, NodeLists lists) {
  const int threadBlocks = int((lists.threadCount + kNodeThreads - 1) / kNodeThreads);
  const int warpBlocks = int((lists.warpCount * 32 + kNodeThreads - 1) / kNodeThreads);
  const int block = int(blockIdx.x), thread = int(threadIdx.x);
  if (block < threadBlocks) {
    const int t = block * int(kNodeThreads) + thread;
    if (t >= lists.threadCount) return;
    const Node n = v.nodes[lists.threadNodes[t]];
    v.boxes[lists.threadNodes[t]] = unionStrided(vertexBox, n.first, n.first + n.count, 1);
  } else if (block < threadBlocks + warpBlocks) {
    const int w = ((block - threadBlocks) * int(kNodeThreads) + thread) / 32, lane = thread % 32;
    if (w >= lists.warpCount) return;  // the whole warp
    const Node n = v.nodes[lists.warpNodes[w]];
    const Box b = warpUnion(unionStrided(vertexBox, n.first + lane, n.first + n.count, 32));
    if (lane == 0) v.boxes[lists.warpNodes[w]] = b;
  } else {  // a block per larger node
    __shared__ Box warpBoxes[kNodeThreads / 32];
    const int id = lists.blockNodes[block - threadBlocks - warpBlocks];
    const Node n = v.nodes[id];
    const Box b = warpUnion(unionStrided(vertexBox, n.first + thread, n.first + n.count, int(kNodeThreads)));
    if (thread % 32 == 0) warpBoxes[thread / 32] = b;
    __syncthreads();
    if (thread == 0) {
      Box all = warpBoxes[0];
      for (int k = 1; k < int(kNodeThreads / 32); ++k) all = merge(all, warpBoxes[k]);
      v.boxes[id] = all;
    }
  }
}

// collision::closestPoint with the warp's lanes testing each leaf's triangles side by side.
// Nsight Compute at 20,352 vertices found the triangle tests to be most of respondGroup's
// instructions, each run by one lane of its warp (1-2 of 32 threads active in the walk). Every lane
// of the warp calls it; `walks`: whether this lane searches (the others only help test the leaves
// of those that do). Each lane's pops, bounds and triangle order are closestPoint's, and its best
// is updated by replacesBest in testLeaf's order, so the result is the same bit for bit.
__device__ P3 shuffle(P3 a, int src) {
  return {__shfl_sync(0xffffffffu, a.x, src), __shfl_sync(0xffffffffu, a.y, src), __shfl_sync(0xffffffffu, a.z, src)};
}
// One lane's triangle of a warp's leaf test: triangle k of node n (vertex k / 3's triangle k % 3)
// against q, testLeaf's arithmetic; `valid` false past the node's triangles.
struct LaneTriangle {
  bool valid = false;
  int tri = -1;
  float d2 = 0.0f, side = 0.0f;
  P3 at{0, 0, 0}, normal{0, 0, 0};
};
__device__ LaneTriangle laneTriangle(const BvhView& v, const Node& n, int k, P3 q, const P3* x, const P3* centres) {
  LaneTriangle r;
  if (k >= 3 * n.count) return r;
  r.tri = 3 * v.order[n.first + k / 3] + k % 3;
  const Tri t = v.tris[r.tri];
  const P3 a = x[t.a], b = x[t.b], c = centres[t.cell];
  r.valid = true;
  r.at = closestOnTriangle(q, a, b, c);
  const P3 d = sub(q, r.at);
  r.d2 = dot3(d, d);
  r.normal = unitNormal(a, b, c);
  r.side = dot3(d, r.normal);
  return r;
}
// Only triangles within the ties of the nearer of the round's nearest (over `width` lanes: the
// node's) and the owner's best so far can be the best once the round is done: one taken before the
// nearest is replaced by it (more than a tie nearer), one after it is not taken. Ties can raise the
// best a little (by at most 1e-4 of it) within a round: a looser filter. The owner then takes fewer
// candidates one by one (a first leaf offered all of its triangles: nothing was found yet).
// Lanes from `split` on belong to (ownerB, idB), the others to (ownerA, idA); each owner takes its
// own lanes' candidates in lane order, the triangles' order (replacesBest), so its best is
// testLeaf's to the bit. Every lane of the warp calls it.
template <int kWidth>
__device__ void offerCandidates(const LaneTriangle& t, float ownerBest, int split, int ownerA, int idA, int ownerB, int idB,
                                Hit& best, bool& found) {
  constexpr unsigned all = 0xffffffffu;
  const int lane = threadIdx.x % 32;
  float nearest = t.valid ? t.d2 : 3.0e38f;
  for (int o = kWidth / 2; o > 0; o /= 2) nearest = fminf(nearest, __shfl_xor_sync(all, nearest, o));
  const float within = 1.01f * tieBound(fminf(nearest, ownerBest)) + 1e-10f;
  for (unsigned c = __ballot_sync(all, t.valid && t.d2 <= within); c; c &= c - 1) {
    const int src = __ffs(c) - 1;
    const float cd2 = __shfl_sync(all, t.d2, src), cside = __shfl_sync(all, t.side, src);
    const P3 cat = shuffle(t.at, src), cnormal = shuffle(t.normal, src);
    const int ctri = __shfl_sync(all, t.tri, src);
    if (lane == (src >= split ? ownerB : ownerA) && replacesBest(best, found, cd2, cside)) {
      best = {cd2, cat, cnormal, cside, src >= split ? idB : idA, ctri};
      found = true;
    }
  }
}

// Two leaves at once (a leaf has at most kLeafVertices * 3 = 12 triangles): leaf idA of lane
// ownerA on lanes 0-15, leaf idB of lane ownerB (idB < 0: none) on lanes 16-31, each half on its
// leaf's triangles (triangle k of the leaf's vertex j on lane 3 j + k). The owners differ (a lane
// reaches one leaf at a time). A warp tested its lanes' leaves one after another with 12 of its 32
// lanes busy. Every lane of the warp calls it.
static_assert(3 * kLeafVertices <= 16, "a leaf's triangles fit in half a warp");
__device__ void testLeafPairWarp(const BvhView& v, int idA, int ownerA, int idB, int ownerB, P3 p, const P3* x,
                                 const P3* centres, Hit& best, bool& found) {
  const int lane = threadIdx.x % 32, half = lane >> 4;
  const int id = half ? idB : idA, owner = half ? ownerB : ownerA;
  const P3 q = shuffle(p, owner < 0 ? 0 : owner);
  const float ownerBest = __shfl_sync(0xffffffffu, best.d2, owner < 0 ? 0 : owner);
  LaneTriangle t;
  if (id >= 0) t = laneTriangle(v, v.nodes[id], lane & 15, q, x, centres);
  offerCandidates<16>(t, ownerBest, 16, ownerA, idA, ownerB, idB, best, found);
}
__device__ Hit closestPointWarp(const BvhView& v, int mesh, P3 p, const P3* x, const P3* centres, float maxD2, int hint,
                                bool walks) {
  constexpr unsigned all = 0xffffffffu;
  Hit best{maxD2, p, {0, 0, 0}, 0.0f, -1};
  bool found = false;
  struct Entry {
    int id;
    float d2;
  };
  Entry stack[kStackDepth];
  int top = 0, leaf = -1;  // leaf: reached by this lane, to be tested by the warp
  if (walks) {
    const int end = mesh + 1 < v.meshes ? v.roots[mesh + 1] : v.nodeCount;
    if (hint >= v.roots[mesh] && hint < end && v.nodes[hint].left < 0) leaf = hint;
    stack[top++] = {v.roots[mesh], squaredDistance(v.boxes[v.roots[mesh]], p)};
  }
  while (true) {
    // The leaves reached, two at a time (testLeafPairWarp).
    for (unsigned pending = __ballot_sync(all, leaf >= 0); pending;) {
      const int ownerA = __ffs(pending) - 1;
      pending &= pending - 1;
      const int ownerB = pending ? __ffs(pending) - 1 : -1;
      if (pending) pending &= pending - 1;
      const int idA = __shfl_sync(all, leaf, ownerA), idB = __shfl_sync(all, leaf, ownerB < 0 ? ownerA : ownerB);
      testLeafPairWarp(v, idA, ownerA, ownerB < 0 ? -1 : idB, ownerB, p, x, centres, best, found);
    }
    leaf = -1;
    if (!__any_sync(all, top > 0)) break;
    if (top > 0) {  // one node per searching lane
      const Entry e = stack[--top];
      const float bound = found ? tieBound(best.d2) : best.d2;
      if (e.d2 <= bound) {
        const Node n = v.nodes[e.id];
        if (n.left < 0) {
          if (e.id != hint) leaf = e.id;
        } else {
          const float dl = squaredDistance(v.boxes[n.left], p), dr = squaredDistance(v.boxes[n.right], p);
          const Entry nearer = dl < dr ? Entry{n.left, dl} : Entry{n.right, dr};
          const Entry farther = dl < dr ? Entry{n.right, dr} : Entry{n.left, dl};
          if (top + 2 <= kStackDepth) {
            if (farther.d2 <= bound) stack[top++] = farther;
            if (nearer.d2 <= bound) stack[top++] = nearer;
          }
        }
      }
    }
  }
  return best;
}

constexpr int kRespondBlocks = 6;  // respondGroup's blocks an SM with the warp's leaf tests (below)

// collision::contactWith for every lane of the warp at once (closestPointWarp).
__device__ bool contactWithWarp(const BvhView& v, int own, int other, P3 p, float margin, float maxD2, int hint,
                                const P3* x, const P3* centres, bool search, Hit& h, float& clearance2) {
  bool walks = search && other < v.meshes && other != own && !(v.exempt && v.exempt[own * v.meshes + other]);
  if (walks) {
    const float box2 = squaredDistance(v.boxes[v.roots[other]], p);
    if (box2 > margin * margin) {  // outside the box grown by the margin
      clearance2 = fmin3(clearance2, box2);
      walks = false;
    }
  }
  h = closestPointWarp(v, walks ? other : 0, p, x, centres, maxD2, hint, walks);
  if (!walks) return false;
  clearance2 = fmin3(clearance2, h.d2);  // maxD2 where nothing was nearer
  return h.d2 < maxD2;
}

// Between full searches (contact_planes.h), a thread a vertex; no clearance (it is paid at the
// full searches). The engine launches it instead of the refit and respondGroup on the branch,
// writing the collision's own force; where the collision is the step's last force after the
// profile, the profile's passes take the planes instead (launchProfileAfterTerms,
// launchProfileFirst). Done by respondGroup's lanes (16 a vertex below 32,768 vertices), such a
// step cost about 16 us more than one without collisions at 20,352 vertices (H200, from the steps
// with a full search every 8 and every 16); with the refit and respondGroup launched to return at
// once, about 9 us more.
__global__ void respondPlanes(MeshView m, ContactPlanes planes, float3* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= m.vertices) return;
  HoldPlane plane;
  out[i] = contactPlaneForce(m, planes, i, hasContactPlane(planes, i), plane,
                             planes.reaction ? reactionPushed(planes.reaction, i) : 0u);
}

// A touching vertex's reaction on its contact triangle (collision::reactionPush;
// CollisionForce::addReaction's arithmetic), into `sums` (ReactionSums). `normal` and `centre`: its
// own normal and the contact cell's centre as the geometry pass computes them. Its own structure
// is active (the caller checks); the contact triangle's vertices are of one structure: one weight.
__device__ void scatterReaction(const MeshView& m, ParamView p, const ContactSettings& settings, const ContactPlane& k,
                                P3 point, P3 normal, P3 centre, unsigned long long* sums) {
  const float alpha = param(p, m.meshOf[k.corners.a], 0);
  const P3* x = reinterpret_cast<const P3*>(m.x);
  P3 push;
  if (!(alpha > 0.0f) || !reactionPush(k, point, normal, settings, x[k.corners.a], x[k.corners.b], centre, push)) return;
  const int first = m.cellOffsets[k.corners.cell], size = m.cellOffsets[k.corners.cell + 1] - first;
  for (int j = 0; j < 2 + size; ++j) {
    const int u = reactionPartner(k, j, m.cellVertices + first);
    const float weight = reactionPart(k, j, size) * alpha;
    addReactionTo(sums, u, push.x * weight, push.y * weight, push.z * weight);
  }
}

// The contact response (collision::contactResponse) with kGroup lanes per vertex: in each round
// the group's lanes search the next kGroup structures, then the group's first lane adds their
// contacts in structure order (addContact), as contactResponse does: the CPU's arithmetic, in its
// order. A vertex still clear of every structure (clearOfContacts) does not search, and a warp with
// none searching skips the rounds. With one thread per vertex, small scenes spent the step on a few
// vertices searching several neighbours one after another (ncu at 20,352 vertices: 6 of 32 threads
// active per warp). kWarpLeaves: the warp tests the reached leaves' triangles together, two leaves
// at a time (contactWithWarp, testLeafPairWarp): at 20,352 vertices the response took 50 instead
// of 78 us (H100, one leaf at a time). One leaf at a time it lost where many lanes walk at once
// (591 against 497 us at 325,632 vertices); two at a time, 4 lanes a vertex won there (358.5
// against 826.5 us), but not with 100 structures, whose 25 rounds a vertex cost more (launchCollision).
// The engine launches it on the steps of a full search only (DeviceCollision::searchesAt).
//
// kWarpLeaves: held to 6 blocks of 128 threads an SM (80 registers instead of the compiler's 91,
// which allowed 5). The walks are latency-bound (ncu at 20,352 vertices: 9.2 cycles between a
// warp's instructions, 0.59 eligible warps per scheduler), so more warps hide more of it. H100, the
// demo's response 66.2 -> 62.7-62.8 us a step at 20,352 vertices, 128.5 -> 123.4 at 81,408; with
// 8 blocks (64 registers) 63.0 and 125.9. A lane per vertex (large scenes) is left unbounded: with
// 6 blocks 830 -> 810 us at 325,632 vertices but 2,151 -> 2,236 at 1,269,152 (docs/collisions.md).
template <int kGroup, bool kWarpLeaves>
__global__ void __launch_bounds__(kThreads, kWarpLeaves ? kRespondBlocks : 0)
    respondGroup(MeshView m, ParamView p, BvhView v, ContactSettings settings, int every,
                 const float* moved, const unsigned* motion, float* depth, int* hint, float* slack, float* stiffness,
                 HoldPlane* hold, ContactPlane* contact, float* contactShare, float3* out,
                 unsigned long long* reaction) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  const int i = t / kGroup, g = t % kGroup;
  const bool valid = i < m.vertices;  // every lane stays for the shuffles
  const int own = valid ? m.meshOf[i] : 0;
  const bool active = valid && param(p, own, 0) > 0.0f;
  const P3* x = reinterpret_cast<const P3*>(m.x);
  const P3* centres = reinterpret_cast<const P3*>(m.cellCentre);
  const P3 point = active ? x[i] : P3{0, 0, 0};
  const P3 previous = active ? reinterpret_cast<const P3*>(m.prev)[i] : P3{0, 0, 0};
  const P3 ownNormal = active ? reinterpret_cast<const P3*>(m.normal)[i] : P3{0, 0, 0};
  const float alpha = active ? param(p, own, 0) * m.mass[i] : 0.0f;
  float lastDepth = active ? depth[i] : 0.0f;
  int lastHint = active ? hint[i] : -1;
  float lastSlack = active ? slack[i] : 0.0f;
  const bool clear = active && clearOfContacts(lastDepth, moved[i], __uint_as_float(*motion), lastSlack);
  // Every lane runs every round (the shuffles need the whole warp).
  const bool search = active && !clear;
  const float maxD2 = fullSearchBound(lastDepth, settings, every, point, previous);
  ContactSum sum;
  HoldPlane plane;
  HoldPlane* const holdPlane = hold && settings.hold >= 0.0f ? &plane : nullptr;
  const unsigned mask = 0xffffffffu;
  const int leader = (threadIdx.x % 32) - g;
  constexpr unsigned groupLanes = kGroup >= 32 ? 0xffffffffu : (1u << kGroup) - 1u;
  float clearance2 = 3.0e38f;
  if (__any_sync(mask, search))
    for (int base = 0; base < v.meshes; base += kGroup) {
      Hit h{};
      bool found;
      if constexpr (kWarpLeaves)
        found = contactWithWarp(v, own, base + g, point, settings.margin, maxD2, lastHint, x, centres, search, h, clearance2);
      else
        found = search && base + g < v.meshes &&
                contactWith(v, own, base + g, point, settings.margin, maxD2, lastHint, x, centres, h, clearance2);
      // The group's contacts, in structure order (its lanes' order), handed to its first lane. Only
      // lanes that found one are visited: one or two of a vertex's 16 (ncu at 20,352 vertices: the
      // 16 rounds of shuffles were most of the kernel's instructions once the walks were done).
      unsigned pending = (__ballot_sync(mask, found) >> leader) & groupLanes;
      while (__any_sync(mask, pending != 0)) {
        const int src = leader + (pending ? __ffs(pending) - 1 : 0);
        Hit c;
        c.d2 = __shfl_sync(mask, h.d2, src);
        c.point = {__shfl_sync(mask, h.point.x, src), __shfl_sync(mask, h.point.y, src), __shfl_sync(mask, h.point.z, src)};
        c.normal = {__shfl_sync(mask, h.normal.x, src), __shfl_sync(mask, h.normal.y, src),
                    __shfl_sync(mask, h.normal.z, src)};
        c.side = __shfl_sync(mask, h.side, src);
        c.leaf = __shfl_sync(mask, h.leaf, src);
        c.tri = __shfl_sync(mask, h.tri, src);
        if (pending && g == 0)
          addContact(c, point, previous, ownNormal, alpha, settings, sum, holdPlane,
                     shareAt(v, own, base + src - leader, c.tri, c.side, settings.margin));
        pending &= pending - 1;
      }
    }
  for (int o = kGroup / 2; o > 0; o /= 2) clearance2 = fminf(clearance2, __shfl_xor_sync(mask, clearance2, o));
  if (!active || g != 0) {
    if (valid && g == 0) out[i] = make_float3(0.0f, 0.0f, 0.0f);
    if (valid && g == 0 && stiffness) stiffness[i] = 0.0f;
    if (valid && g == 0 && holdPlane) hold[i] = plane;  // none: nothing searched
    return;
  }
  if (search) {
    lastDepth = sum.deepest;
    lastHint = sum.nearestLeaf;
    lastSlack = slackAfterSearch(lastDepth, clearance2, settings.margin);
    // The plane is read only where its share, in an array of its own, says there is one.
    if (sum.deepestShare >= 0.0f) {
      const ContactPlane k = contactOn(v, sum.deepestHit, sum.deepestShare, x, centres);
      contact[i] = k;
      if (reaction) scatterReaction(m, p, settings, k, point, ownNormal, centres[k.corners.cell], reaction);
    }
    contactShare[i] = sum.deepestShare >= 0.0f ? sum.deepestShare : -1.0f;
  } else {  // clear: a full search's skip leaves no plane (contactResponse)
    contactShare[i] = -1.0f;
  }
  if (holdPlane) hold[i] = plane;
  depth[i] = lastDepth;
  hint[i] = lastHint;
  slack[i] = lastSlack;
  out[i] = make_float3(sum.force.x, sum.force.y, sum.force.z);
  if (stiffness) stiffness[i] = sum.stiffness;
}

// The reaction's sums between full searches (ReactionSums; a full search's response sums them
// itself), a thread a vertex. Its normal from its neighbours and the contact's cell centre as the
// geometry pass computes them (neighbourNormal, centreOf: the same bits), so that it need not wait
// for that pass. A touching vertex's time is a chain of dependent loads: its plane, its neighbours
// and its own structure are loaded together before its weight is checked.
__global__ void reactionScatter(MeshView m, ReactionSums r) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= m.vertices || !(r.share[i] >= 0.0f)) return;
  const ContactPlane k = r.contact[i];
  const int3 n = m.neighbours[i];
  const int own = m.meshOf[i];
  if (!(param(r.params, own, 0) > 0.0f)) return;
  const float3 p = m.x[i], normal = neighbourNormal(m.x[n.x], m.x[n.y], m.x[n.z]);
  const float3 c = centreOf(m, k.corners.cell);
  scatterReaction(m, r.params, r.settings, k, {p.x, p.y, p.z}, {normal.x, normal.y, normal.z}, {c.x, c.y, c.z}, r.sums);
}

__global__ void addCollisionForce(MeshView m, const float3* collisionForce, unsigned long long* reaction) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= m.vertices) return;
  float3 f = m.force[i] + collisionForce[i];
  if (reaction) f = f + takeReaction(m, reaction, i);
  m.force[i] = f;
}

__global__ void contactSprings(MeshView m, ParamView p, const int* partner, const float3* offset, float* stiffness) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= m.vertices) return;
  const int j = partner[i];
  const float alpha = param(p, m.meshOf[i], 0);
  float k = 0.0f;
  if (j >= 0 && alpha > 0.0f) {
    k = alpha * m.mass[i];
    m.force[i] = m.force[i] + k * ((m.x[j] + offset[i]) - m.x[i]);
  }
  if (stiffness) stiffness[i] = k;
}
// The collision's step ends: the motion's largest (trackMotion, at the next full search) starts again.
__device__ void advanceStep(unsigned* motion) { *motion = 0; }
// The hold (CollisionForce::constrain's arithmetic); then the step's end (advanceStep: the response
// read both).
__global__ void holdOut(MeshView m, const HoldPlane* hold, const float* contactShare, ContactSettings settings,
                        unsigned* motion) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i == 0) advanceStep(motion);
  if (i >= m.vertices || contactShare[i] < 0.0f) return;  // no contact plane: no hold plane (respondGroup)
  const HoldPlane h = hold[i];
  if (!(h.side < 3.0e38f)) return;  // a contact that does not pull: no plane, and no loads of x and prev
  P3* x = reinterpret_cast<P3*>(m.x);
  P3* previous = reinterpret_cast<P3*>(m.prev);
  P3 p = x[i], q = previous[i];
  collision::holdOut(h, p, q, collision::holdLimit(settings, m.area, i));
  x[i] = p;
  previous[i] = q;
}
// The collision's force added, the damped Verlet move, then the hold (as holdOut; hold null: none,
// and `advance` ended the step on the branch).
__global__ void addMoveAndHold(MeshView m, const float3* collisionForce, unsigned long long* reaction, VerletMove move,
                               const HoldPlane* hold, ContactSettings settings, unsigned* motion) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i == 0 && hold) advanceStep(motion);
  if (i >= m.vertices) return;
  float3 f = m.force[i] + collisionForce[i];
  if (reaction) f = f + takeReaction(m, reaction, i);
  m.force[i] = f;
  const float3 current = m.x[i];  // verletMove's arithmetic, the hold's on the values it writes
  const float3 next = verletStep(current, m.prev[i], f, move.dt, move.keep, m.mass[i]);
  P3 p{next.x, next.y, next.z}, q{current.x, current.y, current.z};
  if (hold) collision::holdOut(hold[i], p, q, collision::holdLimit(settings, m.area, i));
  m.x[i] = make_float3(p.x, p.y, p.z);
  m.prev[i] = make_float3(q.x, q.y, q.z);
}
// The step's end without a hold.
__global__ void advance(unsigned* motion) { advanceStep(motion); }
}  // namespace

void launchContactSprings(const MeshView& m, ParamView p, const int* partner, const float3* offset, float* stiffness,
                          cudaStream_t s) {
  contactSprings<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, p, partner, offset, stiffness);
}

void launchCollisionRefit(const MeshView& m, const CollisionDevice& c, cudaStream_t s) {
  BvhView v{c.nodes, c.boxes, c.tris, c.order, c.roots, c.exempt, c.meshes, c.nodeCount, c.share};
  if (c.climb) {
    climbRefit<<<(c.leafCount + kThreads - 1) / kThreads, kThreads, 0, s>>>(
        v, c.leaves, c.leafCount, c.visits, reinterpret_cast<const P3*>(m.x), reinterpret_cast<const P3*>(m.cellCentre),
        m.vertices, c.last, c.moved, c.motion, c.depth, c.lastDepth);
    return;
  }
  vertexBoxes<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(v, m, c.last, c.moved, c.motion, c.depth,
                                                                          c.lastDepth, c.vertexBoxes);
  const NodeLists& l = c.lists;
  const int n = int(kNodeThreads);
  const int blocks = std::max(1, (l.threadCount + n - 1) / n + (l.warpCount * 32 + n - 1) / n + l.blockCount);
  nodeBoxes<<<blocks, kNodeThreads, 0, s>>>(v, c.vertexBoxes, l);
}

void launchCollisionRespond(const MeshView& m, ParamView p, const CollisionDevice& c, const ContactSettings& settings,
                            int every, cudaStream_t s) {
  BvhView v{c.nodes, c.boxes, c.tris, c.order, c.roots, c.exempt, c.meshes, c.nodeCount, c.share, c.lastDepth,
            settings.reaction > 0.0f};
  // Lanes a vertex. From 131,072 vertices, 4 where a vertex's structures take at most 4 rounds of
  // them: with two leaves at once that beat a lane a vertex 358.5 against 826.5 us at 325,632
  // vertices (12 structures), but lost 2,433 against 2,114 us with 100 structures (25 rounds;
  // H100, docs/collisions.md).
  unsigned long long* const sums = settings.reaction > 0.0f ? c.reaction : nullptr;  // the response sums the reaction
  const int group = m.vertices >= 131072 ? (c.meshes <= 16 ? 4 : 1) : m.vertices >= 32768 ? 4 : 16;
  const unsigned grid = static_cast<unsigned>((static_cast<size_t>(m.vertices) * group + kThreads - 1) / kThreads);
  if (group == 1)
    respondGroup<1, false><<<grid, kThreads, 0, s>>>(m, p, v, settings, every, c.moved, c.motion, c.depth, c.hint, c.slack,
                                                c.stiffness, c.hold, c.contact, c.contactShare, c.force, sums);
  else if (group == 4)
    respondGroup<4, true><<<grid, kThreads, 0, s>>>(m, p, v, settings, every, c.moved, c.motion, c.depth, c.hint, c.slack,
                                                c.stiffness, c.hold, c.contact, c.contactShare, c.force, sums);
  else
    respondGroup<16, true><<<grid, kThreads, 0, s>>>(m, p, v, settings, every, c.moved, c.motion, c.depth, c.hint, c.slack,
                                                c.stiffness, c.hold, c.contact, c.contactShare, c.force, sums);
  // With a hold, the hold's kernel ends the step: a launch fewer (2.7 us a step, H100).
  if (settings.hold < 0.0f) advance<<<1, 1, 0, s>>>(c.motion);
}

void launchCollisionReaction(const MeshView& m, const ReactionSums& r, cudaStream_t s) {
  reactionScatter<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, r);
}

void launchCollisionAdd(const MeshView& m, const CollisionDevice& c, cudaStream_t s) {
  addCollisionForce<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, c.force, c.reaction);
}

void launchCollisionMove(const MeshView& m, const CollisionDevice& c, const VerletMove& move,
                         const ContactSettings& settings, cudaStream_t s) {
  addMoveAndHold<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(
      m, c.force, c.reaction, move, settings.hold >= 0.0f ? c.hold : nullptr, settings, c.motion);
}

void launchCollisionPlanes(const MeshView& m, const ContactPlanes& planes, float3* out, cudaStream_t s) {
  respondPlanes<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, planes, out);
}

void launchCollisionHold(const MeshView& m, const CollisionDevice& c, const ContactSettings& settings, cudaStream_t s) {
  holdOut<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, c.hold, c.contactShare, settings, c.motion);
}

}  // namespace sinew::cuda
