// A vertex's elevation and area as MeshStore::refreshCurrent computes them, in the expressions
// every kernel that computes them shares: the geometry pass (geometry_kernels.cu) and the one-pass
// lean step (block_step_kernels.cu) then agree to the bit by construction.
#pragma once

#include "device_math.cuh"

namespace sinew::cuda {

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
