// Attraction points on the device (paper 000 section 4.5): a parallel search for each point's
// closest vertex (ties to the lower index, as on the CPU), then one thread applies equations 2-3
// point by point in the CPU's order, so the sums round identically.
#include "device_math.cuh"

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

__global__ void resetKeys(unsigned long long* keys, int count) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < count) keys[i] = ~0ull;
}

__global__ void applyAttraction(MeshView m, ParamView p, int kRing, const float3* points, const int* pointMesh,
                                int pointCount, const unsigned long long* keys) {
  int group[kMaxGroup];
  float w[kMaxGroup];
  for (int point = 0; point < pointCount; ++point) {
    const int mesh = pointMesh[point];
    const float alpha = param(p, mesh, 0);
    if (!(alpha > 0.0f)) continue;
    const int ring = static_cast<int>(param(p, mesh, kRing));
    const int p0 = static_cast<int>(keys[point] & 0xffffffffu);
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
    const float3 c = points[point];
    float total = 0.0f;
    for (int i = 0; i < size; ++i) {
      w[i] = 1.0f / fmaxf(norm(c - m.x[group[i]]), 1e-6f);
      total += w[i];
    }
    const float3 pull = c - m.x[p0];
    for (int i = 0; i < size; ++i) m.force[group[i]] = m.force[group[i]] + (alpha * w[i] / total) * pull;
  }
}
}  // namespace

void launchAttraction(const MeshView& m, ParamView p, int kRing, const float3* points, const int* pointMesh,
                      const int* meshBegin, const int* meshEnd, int pointCount, unsigned long long* keys,
                      cudaStream_t s) {
  if (pointCount == 0) return;
  resetKeys<<<(pointCount + 255) / 256, 256, 0, s>>>(keys, pointCount);
  closestVertex<<<dim3(64, pointCount), 256, 0, s>>>(m, points, pointMesh, meshBegin, meshEnd, keys);
  applyAttraction<<<1, 1, 0, s>>>(m, p, kRing, points, pointMesh, pointCount, keys);
}

}  // namespace sinew::cuda
