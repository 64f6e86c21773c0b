// Attachments on the device (core/attachments.cpp mirrored: Attachments::shareForces and
// Attachments::project, in their order and arithmetic).
#include "device_math.cuh"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;

// Merged pairs, then fixed and attached vertices: all distinct, so one thread each.
__global__ void share(MeshView m, AttachmentDevice a) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t < a.mergedCount) {
    const int u = a.mergedA[t], v = a.mergedB[t];
    const float3 total = m.force[u] + m.force[v];
    const float mass = m.mass[u] + m.mass[v];
    const float shareA = mass > 0.0f ? m.mass[u] / mass : 0.5f;
    a.mergedShare[t] = shareA;
    m.force[u] = shareA * total;
    m.force[v] = (1.0f - shareA) * total;
    return;
  }
  const int f = t - a.mergedCount;
  if (f < a.fixedCount) {
    m.force[a.fixedVertex[f]] = make_float3(0, 0, 0);
    return;
  }
  const int k = f - a.fixedCount;
  if (k < a.attachedCount) m.force[a.attachedVertex[k]] = make_float3(0, 0, 0);
}

__device__ __forceinline__ void place(float3* at, int u, int v, float wa, float wb, float3 offset) {
  const float3 centre = wa * at[u] + wb * at[v];
  at[u] = centre - wb * offset;
  at[v] = centre + wa * offset;
}

__global__ void projectMergedAndFixed(MeshView m, AttachmentDevice a) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t < a.mergedCount) {
    const float wa = a.mergedShare[t], wb = 1.0f - wa;
    place(m.x, a.mergedA[t], a.mergedB[t], wa, wb, a.mergedOffset[t]);
    place(m.prev, a.mergedA[t], a.mergedB[t], wa, wb, a.mergedOffset[t]);
    return;
  }
  const int f = t - a.mergedCount;
  if (f < a.fixedCount) m.x[a.fixedVertex[f]] = m.prev[a.fixedVertex[f]] = a.fixedAt[f];
}

__device__ __forceinline__ void attach(const MeshView& m, const AttachmentDevice& a, int k) {
  float3 on = a.attachedOffset[k], before = a.attachedOffset[k];
  for (int i = a.attachedOffsets[k]; i < a.attachedOffsets[k + 1]; ++i) {
    on = on + a.attachedWeight[i] * m.x[a.attachedSource[i]];
    before = before + a.attachedWeight[i] * m.prev[a.attachedSource[i]];
  }
  m.x[a.attachedVertex[k]] = on;
  m.prev[a.attachedVertex[k]] = before;
}

__global__ void projectAttached(MeshView m, AttachmentDevice a) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < a.attachedCount) attach(m, a, k);
}

// Some attached vertex follows another: in the scene's order, as the CPU.
__global__ void projectAttachedInOrder(MeshView m, AttachmentDevice a) {
  for (int k = 0; k < a.attachedCount; ++k) attach(m, a, k);
}
}  // namespace

void launchAttachmentShare(const MeshView& m, const AttachmentDevice& a, cudaStream_t s) {
  const int n = a.mergedCount + a.fixedCount + a.attachedCount;
  if (n > 0) share<<<(n + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, a);
}

void launchAttachmentProject(const MeshView& m, const AttachmentDevice& a, cudaStream_t s) {
  const int n = a.mergedCount + a.fixedCount;
  if (n > 0) projectMergedAndFixed<<<(n + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, a);
  if (a.attachedCount == 0) return;
  if (a.attachedInOrder) projectAttachedInOrder<<<1, 1, 0, s>>>(m, a);
  else projectAttached<<<(a.attachedCount + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, a);
}

}  // namespace sinew::cuda
