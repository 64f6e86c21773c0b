// The timeline's sampled error on the device (core/sampled_error.h, whose inline queries these
// kernels run): the tessellation's points gathered, its hierarchy refitted bottom up (the last
// child to arrive merges), then one thread per sample in each direction.
#include "cuda_check.h"
#include "kernels.h"

#include "sinew/core/triangle_bvh.h"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 128;
using collision::P3;
using trianglebvh::Node;

unsigned blocks(int n) { return (unsigned(n) + kThreads - 1) / kThreads; }

// Vertices, then cell centres (the mean of the cell's vertices, as the host computes them).
__global__ void gatherPoints(const float3* x, const int* cellOffsets, const int* cellVertices, int vertices, int cells,
                             P3* points) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < vertices) {
    points[i] = {x[i].x, x[i].y, x[i].z};
  } else if (i < vertices + cells) {
    const int c = i - vertices;
    float sx = 0, sy = 0, sz = 0;
    for (int k = cellOffsets[c]; k < cellOffsets[c + 1]; ++k) {
      const float3 p = x[cellVertices[k]];
      sx += p.x, sy += p.y, sz += p.z;
    }
    const float n = float(cellOffsets[c + 1] - cellOffsets[c]);
    points[i] = {sx / n, sy / n, sz / n};
  }
}

__global__ void refit(Node* nodes, const int* parents, const int* leaves, int leafCount, const int3* triangles,
                      const P3* points, P3* corners, int* visits) {
  const int l = blockIdx.x * blockDim.x + threadIdx.x;
  if (l >= leafCount) return;
  const int id = leaves[l];
  collision::Box box = collision::emptyBox();
  for (int t = nodes[id].first; t < nodes[id].first + nodes[id].count; ++t) {
    const int3 k = triangles[t];
    corners[3 * t] = points[k.x], corners[3 * t + 1] = points[k.y], corners[3 * t + 2] = points[k.z];
    collision::extend(box, points[k.x]);
    collision::extend(box, points[k.y]);
    collision::extend(box, points[k.z]);
  }
  nodes[id].box = box;
  for (int parent = parents[id]; parent >= 0; parent = parents[parent]) {
    __threadfence();
    if (atomicAdd(&visits[parent], 1) == 0) return;
    const volatile Node* n = nodes;
    const int a = n[parent].left, b = n[parent].right;
    collision::Box left, right;
    left.lo = {n[a].box.lo.x, n[a].box.lo.y, n[a].box.lo.z};
    left.hi = {n[a].box.hi.x, n[a].box.hi.y, n[a].box.hi.z};
    right.lo = {n[b].box.lo.x, n[b].box.lo.y, n[b].box.lo.z};
    right.hi = {n[b].box.hi.x, n[b].box.hi.y, n[b].box.hi.z};
    nodes[parent].box = collision::merge(left, right);
  }
}

// Mesh to truth: `per` threads per tessellation triangle (SampledError::samplesPerTriangle).
__global__ void toTruth(trianglebvh::View mesh, trianglebvh::View truth, const int* structureOf, const int* truthRoots,
                        int triangles, int per, WeightedDistance* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= triangles * per) return;
  const int t = i / per, q = i % per;
  const int root = truthRoots[structureOf[t]];
  if (root < 0) {
    out[i] = {0.0f, 0.0f};
    return;
  }
  const P3* c = mesh.corners + 3 * t;
  const P3 n = collision::cross3(collision::sub(c[1], c[0]), collision::sub(c[2], c[0]));
  const float area = 0.5f * sqrtf(collision::dot3(n, n)) / float(per);
  const P3 p = subTriangleCentroid(c[0], c[1], c[2], q, per);
  out[i] = {sqrtf(trianglebvh::closestSquaredDistance(truth, root, p, 3.0e38f)), area};
}

// Truth to mesh: the tessellation's tangent plane at each patch (one thread per patch), then each
// truth sample's distance to its patch's plane (one thread per sample).
__global__ void patchPlanes(trianglebvh::View mesh, const P3* centres, const int* structureOf, const int* meshRoots, int count,
                            trianglebvh::TangentPlane* planes) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < count) planes[i] = trianglebvh::closestTangentPlane(mesh, meshRoots[structureOf[i]], centres[i]);
}
__global__ void fromTruth(const trianglebvh::TangentPlane* planes, const P3* centres, const float3* samples, const float* areas,
                          const int* patchOf, int count, WeightedDistance* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  const int patch = patchOf[i];
  out[i] = {trianglebvh::planeDistance(planes[patch], centres[patch], P3{samples[i].x, samples[i].y, samples[i].z}), areas[i]};
}
__global__ void closestDistances(trianglebvh::View meshes, const P3* points, const int* roots, int count, float* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < count) out[i] = sqrtf(trianglebvh::closestSquaredDistance(meshes, roots[i], points[i], 3.0e38f));
}
}  // namespace

void launchClosestDistances(const Node* nodes, const P3* corners, const P3* points, const int* roots, int count, float* out,
                            cudaStream_t s) {
  if (count > 0) closestDistances<<<blocks(count), kThreads, 0, s>>>({nodes, corners}, points, roots, count, out);
}

void launchSampledError(const MeshView& m, const SampledErrorDevice& e, cudaStream_t s) {
  gatherPoints<<<blocks(m.vertices + m.cells), kThreads, 0, s>>>(m.x, m.cellOffsets, m.cellVertices, m.vertices, m.cells,
                                                                 e.points);
  SINEW_CUDA(cudaMemsetAsync(e.visits, 0, sizeof(int) * e.meshNodeCount, s));
  refit<<<blocks(e.leafCount), kThreads, 0, s>>>(e.meshNodes, e.parents, e.leaves, e.leafCount, e.triangles, e.points,
                                                 e.corners, e.visits);
  const trianglebvh::View mesh{e.meshNodes, e.corners}, truth{e.truthNodes, e.truthCorners};
  toTruth<<<blocks(e.triangleCount * e.samplesPerTriangle), kThreads, 0, s>>>(mesh, truth, e.triangleStructure, e.truthRoots,
                                                                              e.triangleCount, e.samplesPerTriangle, e.toTruth);
  if (e.patchCount > 0)
    patchPlanes<<<blocks(e.patchCount), kThreads, 0, s>>>(mesh, e.patchCentres, e.patchStructure, e.meshRoots, e.patchCount,
                                                          e.planes);
  if (e.sampleCount > 0)
    fromTruth<<<blocks(e.sampleCount), kThreads, 0, s>>>(e.planes, e.patchCentres, e.samples, e.sampleAreas, e.samplePatch,
                                                         e.sampleCount, e.fromTruth);
}

}  // namespace sinew::cuda
