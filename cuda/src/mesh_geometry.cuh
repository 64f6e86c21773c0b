// A cell's centre and a vertex's elevation and area as MeshStore::refreshCurrent computes them, in
// the expressions every kernel that computes them shares: the geometry pass (geometry_kernels.cu),
// the one-pass lean step (block_step_kernels.cu) and the collision refit (collision_kernels.cu)
// then agree to the bit by construction.
#pragma once

#include "device_math.cuh"

namespace sinew::cuda {

// The centre of the cell whose vertices are m.cellVertices[b .. e - 1]. Its first kCellUnrolled
// vertices are loaded at once, then summed in order (the CPU's sum, bit for bit); a loop over the
// cell's vertices left each load waiting for the last (H200, one step of smoothing + shape prior at
// 2,656 vertices: 9.47 -> 8.70-8.75 us; docs/benchmarks.md).
constexpr int kCellUnrolled = 8;
__device__ __forceinline__ float3 centreAt(const MeshView& m, int b, int e) {
  int id[kCellUnrolled];
#pragma unroll
  for (int k = 0; k < kCellUnrolled; ++k) id[k] = b + k < e ? m.cellVertices[b + k] : 0;
  float3 corner[kCellUnrolled];
#pragma unroll
  for (int k = 0; k < kCellUnrolled; ++k) corner[k] = b + k < e ? m.x[id[k]] : make_float3(0, 0, 0);
  float3 sum = make_float3(0, 0, 0);
#pragma unroll
  for (int k = 0; k < kCellUnrolled; ++k)
    if (b + k < e) sum = sum + corner[k];
  for (int i = b + kCellUnrolled; i < e; ++i) sum = sum + m.x[m.cellVertices[i]];
  return sum / static_cast<float>(e - b);
}
__device__ __forceinline__ float3 centreOf(const MeshView& m, int c) {
  return centreAt(m, m.cellOffsets[c], m.cellOffsets[c + 1]);
}

__device__ __forceinline__ float triangleArea(float3 a, float3 b, float3 c) { return 0.5f * norm(cross(b - a, c - a)); }

// Vertex p's elevation over its neighbours q (normal: theirs, neighbourNormal).
__device__ __forceinline__ float vertexElevation(float3 p, const float3 (&q)[3], float3 normal) {
  return dot(p - q[0], normal);
}
// Vertex p's area: the Fig. 1b triangles with its neighbours q and its cells' centres.
__device__ __forceinline__ float vertexArea(float3 p, const float3 (&q)[3], const float3 (&centre)[3]) {
  float a = 0.0f;
#pragma unroll
  for (int j = 0; j < 3; ++j) a += triangleArea(p, q[j], centre[j]) + triangleArea(p, q[j], centre[(j + 1) % 3]);
  return a;
}

}  // namespace sinew::cuda
