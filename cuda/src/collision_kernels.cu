// Collision detection and response on the device (core/collision_bvh.h holds the code the CPU
// force runs too): the hierarchies refitted bottom up, the last child to arrive at a node computing
// its box, then one thread per vertex finding its contacts.
#include "cuda_check.h"
#include "device_math.cuh"

#include "sinew/core/collision_bvh.h"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 128;
using namespace sinew::collision;

// Only the steps of a full search read the boxes (counter: the level's steps so far).
__global__ void refit(BvhView v, const int* leaves, int leafCount, int* visits, const P3* x, const P3* centres,
                      const int* counter, int every) {
  const int l = blockIdx.x * blockDim.x + threadIdx.x;
  if (l >= leafCount || *counter % every != 0) return;
  int id = leaves[l];
  v.boxes[id] = leafBox(v, v.nodes[id], x, centres);
  // Up the tree: the first child to arrive stops, the second merges both (its sibling's box is
  // written and fenced before the counter moved).
  for (int parent = v.nodes[id].parent; parent >= 0; parent = v.nodes[parent].parent) {
    __threadfence();
    if (atomicAdd(&visits[parent], 1) == 0) return;
    const Node n = v.nodes[parent];
    const volatile Box* boxes = v.boxes;
    Box a, b;
    a.lo = {boxes[n.left].lo.x, boxes[n.left].lo.y, boxes[n.left].lo.z};
    a.hi = {boxes[n.left].hi.x, boxes[n.left].hi.y, boxes[n.left].hi.z};
    b.lo = {boxes[n.right].lo.x, boxes[n.right].lo.y, boxes[n.right].lo.z};
    b.hi = {boxes[n.right].hi.x, boxes[n.right].hi.y, boxes[n.right].hi.z};
    v.boxes[parent] = merge(a, b);
  }
}

__global__ void respond(MeshView m, ParamView p, BvhView v, float margin, float damping, float reach,
                        const int* counter, int every, float* depth, int* hint, float* stiffness) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= m.vertices) return;
  const int own = m.meshOf[i];
  const float alpha = param(p, own, 0);
  float k = 0.0f;
  if (alpha > 0.0f) {
    const P3* x = reinterpret_cast<const P3*>(m.x);
    const P3* centres = reinterpret_cast<const P3*>(m.cellCentre);
    P3 f{0, 0, 0};
    const P3 previous = reinterpret_cast<const P3*>(m.prev)[i];
    k = contactResponse(v, own, x[i], previous, alpha * m.mass[i], margin, damping, reach, *counter % every == 0, every,
                        depth[i], hint[i], x, centres, f);
    m.force[i] = m.force[i] + make_float3(f.x, f.y, f.z);
  }
  if (stiffness) stiffness[i] = k;
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
__global__ void advance(int* counter) { ++*counter; }
}  // namespace

void launchContactSprings(const MeshView& m, ParamView p, const int* partner, const float3* offset, float* stiffness,
                          cudaStream_t s) {
  contactSprings<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, p, partner, offset, stiffness);
}

void launchCollision(const MeshView& m, ParamView p, const CollisionDevice& c, float margin, float damping, float reach,
                     int every, cudaStream_t s) {
  BvhView v{c.nodes, c.boxes, c.tris, c.order, c.roots, c.exempt, c.meshes, c.nodeCount};
  SINEW_CUDA(cudaMemsetAsync(c.visits, 0, sizeof(int) * c.nodeCount, s));
  refit<<<(c.leafCount + kThreads - 1) / kThreads, kThreads, 0, s>>>(v, c.leaves, c.leafCount, c.visits,
                                                                      reinterpret_cast<const P3*>(m.x),
                                                                      reinterpret_cast<const P3*>(m.cellCentre),
                                                                      c.counter, every);
  respond<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, p, v, margin, damping, reach, c.counter, every,
                                                                      c.depth, c.hint, c.stiffness);
  advance<<<1, 1, 0, s>>>(c.counter);
}

}  // namespace sinew::cuda
