// Placed points on the device (the attraction_points force: attraction points, paper 000 section
// 4.5; include / exclude points, paper 001 section 4): a parallel search for each point's closest
// vertex (ties to the lower index, as on the CPU), then one thread applies the pulls point by point
// in the CPU's order, so the sums round identically.
#include "device_math.cuh"
#include "kernels.h"
#include "sinew/core/winding.h"

namespace sinew::cuda {

namespace {
constexpr int kMaxGroup = 1024;

// Squared distances are non-negative, so their float bits order like the values; the vertex index
// in the low word breaks ties toward the lower index.
__global__ void closestVertex(MeshView m, const float3* points, const int* pointMesh, const int* meshBegin,
                              const int* meshEnd, unsigned long long* keys) {
  const int point = blockIdx.y;
  const int mesh = pointMesh[point];
  const float3 c = points[point];
  unsigned long long best = ~0ull;
  for (int v = meshBegin[mesh] + blockIdx.x * blockDim.x + threadIdx.x; v < meshEnd[mesh]; v += gridDim.x * blockDim.x) {
    const float d2 = squaredNorm(m.x[v] - c);
    const unsigned long long key = (static_cast<unsigned long long>(__float_as_uint(d2)) << 32) | static_cast<unsigned>(v);
    best = min(best, key);
  }
  for (int offset = 16; offset > 0; offset /= 2) best = min(best, __shfl_down_sync(0xffffffffu, best, offset));
  if ((threadIdx.x & 31) == 0) atomicMin(keys + point, best);
}

__global__ void resetKeys(unsigned long long* keys, float* windings, int count) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < count) {
    keys[i] = ~0ull;
    windings[i] = 0.0f;
  }
}

// The solid angle each include / exclude point's structure subtends at it (core/winding.h), summed
// over the cells by warps; the sum's order varies, but only its side of 2 pi is used.
__global__ void windingSum(MeshView m, const float3* points, const int* pointMesh, const int* pointKind,
                           float* windings) {
  const int point = blockIdx.y;
  if (pointKind[point] == kAttractPoint) return;
  const int mesh = pointMesh[point];
  const auto* x = reinterpret_cast<const collision::P3*>(m.x);
  const auto* centres = reinterpret_cast<const collision::P3*>(m.cellCentre);
  const float3 c = points[point];
  float sum = 0.0f;
  for (int cell = blockIdx.x * blockDim.x + threadIdx.x; cell < m.cells; cell += gridDim.x * blockDim.x)
    if (m.meshOf[m.cellVertices[m.cellOffsets[cell]]] == mesh)
      sum += cellSolidAngle(x, centres, m.cellOffsets, m.cellVertices, cell, {c.x, c.y, c.z});
  for (int offset = 16; offset > 0; offset /= 2) sum += __shfl_down_sync(0xffffffffu, sum, offset);
  if ((threadIdx.x & 31) == 0 && sum != 0.0f) atomicAdd(windings + point, sum);
}

__global__ void applyAttraction(MeshView m, ParamView p, int kRing, int kMargin, const float3* points,
                                const int* pointMesh, const int* pointKind, int pointCount,
                                const unsigned long long* keys, const float* windings) {
  int group[kMaxGroup];
  float w[kMaxGroup];
  for (int point = 0; point < pointCount; ++point) {
    const int mesh = pointMesh[point];
    const float alpha = param(p, mesh, 0);
    if (!(alpha > 0.0f)) continue;
    const int p0 = static_cast<int>(keys[point] & 0xffffffffu);
    const float3 c = points[point];
    float3 pull;
    if (pointKind[point] == kAttractPoint) {
      pull = alpha * (c - m.x[p0]);
    } else {
      // As the CPU force: the side by the winding number, the push along P0's normal.
      const bool inside = windings[point] > 2.0f * 3.14159265f;
      const float shift = constraintShift(pointKind[point] == kIncludePoint, inside, norm(c - m.x[p0]),
                                          param(p, mesh, kMargin));
      if (shift == 0.0f) continue;
      pull = (alpha * shift) * m.normal[p0];
    }
    const int ring = static_cast<int>(param(p, mesh, kRing));
    // Breadth-first p-ring, in the CPU's order.
    int size = 1, frontier = 0;
    group[0] = p0;
    for (int level = 0; level < ring; ++level) {
      const int end = size;
      for (int i = frontier; i < end; ++i) {
        const int3 n = m.neighbours[group[i]];
        const int nb[3] = {n.x, n.y, n.z};
        for (int k = 0; k < 3; ++k) {
          bool seen = false;
          for (int q = 0; q < size && !seen; ++q) seen = group[q] == nb[k];
          if (!seen && size < kMaxGroup) group[size++] = nb[k];
        }
      }
      frontier = end;
    }
    float total = 0.0f;
    for (int i = 0; i < size; ++i) {
      w[i] = 1.0f / fmaxf(norm(c - m.x[group[i]]), 1e-6f);
      total += w[i];
    }
    if (pointKind[point] == kAttractPoint)
      for (int i = 0; i < size; ++i) m.force[group[i]] = m.force[group[i]] + (w[i] / total) * pull;
    else
      for (int i = 0; i < size; ++i) m.force[group[i]] = m.force[group[i]] + (m.mass[group[i]] * w[i] / w[0]) * pull;
  }
}
}  // namespace

void launchAttraction(const MeshView& m, ParamView p, int kRing, int kMargin, const float3* points, const int* pointMesh,
                      const int* pointKind, const int* meshBegin, const int* meshEnd, int pointCount,
                      unsigned long long* keys, float* windings, bool constraints, cudaStream_t s) {
  if (pointCount == 0) return;
  resetKeys<<<(pointCount + 255) / 256, 256, 0, s>>>(keys, windings, pointCount);
  closestVertex<<<dim3(64, pointCount), 256, 0, s>>>(m, points, pointMesh, meshBegin, meshEnd, keys);
  if (constraints) windingSum<<<dim3(64, pointCount), 256, 0, s>>>(m, points, pointMesh, pointKind, windings);
  applyAttraction<<<1, 1, 0, s>>>(m, p, kRing, kMargin, points, pointMesh, pointKind, pointCount, keys, windings);
}

}  // namespace sinew::cuda
