// Forces and the integrator on the device, one thread per vertex, each a line-for-line mirror of
// its CPU plugin (plugins/forces/*, plugins/integrators/damped_verlet).
#include "device_math.cuh"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;
unsigned blocks(int n) { return (n + kThreads - 1) / kThreads; }

// Per-vertex force terms; each returns what its CPU plugin adds to forces[v] (alpha included).
__device__ __forceinline__ float3 smoothingTerm(const MeshView& m, const ParamView& p, int kElevation, int v,
                                                float alpha) {
  const int mesh = m.meshOf[v];
  const int3 n = m.neighbours[v];
  const float a0 = m.area[n.x], a1 = m.area[n.y], a2 = m.area[n.z];
  const float total = a0 + a1 + a2;
  const float3 x0 = m.x[n.x], x1 = m.x[n.y], x2 = m.x[n.z];
  const float3 centre = total > 0.0f ? (a0 * x0 + a1 * x1 + a2 * x2) / total : (x0 + x1 + x2) / 3.0f;
  const float lift = param(p, mesh, kElevation) * (m.elevation[n.x] + m.elevation[n.y] + m.elevation[n.z]) / 3.0f;
  return alpha * (centre + lift * m.normal[v] - m.x[v]);
}

__device__ __forceinline__ float3 shapePriorTerm(const MeshView& m, const float4* __restrict__ ref, int v, float alpha) {
  const int3 n = m.neighbours[v];
  const float3 p1 = m.x[n.x], p2 = m.x[n.y], p3 = m.x[n.z], x = m.x[v];
  const Frame f = neighbourFrame(p1, p2, p3);
  const float4 r = ref[v];
  const float eps3 = 1.0f - r.x - r.y;
  const float3 foot = r.x * p1 + r.y * p2 + eps3 * p3;
  float3 target = foot;
  if (f.twiceArea > 0.0f) {
    const float d2 = squaredNorm(foot - f.centre);
    target = foot + elevationFromSinCos(f.radius, d2, r.z, r.w, dot(x - p1, f.normal)) * f.normal;
  }
  return alpha * (target - x);
}

__device__ __forceinline__ float3 gradientTerm(const MeshView& m, const ParamView& p, int kEps, int kDepth, int kStep,
                                               const VolumeView& vol, const float3* __restrict__ grad, int v,
                                               float alpha) {
  const int mesh = m.meshOf[v];
  const float eps = param(p, mesh, kEps), step = param(p, mesh, kStep);
  const int reach = static_cast<int>(floorf(param(p, mesh, kDepth) / step));
  const float3 n = m.normal[v], x = m.x[v];
  float best = 3.402823466e+38f;
  int bestJ = 0;
  for (int j = -reach; j <= reach; ++j) {
    const float e = eps * dot(sampleVolume(vol, grad, x + (static_cast<float>(j) * step) * n), n);
    if (e < best || (e == best && abs(j) < abs(bestJ))) {
      best = e;
      bestJ = j;
    }
  }
  return (alpha * (static_cast<float>(bestJ) * step)) * n;
}

__global__ void smoothing(MeshView m, ParamView p, int kElevation) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const float alpha = param(p, m.meshOf[v], 0);
  if (alpha > 0.0f) m.force[v] = m.force[v] + smoothingTerm(m, p, kElevation, v, alpha);
}

__global__ void shapePrior(MeshView m, ParamView p, const float4* __restrict__ ref) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const float alpha = param(p, m.meshOf[v], 0);
  if (alpha > 0.0f) m.force[v] = m.force[v] + shapePriorTerm(m, ref, v, alpha);
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
template <bool kWithGradient>
__global__ void __launch_bounds__(kThreads, kWithGradient ? 0 : 5) fusedForces(MeshView m, FusedTerms t) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const int mesh = m.meshOf[v];
  float3 f = make_float3(0, 0, 0);
  for (int i = 0; i < t.count; ++i) {
    const FusedTerm& term = t.terms[i];
    const float alpha = param(term.params, mesh, 0);
    if (!(alpha > 0.0f)) continue;
    switch (term.kind) {
      case FusedTerm::Smoothing: f = f + smoothingTerm(m, term.params, term.k0, v, alpha); break;
      case FusedTerm::ShapePrior: f = f + shapePriorTerm(m, t.reference, v, alpha); break;
      case FusedTerm::Gradient:
        if constexpr (kWithGradient)
          f = f + gradientTerm(m, term.params, term.k0, term.k1, term.k2, t.gradientVolume, t.gradient, v, alpha);
        break;
    }
  }
  m.force[v] = f;
}

// The target image as quads for the profile force: quad (i, j, k) holds the voxels (i, j), (i+1, j),
// (i, j+1) and (i+1, j+1) of slice k, border voxels repeated (as Volume::sample extends them), so a
// trilinear sample takes two 16-byte loads instead of eight scattered ones, with the same values
// interpolated in the same order as sampleVolume.
__global__ void volumeQuads(const float* __restrict__ image, VolumeView v, float4* __restrict__ quads) {
  const size_t index = static_cast<size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  const size_t row = static_cast<size_t>(v.sx), slice = row * v.sy;
  if (index >= slice * v.sz) return;
  const int i = static_cast<int>(index % row), j = static_cast<int>((index / row) % v.sy);
  const size_t dx = i + 1 < v.sx ? 1 : 0, dy = j + 1 < v.sy ? row : 0;
  quads[index] = make_float4(image[index], image[index + dx], image[index + dy], image[index + dy + dx]);
}

__device__ __forceinline__ float sampleQuads(const VolumeView& v, const float4* __restrict__ quads, float3 p) {
  const VolumeCell c = cellAt(v, p);
  const float4 a = quads[(static_cast<size_t>(c.i0[2]) * v.sy + c.i0[1]) * v.sx + c.i0[0]];
  const float4 b = quads[(static_cast<size_t>(c.i1[2]) * v.sy + c.i0[1]) * v.sx + c.i0[0]];
  const float c00 = lerp(a.x, a.y, c.f[0]), c10 = lerp(a.z, a.w, c.f[0]);
  const float c01 = lerp(b.x, b.y, c.f[0]), c11 = lerp(b.z, b.w, c.f[0]);
  return lerp(lerp(c00, c10, c.f[1]), lerp(c01, c11, c.f[1]), c.f[2]);
}

// Intensity profiles, one warp per vertex (paper 000 section 6.2 suggests parallelising the m
// search positions): the lanes sample the search line into shared memory together, then each lane
// scores some offsets; a warp reduction keeps the CPU's choice (highest NCC, then smallest |j|, then
// the lower j).
constexpr int kLineCapacity = 128;

__device__ __forceinline__ bool better(float a, int ja, float b, int jb) {
  return a > b || (a == b && (abs(ja) < abs(jb) || (abs(ja) == abs(jb) && ja < jb)));
}
// The CPU plugin's reach (samples searched each way) and window score, in its operation order.
__device__ __forceinline__ int profileReach(const ParamView& p, int mesh, int kDepth, float spacing) {
  return static_cast<int>(floorf(param(p, mesh, kDepth) / spacing));
}
__device__ __forceinline__ float windowNcc(float sum, float sum2, float dotp, int length) {
  const float var = sum2 - sum * sum / static_cast<float>(length);
  return var > 1e-12f ? dotp / sqrtf(var) : -1.0f;
}

__global__ void profileWarp(MeshView m, ParamView p, int kDepth, VolumeView vol, const float4* __restrict__ quads,
                            const float* __restrict__ profiles, int inside, int length, float spacing) {
  __shared__ float lines[8][kLineCapacity];
  const int warp = threadIdx.x / 32, lane = threadIdx.x % 32;
  const int v = blockIdx.x * (blockDim.x / 32) + warp;
  if (v >= m.vertices) return;  // the whole warp leaves together
  const int mesh = m.meshOf[v];
  const float alpha = param(p, mesh, 0);
  if (!(alpha > 0.0f)) return;
  const float* ref = profiles + static_cast<size_t>(v) * length;
  const int reach = profileReach(p, mesh, kDepth, spacing);
  const float3 n = m.normal[v], x = m.x[v];
  const int lineLength = length + 2 * reach;
  auto sampleAt = [&](int q) {
    const float offset = (static_cast<float>(q - inside) + 0.5f) * spacing;
    return sampleQuads(vol, quads, x + (offset - static_cast<float>(reach) * spacing) * n);
  };
  float* line = lines[warp];
  const bool cached = lineLength <= kLineCapacity;
  if (cached)
    for (int q = lane; q < lineLength; q += 32) line[q] = sampleAt(q);
  __syncwarp();
  float best = -2.0f;
  int bestJ = 0;
  for (int jj = lane; jj <= 2 * reach; jj += 32) {
    float sum = 0.0f, sum2 = 0.0f, dotp = 0.0f;
    for (int k = 0; k < length; ++k) {
      const float w = cached ? line[jj + k] : sampleAt(jj + k);
      sum += w;
      sum2 += w * w;
      dotp += w * ref[k];
    }
    const float ncc = windowNcc(sum, sum2, dotp, length);
    const int j = jj - reach;
    if (better(ncc, j, best, bestJ)) {
      best = ncc;
      bestJ = j;
    }
  }
  for (int offset = 16; offset > 0; offset /= 2) {
    const float otherBest = __shfl_down_sync(0xffffffffu, best, offset);
    const int otherJ = __shfl_down_sync(0xffffffffu, bestJ, offset);
    if (better(otherBest, otherJ, best, bestJ)) {
      best = otherBest;
      bestJ = otherJ;
    }
  }
  if (lane == 0) m.force[v] = m.force[v] + (alpha * (static_cast<float>(bestJ) * spacing)) * n;
}

// Intensity profiles for the default layout (kLength samples per profile, reach <= kMaxReach). A warp
// takes 32 / kLanes vertices, kLanes lanes each. It first samples its vertices' search lines into
// shared memory, every (vertex, slot) pair in turn on consecutive lanes, so that neighbouring lanes
// read neighbouring voxels and several samples are in flight per lane. Then each lane scores every
// kLanes-th window of its vertex from registers, and the vertex's lanes agree on the best by a
// shuffle reduction (the CPU's choice: highest NCC, then smallest |j|, then the lower j). Slot s of a
// line lies where the CPU's sample q = s - (kMaxReach - reach) does, so the window and slot indices
// are compile-time constants whatever the vertex's reach. Same float operations in the same order as
// the CPU plugin: bit-identical. kLanes trades parallelism (small scenes) for fewer shared-memory
// reads (large ones).
template <int kLength, int kMaxReach, int kLanes>
__global__ void __launch_bounds__(128) profileLanes(MeshView m, ParamView p, int kDepth, VolumeView vol,
                                                    const float4* __restrict__ quads,
                                                    const float* __restrict__ profiles, int inside, float spacing) {
  constexpr int kLine = kLength + 2 * kMaxReach, kPerWarp = 32 / kLanes;
  constexpr int kWindows = 2 * kMaxReach + 1, kTurns = (kWindows + kLanes - 1) / kLanes;
  constexpr int kLocal = kLanes * (kTurns - 1) + kLength;  // the slots one lane's windows cover
  __shared__ float lines[4][kLine * kPerWarp];
  __shared__ float refs[4][kPerWarp * kLength];
  __shared__ float3 starts[4][kPerWarp], normals[4][kPerWarp];
  __shared__ int reaches[4][kPerWarp];
  const int warp = threadIdx.x / 32, lane = threadIdx.x % 32, mine = lane / kLanes, part = lane % kLanes;
  const int first = (blockIdx.x * 4 + warp) * kPerWarp, v = first + mine;
  if (first >= m.vertices) return;  // the whole warp leaves together
  const int count = min(kPerWarp, m.vertices - first);
  // The warp's reference profiles, read once and coalesced.
  for (int i = lane; i < count * kLength; i += 32) refs[warp][i] = profiles[static_cast<size_t>(first) * kLength + i];
  int reach = -1;  // -1: nothing to do for this vertex
  float3 n = make_float3(0, 0, 0);
  if (v < m.vertices) {
    const int mesh = m.meshOf[v];
    if (param(p, mesh, 0) > 0.0f) {
      reach = profileReach(p, mesh, kDepth, spacing);  // <= kMaxReach (the launch checks)
      n = m.normal[v];
    }
  }
  if (part == 0 && mine < count) {
    reaches[warp][mine] = reach;
    normals[warp][mine] = n;
    if (reach >= 0) starts[warp][mine] = m.x[v];
  }
  __syncwarp();
#pragma unroll 4
  for (int item = lane; item < count * kLine; item += 32) {
    const int i = item / kLine, slot = item - i * kLine, r = reaches[warp][i];
    const int q = slot - (kMaxReach - r);  // the CPU's sample index
    if (r < 0 || q < 0 || q >= kLength + 2 * r) continue;
    const float offset = (static_cast<float>(q - inside) + 0.5f) * spacing;
    lines[warp][slot * kPerWarp + i] =
        sampleQuads(vol, quads, starts[warp][i] + (offset - static_cast<float>(r) * spacing) * normals[warp][i]);
  }
  __syncwarp();
  float best = -2.0f;
  int bestJ = 0;
  if (reach >= 0) {
    float local[kLocal], ref[kLength];
#pragma unroll
    for (int u = 0; u < kLocal; ++u) local[u] = part + u < kLine ? lines[warp][(part + u) * kPerWarp + mine] : 0.0f;
#pragma unroll
    for (int k = 0; k < kLength; ++k) ref[k] = refs[warp][mine * kLength + k];
#pragma unroll
    for (int t = 0; t < kTurns; ++t) {
      const int j = part + kLanes * t - kMaxReach;
      if (j < -reach || j > reach) continue;
      float sum = 0.0f, sum2 = 0.0f, dotp = 0.0f;
#pragma unroll
      for (int k = 0; k < kLength; ++k) {
        const float w = local[kLanes * t + k];
        sum += w;
        sum2 += w * w;
        dotp += w * ref[k];
      }
      const float ncc = windowNcc(sum, sum2, dotp, kLength);
      if (better(ncc, j, best, bestJ)) {
        best = ncc;
        bestJ = j;
      }
    }
  }
#pragma unroll
  for (int offset = kLanes / 2; offset > 0; offset /= 2) {
    const float otherBest = __shfl_xor_sync(0xffffffffu, best, offset);
    const int otherJ = __shfl_xor_sync(0xffffffffu, bestJ, offset);
    if (better(otherBest, otherJ, best, bestJ)) {
      best = otherBest;
      bestJ = otherJ;
    }
  }
  if (reach >= 0 && part == 0)
    m.force[v] = m.force[v] + (param(p, m.meshOf[v], 0) * (static_cast<float>(bestJ) * spacing)) * n;
}

// The layout the register kernels are built for: the default 25 + 5 samples, up to 10 each way.
constexpr int kRegisterLength = 30, kRegisterReach = 10;

template <int kLanes>
void launchProfileLanes(const MeshView& m, ParamView p, int kDepth, VolumeView vol, const float4* quads,
                        const float* profiles, int inside, float spacing, cudaStream_t s) {
  constexpr int perBlock = 4 * (32 / kLanes);
  profileLanes<kRegisterLength, kRegisterReach, kLanes><<<(m.vertices + perBlock - 1) / perBlock, 128, 0, s>>>(m, p, kDepth, vol, quads,
                                                                                    profiles, inside, spacing);
}

__global__ void verlet(MeshView m, float dt, float keep) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const float3 current = m.x[v];
  m.x[v] = current + keep * (current - m.prev[v]) + (dt * dt / m.mass[v]) * m.force[v];
  m.prev[v] = current;
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
void launchVolumeQuads(const float* image, VolumeView v, float4* quads, cudaStream_t s) {
  const size_t voxels = static_cast<size_t>(v.sx) * v.sy * v.sz;
  volumeQuads<<<static_cast<unsigned>((voxels + kThreads - 1) / kThreads), kThreads, 0, s>>>(image, v, quads);
}
void launchProfile(const MeshView& m, ParamView p, int kDepth, VolumeView vol, const float4* quads,
                   const float* profiles, int inside, int outside, float spacing, int maxReach, cudaStream_t s) {
  if (inside + outside == kRegisterLength && maxReach <= kRegisterReach) {
    // Lanes per vertex by size, measured on an H100 (docs/benchmarks.md): parallelism for small
    // scenes, fewer shared-memory reads for large ones.
    if (m.vertices < 8192) launchProfileLanes<8>(m, p, kDepth, vol, quads, profiles, inside, spacing, s);
    else if (m.vertices < 131072) launchProfileLanes<4>(m, p, kDepth, vol, quads, profiles, inside, spacing, s);
    else launchProfileLanes<2>(m, p, kDepth, vol, quads, profiles, inside, spacing, s);
    return;
  }
  constexpr int warps = 8;  // lines[8][...] in the kernel
  profileWarp<<<(m.vertices + warps - 1) / warps, warps * 32, 0, s>>>(m, p, kDepth, vol, quads, profiles, inside,
                                                                     inside + outside, spacing);
}
void launchFusedForces(const MeshView& m, const FusedTerms& t, cudaStream_t s) {
  bool gradient = false;
  for (int i = 0; i < t.count; ++i) gradient = gradient || t.terms[i].kind == FusedTerm::Gradient;
  if (gradient) fusedForces<true><<<blocks(m.vertices), kThreads, 0, s>>>(m, t);
  else fusedForces<false><<<blocks(m.vertices), kThreads, 0, s>>>(m, t);
}
void launchVerlet(const MeshView& m, float dt, float keep, cudaStream_t s) {
  verlet<<<blocks(m.vertices), kThreads, 0, s>>>(m, dt, keep);
}
void launchProlong(const int* rows, const int* index, const float* weight, int count, const float3* coarse,
                   float3* fine, cudaStream_t s) {
  prolong<<<blocks(count), kThreads, 0, s>>>(rows, index, weight, count, coarse, fine);
}

}  // namespace sinew::cuda
