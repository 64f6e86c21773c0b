// The intensity-profile force on the device (plugins/forces/intensity_profile: paper 000 section
// 3.2.2). Each vertex samples a line along its normal in the target image and pulls toward the
// window whose normalised cross-correlation (NCC) with its trained profile is highest.
//
// Not bit-identical to the CPU plugin (issue 15 made parity a tolerance): the image is a 3D texture
// of 16-bit values mapped to [0, 1] (device_image.h; the NCC does not change under an affine change
// of intensities), sampled by the texture units' trilinear filter (8-bit interpolation weights: a
// sample differs from the exact trilinear value by up to 1/512 of its cell's range); the window dot
// products use fused multiply-add, and the window sums slide in double instead of being summed
// again. About one vertex in 500 then picks another offset than the CPU in a step, almost always
// one sample away (tst_cuda_parity states the tolerance; docs/benchmarks.md). Run to run the kernels
// repeat themselves exactly.
#include "contact_planes.h"
#include "force_terms.cuh"

#include <cstdlib>

namespace sinew::cuda {

namespace {

// The CPU's choice: highest NCC, then smallest |j|, then the lower j.
__device__ __forceinline__ bool better(float a, int ja, float b, int jb) {
  return a > b || (a == b && (abs(ja) < abs(jb) || (abs(ja) == abs(jb) && ja < jb)));
}
// The CPU plugin's reach (samples searched each way).
__device__ __forceinline__ int profileReach(const ParamView& p, int mesh, int kDepth, float spacing) {
  return static_cast<int>(floorf(param(p, mesh, kDepth) / spacing));
}
// A window's NCC from its sums (ref has zero mean and unit norm); inverseLength: 1 / its samples.
__device__ __forceinline__ float ncc(double sum, double sum2, float dot, double inverseLength) {
  const float var = static_cast<float>(sum2 - sum * sum * inverseLength);
  return var > 1e-12f ? dot * rsqrtf(var) : -1.0f;
}

// A search line in texture coordinates (voxel i's centre at i + 0.5): sample s at start + s * step.
struct Line {
  float3 start, step;
};
// The line whose sample s lies (s + first) spacings along the normal n from x.
__device__ __forceinline__ Line searchLine(const VolumeView& v, float3 x, float3 n, float first, float spacing) {
  const float3 q = x - v.origin;
  const float3 c = make_float3(v.m[0] * q.x + v.m[1] * q.y + v.m[2] * q.z + 0.5f, v.m[3] * q.x + v.m[4] * q.y + v.m[5] * q.z + 0.5f,
                               v.m[6] * q.x + v.m[7] * q.y + v.m[8] * q.z + 0.5f);
  const float3 d = spacing * make_float3(v.m[0] * n.x + v.m[1] * n.y + v.m[2] * n.z, v.m[3] * n.x + v.m[4] * n.y + v.m[5] * n.z,
                                         v.m[6] * n.x + v.m[7] * n.y + v.m[8] * n.z);
  return {make_float3(fmaf(first, d.x, c.x), fmaf(first, d.y, c.y), fmaf(first, d.z, c.z)), d};
}
// Border voxels extend outside (the texture clamps), as Volume::sample does.
__device__ __forceinline__ float sampleLine(cudaTextureObject_t image, const Line& l, float s) {
  return tex3D<float>(image, fmaf(s, l.step.x, l.start.x), fmaf(s, l.step.y, l.start.y), fmaf(s, l.step.z, l.start.z));
}

// Scores kCount consecutive windows of w (window c covers w[c .. c + kLength - 1]; its offset is
// jFirst + c samples) against ref and keeps the best within the reach. The window sums slide in
// double (exact enough that a flat window's variance stays at its rounding, not at the slide's).
template <int kLength, int kCount, class Ref>
__device__ __forceinline__ void scoreWindows(const float (&w)[kCount + kLength - 1], const Ref& ref, int jFirst, int reach,
                                             float& best, int& bestJ) {
  float dot[kCount];
#pragma unroll
  for (int c = 0; c < kCount; ++c) dot[c] = 0.0f;
#pragma unroll
  for (int k = 0; k < kLength; ++k) {
    const float r = ref(k);
#pragma unroll
    for (int c = 0; c < kCount; ++c) dot[c] = fmaf(w[c + k], r, dot[c]);
  }
  double sum = 0.0, sum2 = 0.0;
#pragma unroll
  for (int k = 0; k < kLength; ++k) {
    sum += w[k];
    sum2 = fma(double(w[k]), double(w[k]), sum2);
  }
#pragma unroll
  for (int c = 0; c < kCount; ++c) {
    if (c > 0) {
      const double in = w[c + kLength - 1], out = w[c - 1];
      sum += in - out;
      sum2 = fma(in, in, fma(-out, out, sum2));
    }
    const int j = jFirst + c;
    if (j < -reach || j > reach) continue;
    const float score = ncc(sum, sum2, dot[c], 1.0 / kLength);
    if (better(score, j, best, bestJ)) {
      best = score;
      bestJ = j;
    }
  }
}

// The default layout (kLength samples, reach <= kMaxReach). A warp takes 32 / kLanes vertices,
// kLanes lanes each. Slot s of a line lies (s - kMaxReach - inside + 0.5) spacings along the normal
// whatever the vertex's reach, so slot and window indices are compile-time constants. A vertex's
// lanes sample its line into shared memory, each every kLanes-th slot (no index arithmetic but the
// texture coordinates); then each lane scores a run of consecutive windows from registers, and the
// vertex's lanes agree on the best by a shuffle reduction. kLanes trades parallelism (small scenes)
// for fewer shared-memory reads and registers per vertex (large ones). With `integrate`, the
// vertex's first lane then moves it by damped Verlet (the step's force complete): a vertex's
// position is read and written by its own lanes only, so the move needs no pass of its own.
// kWithTerms: the fused terms are summed here instead of read from m.force, and the move is
// verletMoveAside (launchProfileAfterTerms), so the pass writes no position another vertex reads:
// it can also add the collision's contact planes after the profile (kPlanes), and hold the vertex
// (planes.heldPrevious not null). So can the pass of the term alone (termFirst, launchProfileFirst),
// which writes no position either; its hold planes go to planes.hold. Two lanes a vertex are held
// to 6 blocks an SM (80 registers): at 7 (72) the kernel with the terms spilled 40 bytes (H200,
// case (a): 42,496 vertices 21.6 -> 20.9-21.1 us a step, 2,719,744 vertices 699-702 -> 681-682).
template <int kLength, int kMaxReach, int kLanes, bool kWithTerms, bool kPlanes>
__global__ void __launch_bounds__(128, kLanes == 1 ? 0 : kLanes == 2 ? 6 : 8) profileLanes(MeshView m, ParamView p, int kDepth, VolumeView vol,
                                                    cudaTextureObject_t image, const float* __restrict__ profiles,
                                                    int inside, float spacing, bool integrate, VerletMove move,
                                                    FusedTerms terms, bool termFirst, ContactPlanes planes) {
  constexpr int kLine = kLength + 2 * kMaxReach, kPerWarp = 32 / kLanes, kWindows = 2 * kMaxReach + 1;
  constexpr int kTurns = (kWindows + kLanes - 1) / kLanes;  // windows per lane
  constexpr int kLocal = kTurns + kLength - 1;               // the slots one lane's windows cover
  constexpr int kRow = kLine | 1, kRefRow = kLength | 1;     // odd strides: no bank conflicts
  __shared__ float lines[4][kPerWarp * kRow];
  __shared__ float refs[4][kPerWarp * kRefRow];
  const int warp = threadIdx.x / 32, lane = threadIdx.x % 32, mine = lane / kLanes, part = lane % kLanes;
  const int first = (blockIdx.x * 4 + warp) * kPerWarp, v = first + mine;
  if (first >= m.vertices) return;  // the whole warp leaves together
  const int count = min(kPerWarp, m.vertices - first);
  // The warp's reference profiles: each vertex's read by consecutive lanes, all in flight at once,
  // and stored to shared memory only after the line's fetches are issued, so that the two wait
  // together (H100, case (a): 42,496 vertices 20.29-20.40 -> 20.03-20.24 us a step, 2,719,744
  // vertices 725-728 -> 712-713; docs/benchmarks.md).
  static_assert(kLength <= 32, "a lane per sample of a reference profile");
  float refIn[kPerWarp];
#pragma unroll
  for (int r = 0; r < kPerWarp; ++r)
    refIn[r] = lane < kLength && r < count ? profiles[static_cast<size_t>(first + r) * kLength + lane] : 0.0f;
  int reach = -1;  // -1: nothing to do for this vertex
  float3 n = make_float3(0, 0, 0), at = n;
  bool touching = false;  // a contact plane to add, and the reaction's flag (read here, off the pass's last stretch)
  unsigned pushed = 0;
  if (v < m.vertices) {
    if constexpr (kPlanes) {
      touching = hasContactPlane(planes, v);
      if (planes.reaction) pushed = reactionPushed(planes.reaction, v);
    }
    // Loaded before the weight is known, beside the structure's index: one round trip fewer before
    // the line's fetches (H200, case (a): 2,656 vertices 9.50 -> 9.18-9.29 us a step, 2,719,744
    // vertices 699-702 -> 680-686).
    n = m.normal[v];
    at = m.x[v];
    const int mesh = m.meshOf[v];
    if (param(p, mesh, 0) > 0.0f) reach = profileReach(p, mesh, kDepth, spacing);  // <= kMaxReach (the launch checks)
  }
  if (reach >= 0) {
    // This lane's slots part, part + kLanes, ...: unrolled, every fetch in flight at once.
    const Line path = searchLine(vol, at, n, static_cast<float>(part - kMaxReach - inside) + 0.5f, spacing);
    float* line = &lines[warp][mine * kRow + part];
#pragma unroll
    for (int k = 0; k < (kLine + kLanes - 1) / kLanes; ++k)
      if (kLine % kLanes == 0 || part + kLanes * k < kLine) line[kLanes * k] = sampleLine(image, path, float(kLanes * k));
  }
#pragma unroll
  for (int r = 0; r < kPerWarp; ++r)
    if (lane < kLength && r < count) refs[warp][r * kRefRow + lane] = refIn[r];
  __syncwarp();
  float best = -2.0f;
  int bestJ = 0;
  if (reach >= 0) {
    const int start = part * kTurns;
    float w[kLocal];
#pragma unroll
    for (int u = 0; u < kLocal; ++u) w[u] = start + u < kLine ? lines[warp][mine * kRow + start + u] : 0.0f;
    const float* ref = &refs[warp][mine * kRefRow];
    scoreWindows<kLength, kTurns>(w, [&](int k) { return ref[k]; }, start - kMaxReach, reach, best, bestJ);
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
  if (part != 0 || v >= m.vertices || (reach < 0 && !integrate && !kWithTerms && !termFirst)) return;
  float3 f;
  if constexpr (kWithTerms) f = fusedSum<false, false>(m, terms, v);
  else f = termFirst ? make_float3(0, 0, 0) : m.force[v];
  if (reach >= 0) f = f + (param(p, m.meshOf[v], 0) * (static_cast<float>(bestJ) * spacing)) * n;
  collision::HoldPlane hold;
  if constexpr (kPlanes) f = f + contactPlaneForce(m, planes, v, touching, hold, pushed);  // reads x, not written here
  if (reach >= 0 || kWithTerms || termFirst) m.force[v] = f;
  if constexpr (kWithTerms) {
    if (kPlanes && planes.heldPrevious) {  // verletMoveAside and the hold (launchCollisionMove's arithmetic)
      const float3 current = m.x[v], next = verletStep(current, m.prev[v], f, move.dt, move.keep, m.mass[v]);
      collision::P3 p{next.x, next.y, next.z}, q{current.x, current.y, current.z};
      collision::holdOut(hold, p, q, collision::holdLimit(planes.settings, m.area, v));
      m.prev[v] = make_float3(p.x, p.y, p.z);
      planes.heldPrevious[v] = make_float3(q.x, q.y, q.z);
    } else {
      verletMoveAside(m, v, f, move.dt, move.keep);
    }
  } else if (integrate) {
    verletMove(m, v, f, move.dt, move.keep);
  }
}

// Any other layout: one warp per vertex; the lanes sample the search line into shared memory
// together, then each lane scores some windows (kLineCapacity samples at most per line, sampled
// again per window beyond that).
constexpr int kLineCapacity = 128;

__global__ void profileWarp(MeshView m, ParamView p, int kDepth, VolumeView vol, cudaTextureObject_t image,
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
  const float3 n = m.normal[v];
  const Line path = searchLine(vol, m.x[v], n, static_cast<float>(-reach - inside) + 0.5f, spacing);
  const int lineLength = length + 2 * reach;
  float* line = lines[warp];
  const bool cached = lineLength <= kLineCapacity;
  if (cached)
    for (int q = lane; q < lineLength; q += 32) line[q] = sampleLine(image, path, static_cast<float>(q));
  __syncwarp();
  float best = -2.0f;
  int bestJ = 0;
  const double inverseLength = 1.0 / length;
  for (int jj = lane; jj <= 2 * reach; jj += 32) {
    double sum = 0.0, sum2 = 0.0;
    float dot = 0.0f;
    for (int k = 0; k < length; ++k) {
      const float w = cached ? line[jj + k] : sampleLine(image, path, static_cast<float>(jj + k));
      sum += w;
      sum2 = fma(double(w), double(w), sum2);
      dot = fmaf(w, ref[k], dot);
    }
    const float score = ncc(sum, sum2, dot, inverseLength);
    const int j = jj - reach;
    if (better(score, j, best, bestJ)) {
      best = score;
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

// The layout the register kernels are built for: the default 25 + 5 samples, up to 10 each way.
constexpr int kRegisterLength = 30, kRegisterReach = 10;
bool registerLayout(int inside, int outside, int maxReach) {
  return inside + outside == kRegisterLength && maxReach <= kRegisterReach;
}

// terms: when not null, the kWithTerms kernel (then must not be null). first: the term is written
// alone (launchProfileFirst).
template <int kMaxReach, int kLanes>
void launchProfileLanes(const MeshView& m, ParamView p, int kDepth, VolumeView vol, cudaTextureObject_t image,
                        const float* profiles, int inside, float spacing, const VerletMove* then, const FusedTerms* terms,
                        bool first, const ContactPlanes* planes, cudaStream_t s) {
  constexpr int perBlock = 4 * (32 / kLanes);
  const unsigned grid = (m.vertices + perBlock - 1) / perBlock;
  // The planes' path compiled in only where there are planes: in every pass it cost case (a) 0.3-1.2 %
  // (H200, 42,496-2,719,744 vertices, beside b4731ca's bench_cuda).
  const bool withPlanes = planes && planes->contact && (terms || first);
  const ContactPlanes c = withPlanes ? *planes : ContactPlanes{};
  if (terms && withPlanes)
    profileLanes<kRegisterLength, kMaxReach, kLanes, true, true>
        <<<grid, 128, 0, s>>>(m, p, kDepth, vol, image, profiles, inside, spacing, true, *then, *terms, false, c);
  else if (terms)
    profileLanes<kRegisterLength, kMaxReach, kLanes, true, false>
        <<<grid, 128, 0, s>>>(m, p, kDepth, vol, image, profiles, inside, spacing, true, *then, *terms, false, c);
  else if (withPlanes)
    profileLanes<kRegisterLength, kMaxReach, kLanes, false, true><<<grid, 128, 0, s>>>(
        m, p, kDepth, vol, image, profiles, inside, spacing, false, VerletMove{}, FusedTerms{}, true, c);
  else
    profileLanes<kRegisterLength, kMaxReach, kLanes, false, false><<<grid, 128, 0, s>>>(
        m, p, kDepth, vol, image, profiles, inside, spacing, then != nullptr, then ? *then : VerletMove{}, FusedTerms{},
        first, c);
}
// The kernel for the scene's largest reach, rounded up to an even number of samples: a line is
// sampled and scored for that reach, whatever a vertex's own.
template <int kLanes>
void launchForReach(int maxReach, const MeshView& m, ParamView p, int kDepth, VolumeView vol, cudaTextureObject_t image,
                    const float* profiles, int inside, float spacing, const VerletMove* then, const FusedTerms* terms,
                    bool first, const ContactPlanes* planes, cudaStream_t s) {
  if (maxReach <= 2) launchProfileLanes<2, kLanes>(m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s);
  else if (maxReach <= 4) launchProfileLanes<4, kLanes>(m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s);
  else if (maxReach <= 6) launchProfileLanes<6, kLanes>(m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s);
  else if (maxReach <= 8) launchProfileLanes<8, kLanes>(m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s);
  else launchProfileLanes<10, kLanes>(m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s);
}

// Lanes per vertex by scene size, measured with bench_cuda case (a) (docs/benchmarks.md): on an H100
// (2026-11-25) 8 were best up to 10,624 vertices, 4 at 42,496, 2 from 169,984 up; on an H200 with the
// terms and the move in the pass (2026-11-26) 8 / 4 / 2 / 1 lanes took 11.74 / 11.90-11.97 /
// 13.36-13.43 / 16.04-16.26 us at 10,624 vertices and 26.99 / 22.97-23.01 / 21.91-22.14 / 24.91 us
// at 42,496: 2 from 32,768 (between the two, unmeasured, the larger count's side was chosen).
// SINEW_PROFILE_LANES (1, 2, 4 or 8) fixes it, for such sweeps.
int lanesFor(int vertices) {
  static const int fixed = [] {
    const char* e = std::getenv("SINEW_PROFILE_LANES");
    return e ? std::atoi(e) : 0;
  }();
  if (fixed == 1 || fixed == 2 || fixed == 4 || fixed == 8) return fixed;
  return vertices < 16384 ? 8 : vertices < 32768 ? 4 : 2;
}

void launchRegisterKernel(const MeshView& m, ParamView p, int kDepth, VolumeView vol, cudaTextureObject_t image,
                          const float* profiles, int inside, float spacing, int maxReach, const VerletMove* then,
                          const FusedTerms* terms, bool first, const ContactPlanes* planes, cudaStream_t s) {
  switch (lanesFor(m.vertices)) {
    case 1: launchForReach<1>(maxReach, m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s); break;
    case 2: launchForReach<2>(maxReach, m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s); break;
    case 4: launchForReach<4>(maxReach, m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s); break;
    default: launchForReach<8>(maxReach, m, p, kDepth, vol, image, profiles, inside, spacing, then, terms, first, planes, s); break;
  }
}

// From this many vertices the move leaves the profile's pass: into the terms' pass after it where
// the profile goes first (launchProfileFirst), else into a pass of its own (launchProfile).
constexpr int kSeparateMoveFrom = 131072;
}  // namespace

bool profileTakesTerms(int vertices, int inside, int outside, int maxReach) {
  return vertices < kSeparateMoveFrom && registerLayout(inside, outside, maxReach);
}

void launchProfileAfterTerms(const MeshView& m, const FusedTerms& terms, ParamView p, int kDepth, VolumeView vol,
                             cudaTextureObject_t image, const float* profiles, int inside, float spacing, int maxReach,
                             const VerletMove& move, const ContactPlanes* planes, cudaStream_t s) {
  launchRegisterKernel(m, p, kDepth, vol, image, profiles, inside, spacing, maxReach, &move, &terms, false, planes, s);
}

bool profileGoesFirst(int vertices, int inside, int outside, int maxReach) {
  return vertices >= kSeparateMoveFrom && registerLayout(inside, outside, maxReach);
}

void launchProfileFirst(const MeshView& m, ParamView p, int kDepth, VolumeView vol, cudaTextureObject_t image,
                        const float* profiles, int inside, float spacing, int maxReach, const ContactPlanes* planes,
                        cudaStream_t s) {
  launchRegisterKernel(m, p, kDepth, vol, image, profiles, inside, spacing, maxReach, nullptr, nullptr, true, planes, s);
}

void launchProfile(const MeshView& m, ParamView p, int kDepth, VolumeView vol, cudaTextureObject_t image,
                   const float* profiles, int inside, int outside, float spacing, int maxReach, const VerletMove* then,
                   cudaStream_t s) {
  // The move in the profile pass saves a launch, which is what small scenes pay for; from 131,072
  // vertices its scattered accesses (a vertex's first lane only) cost more than the separate,
  // coalesced pass (H200: 2,656 / 42,496 vertices 14.41 -> 12.96 / 24.44 -> 23.22 us a step,
  // 679,936 / 2.7 M 190.4 -> 193.8 / 686.6 -> 704.1).
  if (then && m.vertices >= kSeparateMoveFrom) {
    launchProfile(m, p, kDepth, vol, image, profiles, inside, outside, spacing, maxReach, nullptr, s);
    launchVerlet(m, then->dt, then->keep, s);
    return;
  }
  if (registerLayout(inside, outside, maxReach)) {
    launchRegisterKernel(m, p, kDepth, vol, image, profiles, inside, spacing, maxReach, then, nullptr, false, nullptr, s);
    return;
  }
  constexpr int warps = 8;  // lines[8][...] in the kernel
  profileWarp<<<(m.vertices + warps - 1) / warps, warps * 32, 0, s>>>(m, p, kDepth, vol, image, profiles, inside,
                                                                     inside + outside, spacing);
  if (then) launchVerlet(m, then->dt, then->keep, s);
}

}  // namespace sinew::cuda
