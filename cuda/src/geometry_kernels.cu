// Geometry refresh on the device: cell centres, then per vertex normal, elevation, area and mass
// (mirrors MeshStore::refreshCurrent).
#include "device_math.cuh"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;

__device__ __forceinline__ float triangleArea(float3 a, float3 b, float3 c) { return 0.5f * norm(cross(b - a, c - a)); }
__device__ __forceinline__ int pick(const int3& v, int k) { return k == 0 ? v.x : (k == 1 ? v.y : v.z); }

__global__ void cellCentres(MeshView m) {
  const int c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= m.cells) return;
  float3 sum = make_float3(0, 0, 0);
  const int b = m.cellOffsets[c], e = m.cellOffsets[c + 1];
  for (int i = b; i < e; ++i) sum = sum + m.x[m.cellVertices[i]];
  m.cellCentre[c] = sum / static_cast<float>(e - b);
}

__global__ void vertexGeometry(MeshView m) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const int3 n = m.neighbours[v];
  const float3 p = m.x[v], p1 = m.x[n.x], p2 = m.x[n.y], p3 = m.x[n.z];
  const Frame f = neighbourFrame(p1, p2, p3);
  if (m.normal) m.normal[v] = f.normal;
  if (m.elevation) m.elevation[v] = dot(p - p1, f.normal);
  if (m.area) {
    const int3 c = m.vertexCells[v];
    float a = 0.0f;
#pragma unroll
    for (int j = 0; j < 3; ++j) {
      const float3 q = m.x[pick(n, j)];
      a += triangleArea(p, q, m.cellCentre[pick(c, j)]) + triangleArea(p, q, m.cellCentre[pick(c, (j + 1) % 3)]);
    }
    m.area[v] = a;
    if (m.mass) m.mass[v] = a * m.density[m.meshOf[v]];
  }
}
}  // namespace

void launchGeometry(const MeshView& m, cudaStream_t s) {
  if (m.cellCentre) cellCentres<<<(m.cells + kThreads - 1) / kThreads, kThreads, 0, s>>>(m);
  if (m.normal || m.elevation || m.area) vertexGeometry<<<(m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m);
}

}  // namespace sinew::cuda
