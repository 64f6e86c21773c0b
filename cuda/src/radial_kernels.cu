// The radial force's kernels (plugins/forces/radial mirrored; device_radial.h lays out the data).
// The medial relaxation runs one warp per medial vertex: its lanes share the surface vertices that
// vote for it, each recomputing that vertex's spring from the previous medial positions (Jacobi,
// as the CPU force), and a fixed shuffle tree sums them, so runs repeat exactly.
#include "device_math.cuh"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;
constexpr int kWarpsPerBlock = kThreads / 32;

// P_i_perp = sum_k w_ik Q_k.
__device__ __forceinline__ float3 foot(const RadialDevice& r, const float3* __restrict__ q, int v) {
  float3 f = make_float3(0, 0, 0);
  for (int k = r.surfaceOffsets[v]; k < r.surfaceOffsets[v + 1]; ++k) f = f + r.surfaceWeight[k] * q[r.surfaceMedial[k]];
  return f;
}

// g_i = (1 - r_i / d) (P_i_perp - x_i): the force per stiffness.
__device__ __forceinline__ float3 spring(float3 toFoot, float radius) {
  const float d = norm(toFoot);
  return d > 1e-6f ? (1.0f - radius / d) * toFoot : make_float3(0, 0, 0);
}

__global__ void votes(MeshView m, RadialDevice r, const int* fresh, float3* q) {
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= r.medialCount || !fresh[r.medialMesh[j]]) return;
  float3 sum = make_float3(0, 0, 0);
  float weights = 0.0f;
  for (int e = r.medialOffsets[j]; e < r.medialOffsets[j + 1]; ++e) {
    const int i = r.medialVertex[e];
    sum = sum + r.medialWeight[e] * (m.x[i] - r.radius[i] * m.normal[i]);
    weights += r.medialWeight[e];
  }
  if (weights > 0.0f) q[j] = sum / weights;  // else Q_j of the reference, uploaded before
}

__global__ void relax(MeshView m, ParamView p, RadialDevice r, const float3* __restrict__ qIn, float3* __restrict__ qOut) {
  const int j = blockIdx.x * kWarpsPerBlock + threadIdx.x / 32, lane = threadIdx.x % 32;
  if (j >= r.medialCount) return;  // the whole warp leaves together
  if (!(param(p, r.medialMesh[j], 0) > 0.0f)) {
    if (lane == 0) qOut[j] = qIn[j];
    return;
  }
  float3 reaction = make_float3(0, 0, 0);
  float stiffness = 0.0f;
  for (int e = r.medialOffsets[j] + lane; e < r.medialOffsets[j + 1]; e += 32) {
    const int i = r.medialVertex[e];
    const float wm = r.medialWeight[e] * m.mass[i];
    reaction = reaction - wm * spring(foot(r, qIn, i) - m.x[i], r.radius[i]);
    stiffness += wm;
  }
  for (int offset = 16; offset > 0; offset /= 2) {
    reaction.x += __shfl_down_sync(0xffffffffu, reaction.x, offset);
    reaction.y += __shfl_down_sync(0xffffffffu, reaction.y, offset);
    reaction.z += __shfl_down_sync(0xffffffffu, reaction.z, offset);
    stiffness += __shfl_down_sync(0xffffffffu, stiffness, offset);
  }
  if (lane == 0) qOut[j] = stiffness > 0.0f ? qIn[j] + reaction / stiffness : qIn[j];
}

__global__ void apply(MeshView m, ParamView p, RadialDevice r, const float3* __restrict__ q, float3* __restrict__ home) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (home && t < r.medialCount) home[t] = q[t];
  if (t >= m.vertices) return;
  const float alpha = param(p, m.meshOf[t], 0);
  if (!(alpha > 0.0f)) return;
  const float3 toFoot = foot(r, q, t) - m.x[t];
  if (!(norm(toFoot) > 1e-6f)) return;
  m.force[t] = m.force[t] + (alpha * m.mass[t]) * spring(toFoot, r.radius[t]);
}
}  // namespace

void launchRadialVotes(const MeshView& m, const RadialDevice& r, const int* fresh, float3* q, cudaStream_t s) {
  if (r.medialCount > 0) votes<<<(r.medialCount + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, r, fresh, q);
}
void launchRadialRelax(const MeshView& m, ParamView p, const RadialDevice& r, const float3* qIn, float3* qOut,
                       cudaStream_t s) {
  if (r.medialCount > 0)
    relax<<<(r.medialCount + kWarpsPerBlock - 1) / kWarpsPerBlock, kThreads, 0, s>>>(m, p, r, qIn, qOut);
}
void launchRadialApply(const MeshView& m, ParamView p, const RadialDevice& r, const float3* q, float3* home,
                       cudaStream_t s) {
  const int n = home && r.medialCount > m.vertices ? r.medialCount : m.vertices;
  apply<<<(n + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, p, r, q, home);
}

}  // namespace sinew::cuda
