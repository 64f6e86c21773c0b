// The radial force's kernels (plugins/forces/radial mirrored; device_radial.h lays out the data).
// A relaxation is one kernel: a block per chunk of a medial vertex's voters recomputes their springs
// from the previous medial positions (Jacobi, as the CPU force) and sums their reactions by a fixed
// tree; the last of a medial vertex's chunks to finish sums the chunks' sums by the same tree and
// moves it. Large medial vertices (a sphere's centre takes every vertex's vote) are spread over many
// blocks, and the sums do not depend on which block ends last, so runs repeat exactly.
#include "device_math.cuh"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;
static_assert(kRadialChunk == kThreads, "one voter per thread");

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

__device__ __forceinline__ float4 add4(float4 a, float4 b) { return make_float4(a.x + b.x, a.y + b.y, a.z + b.z, a.w + b.w); }

// The block's values summed by a fixed tree (shuffles within warps, then the warps in order); the
// result is in thread 0.
__device__ __forceinline__ float4 blockSum(float4 s, float4* warpSums) {
  for (int offset = 16; offset > 0; offset /= 2)
    s = add4(s, make_float4(__shfl_down_sync(0xffffffffu, s.x, offset), __shfl_down_sync(0xffffffffu, s.y, offset),
                            __shfl_down_sync(0xffffffffu, s.z, offset), __shfl_down_sync(0xffffffffu, s.w, offset)));
  __syncthreads();  // warpSums free (a previous sum read it)
  if (threadIdx.x % 32 == 0) warpSums[threadIdx.x / 32] = s;
  __syncthreads();
  if (threadIdx.x == 0)
    for (int w = 1; w < int(kThreads / 32); ++w) s = add4(s, warpSums[w]);
  return s;
}

__global__ void relax(MeshView m, ParamView p, RadialDevice r, const float3* __restrict__ qIn, float3* __restrict__ qOut) {
  __shared__ float4 warpSums[kThreads / 32];
  __shared__ bool last;
  const int c = blockIdx.x, j = r.chunkRow[c];
  const int first = r.rowChunks[j], chunks = r.rowChunks[j + 1] - first;
  const bool active = param(p, r.medialMesh[j], 0) > 0.0f;
  float4 s = make_float4(0, 0, 0, 0);
  const int e = r.chunkBegin[c] + int(threadIdx.x);
  if (active && e < r.chunkBegin[c + 1]) {
    const int i = r.medialVertex[e];
    const float wm = r.medialWeight[e] * m.mass[i];
    const float3 g = spring(foot(r, qIn, i) - m.x[i], r.radius[i]);
    s = make_float4(-wm * g.x, -wm * g.y, -wm * g.z, wm);
  }
  s = blockSum(s, warpSums);
  if (chunks > 1) {
    // Several chunks: the last to finish sums the chunks' sums, in chunk order by the same tree.
    if (threadIdx.x == 0) {
      r.partial[c] = s;
      __threadfence();  // the sum is visible before the arrival is counted
      last = atomicAdd(&r.arrivals[j], 1u) == unsigned(chunks - 1);
    }
    __syncthreads();
    if (!last) return;
    float4 t = make_float4(0, 0, 0, 0);
    for (int k = int(threadIdx.x); k < chunks; k += kThreads) t = add4(t, __ldcg(&r.partial[first + k]));
    s = blockSum(t, warpSums);
    if (threadIdx.x == 0) r.arrivals[j] = 0u;  // for the next relaxation (a later kernel)
  }
  if (threadIdx.x != 0) return;
  const float3 reaction = make_float3(s.x, s.y, s.z);
  qOut[j] = active && s.w > 0.0f ? qIn[j] + reaction / s.w : qIn[j];
}

__global__ void apply(MeshView m, ParamView p, RadialDevice r, const float3* __restrict__ q, float3* __restrict__ home,
                      float* pull, float* slack, float3* direction) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (home && t < r.medialCount) home[t] = q[t];
  if (t >= m.vertices) return;
  if (pull) pull[t] = 0.0f;
  const float alpha = param(p, m.meshOf[t], 0);
  if (!(alpha > 0.0f)) return;
  const float3 toFoot = foot(r, q, t) - m.x[t];
  const float d = norm(toFoot);
  if (!(d > 1e-6f)) return;
  const float k = alpha * m.mass[t];
  m.force[t] = m.force[t] + k * spring(toFoot, r.radius[t]);
  if (!pull) return;
  // The CPU force's Jacobian block, with the medial points held over the step.
  pull[t] = k;
  slack[t] = fmaxf(0.0f, 1.0f - r.radius[t] / d);
  direction[t] = toFoot / d;
}
}  // namespace

void launchRadialVotes(const MeshView& m, const RadialDevice& r, const int* fresh, float3* q, cudaStream_t s) {
  if (r.medialCount > 0) votes<<<(r.medialCount + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, r, fresh, q);
}
void launchRadialRelax(const MeshView& m, ParamView p, const RadialDevice& r, const float3* qIn, float3* qOut,
                       cudaStream_t s) {
  if (r.chunkCount > 0) relax<<<r.chunkCount, kThreads, 0, s>>>(m, p, r, qIn, qOut);
}
void launchRadialApply(const MeshView& m, ParamView p, const RadialDevice& r, const float3* q, float3* home,
                       float* pull, float* slack, float3* direction, cudaStream_t s) {
  const int n = home && r.medialCount > m.vertices ? r.medialCount : m.vertices;
  apply<<<(n + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, p, r, q, home, pull, slack, direction);
}

}  // namespace sinew::cuda
