// Forces and the integrator on the device, one thread per vertex, each a line-for-line mirror of
// its CPU plugin (plugins/forces/*, plugins/integrators/damped_verlet).
#include "force_terms.cuh"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;
unsigned blocks(int n) { return (n + kThreads - 1) / kThreads; }
// The fused pass's blocks: below 131,072 vertices 64 threads, so that its few warps spread over
// every SM (H100, smoothing + shape prior with the move at 2,656 / 10,624 / 42,496 vertices 7.05 /
// 7.48 / 9.31 -> 6.90-6.94 / 7.15-7.17 / 8.99-9.06 us a step; 128 threads between the two;
// docs/benchmarks.md). The kernel's register bound stays that of 256 threads.
constexpr int kSmallBlocksBelow = 131072;
unsigned fusedThreads(int n) { return n < kSmallBlocksBelow ? 64 : kThreads; }

__global__ void smoothing(MeshView m, ParamView p, int kElevation) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const float alpha = param(p, m.meshOf[v], 0);
  if (alpha > 0.0f) m.force[v] = m.force[v] + smoothingTerm(m, p, kElevation, v, m.neighbours[v], alpha);
}

__global__ void shapePrior(MeshView m, ParamView p, const float4* __restrict__ ref) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const float alpha = param(p, m.meshOf[v], 0);
  if (alpha > 0.0f) m.force[v] = m.force[v] + shapePriorTerm(m, ref, v, m.neighbours[v], alpha);
}

__global__ void gradient(MeshView m, ParamView p, int kEps, int kDepth, int kStep, VolumeView vol,
                         const float3* __restrict__ grad) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const float alpha = param(p, m.meshOf[v], 0);
  if (alpha > 0.0f) m.force[v] = m.force[v] + gradientTerm(m, p, kEps, kDepth, kStep, vol, grad, v, alpha);
}

// Every per-vertex force of the step in one pass, in the scene's order: one read of each array
// instead of one per kernel, and no separate zeroing. Sums are formed in the same order as force by
// force, so the result is bit-identical to the separate kernels (and to the CPU). Without a gradient
// term the kernel is compiled without its image search and held to 48 registers (5 blocks of 256 per
// SM, 8 bytes spilled): 4, 5, 6 and 8 blocks gave 282, 273, 278 and 325 us per step of smoothing +
// shape prior at 2.7 M vertices (H100, 2026-11-24; docs/benchmarks.md).
// kMove: the step's damped Verlet move in the same pass, written over prev (verletMoveAside), as
// the pass's other vertices still read x (launchFusedForcesAndMove); m.force may then be null (the
// forces are not kept). kOwnFrame: the lean geometry (m.normal and m.mass not stored): each vertex's
// normal comes from its neighbours and its mass from its area, the values the geometry pass writes.
template <bool kWithGradient, bool kMove, bool kOwnFrame = false>
__global__ void __launch_bounds__(kThreads, kWithGradient ? 0 : 5) fusedForces(MeshView m, FusedTerms t, VerletMove move) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  float3 f = fusedSum<kWithGradient, true, kOwnFrame>(m, t, v);
  if (t.plus) f = f + t.plus[v];
  if (!kMove || m.force) m.force[v] = f;
  if constexpr (kMove && kOwnFrame) verletMoveAside(m, v, f, move.dt, move.keep, massFromArea(m, m.meshOf[v], m.area[v]));
  else if constexpr (kMove) verletMoveAside(m, v, f, move.dt, move.keep);
}

__global__ void verlet(MeshView m, float dt, float keep) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  verletMove(m, v, m.force[v], dt, keep);
}

__global__ void prolong(const int* __restrict__ rows, const int* __restrict__ index, const float* __restrict__ weight,
                        int count, const float3* __restrict__ coarse, float3* __restrict__ fine) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  float3 sum = make_float3(0, 0, 0);
  for (int k = rows[i]; k < rows[i + 1]; ++k) sum = sum + weight[k] * coarse[index[k]];
  fine[i] = sum;
}
}  // namespace

void launchSmoothing(const MeshView& m, ParamView p, int kElevation, cudaStream_t s) {
  smoothing<<<blocks(m.vertices), kThreads, 0, s>>>(m, p, kElevation);
}
void launchShapePrior(const MeshView& m, ParamView p, const float4* ref, cudaStream_t s) {
  shapePrior<<<blocks(m.vertices), kThreads, 0, s>>>(m, p, ref);
}
void launchGradient(const MeshView& m, ParamView p, int kEps, int kDepth, int kStep, VolumeView vol,
                    const float3* grad, cudaStream_t s) {
  gradient<<<blocks(m.vertices), kThreads, 0, s>>>(m, p, kEps, kDepth, kStep, vol, grad);
}
void launchFusedForces(const MeshView& m, const FusedTerms& t, cudaStream_t s) {
  const unsigned threads = fusedThreads(m.vertices), grid = (m.vertices + threads - 1) / threads;
  if (hasGradientTerm(t)) fusedForces<true, false><<<grid, threads, 0, s>>>(m, t, VerletMove{});
  else fusedForces<false, false><<<grid, threads, 0, s>>>(m, t, VerletMove{});
}
void launchFusedForcesAndMove(const MeshView& m, const FusedTerms& t, const VerletMove& move, cudaStream_t s) {
  const unsigned threads = fusedThreads(m.vertices), grid = (m.vertices + threads - 1) / threads;
  if (hasGradientTerm(t)) fusedForces<true, true><<<grid, threads, 0, s>>>(m, t, move);
  else if (!m.mass) fusedForces<false, true, true><<<grid, threads, 0, s>>>(m, t, move);
  else fusedForces<false, true><<<grid, threads, 0, s>>>(m, t, move);
}
void launchVerlet(const MeshView& m, float dt, float keep, cudaStream_t s) {
  verlet<<<blocks(m.vertices), kThreads, 0, s>>>(m, dt, keep);
}
void launchProlong(const int* rows, const int* index, const float* weight, int count, const float3* coarse,
                   float3* fine, cudaStream_t s) {
  prolong<<<blocks(count), kThreads, 0, s>>>(rows, index, weight, count, coarse, fine);
}

}  // namespace sinew::cuda
