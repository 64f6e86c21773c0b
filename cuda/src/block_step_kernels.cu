// The lean step in one pass (launchStepInBlocks, kernels.h): the geometry, smoothing, the shape
// prior and the damped Verlet move, per block of kStepBlock consecutive vertices. The separate
// passes (cellCentres, vertexGeometry, fusedForces) each go through memory; here a block copies
// what it needs into shared memory once (its own vertices' arrays, its connectivity as indices into
// its own shared arrays, its neighbours' positions) and keeps the cell centres, areas and
// elevations there. Every value comes from the expressions those passes use (mesh_geometry.cuh,
// force_terms.cuh), in the same order; this file alone is compiled with fused multiply-add
// (cuda/CMakeLists.txt), so its results are the CPU's within a tolerance (tst_cuda_parity).
#include "force_terms.cuh"
#include "mesh_geometry.cuh"

#include <cuda_pipeline.h>

#include <stdexcept>

namespace sinew::cuda {

namespace {

__device__ __forceinline__ int slotPart(int packed) { return packed & 0xffff; }
__device__ __forceinline__ int cellPart(int packed) { return packed >> 16; }

// The terms' sum is fusedSum's (every weight read first, the terms in the scene's order, no
// gradient term), the force kept and the move written aside as fusedForces<false, true, true> does.
//
// Everything a block reads from memory is requested at once, before the first barrier, as
// asynchronous copies into shared memory (cp.async): a copy in flight holds no register, where a
// load in flight holds its destination until it arrives. Contiguous arrays go in 16-byte pieces.
// Nsight Compute then finds the kernel bound by its instructions (80 % of the SMs' issue), hence
// the fused multiply-adds. Held to 48 registers, 5 blocks an SM (80 bytes spilled). On an H100
// (2026-11-27, case (b) at 2,719,744 vertices, us a step; docs/benchmarks.md): loads into
// registers 153.1; these copies a word at a time 147.7 (6 blocks an SM, 40 registers: 159.2); with
// fused multiply-adds 141.6; in 16-byte pieces 133.1-134.6 (4 blocks an SM, 56 registers and no
// spill: 146.0).
constexpr int kBlocksPerSM = 5;

// n 4-byte words from global to shared memory, a word a thread at a time (coalesced).
__device__ __forceinline__ void copyWords(void* to, const void* from, int n) {
  for (int k = threadIdx.x; k < n; k += kStepBlock)
    __pipeline_memcpy_async(static_cast<unsigned*>(to) + k, static_cast<const unsigned*>(from) + k, 4);
}
// The 16-byte span of global memory that holds [from, from + bytes), to shared memory at `to`
// (16-byte aligned), a piece a thread at a time: `from` lands spanShift(from) bytes after `to`.
__device__ __forceinline__ int spanShift(const void* from) { return int(reinterpret_cast<unsigned long long>(from) & 15); }
__device__ __forceinline__ void copySpan(void* to, const void* from, int bytes) {
  const long long a = static_cast<long long>(reinterpret_cast<unsigned long long>(from)), base = a & ~15ll;
  const int pieces = spanCopyWords(a, bytes) / 4;
  for (int k = threadIdx.x; k < pieces; k += kStepBlock)
    __pipeline_memcpy_async(static_cast<float4*>(to) + k, reinterpret_cast<const float4*>(base) + k, 16);
}

__global__ void __launch_bounds__(kStepBlock, kBlocksPerSM) stepInBlocks(MeshView m, StepBlocks b, FusedTerms t, VerletMove move) {
  extern __shared__ float4 shared[];
  float* const words = reinterpret_cast<float*>(shared);
  const StepBlockLayout& l = b.layout;
  float4* const reference = shared;
  float3* const pos = reinterpret_cast<float3*>(words + l.pos);
  float3* const centre = reinterpret_cast<float3*>(words + l.centre);
  float* const previousWords = words + l.previous;
  float* const area = words + l.area;
  float* const elevation = words + l.elevation;
  int* const meshes = reinterpret_cast<int*>(words + l.mesh);
  const int4 at = b.start[blockIdx.x], end = b.start[blockIdx.x + 1];
  const int first = blockIdx.x * kStepBlock, count = min(kStepBlock, m.vertices - first);
  const int halo = end.x - at.x, geometries = end.y - at.y, cells = end.z - at.z;
  const int i = threadIdx.x, v = first + i;
  const bool mine = i < count;
  // The first of this thread's neighbours' indices, requested before the copies that need none.
  const int outside = i < halo ? b.vertices[at.x + i] : 0;
  // A full block's own entries are whole 16-byte pieces (the arrays' allocations start on 256
  // bytes); the last block's are copied word by word, so that nothing past the arrays is read.
  if (count == kStepBlock && (spanShift(m.x) | spanShift(m.prev) | spanShift(m.meshOf)) == 0) {
    copySpan(pos, m.x + first, kStepBlock * 12);
    copySpan(previousWords, m.prev + first, kStepBlock * 12);
    copySpan(meshes, m.meshOf + first, kStepBlock * 4);
  } else {
    copyWords(pos, m.x + first, 3 * count);
    copyWords(previousWords, m.prev + first, 3 * count);
    copyWords(meshes, m.meshOf + first, count);
  }
  if (t.reference && mine) __pipeline_memcpy_async(reference + i, t.reference + v, 16);
  // The connectivity as the 16-byte spans that hold it (the arrays have 16 bytes more at their end).
  copySpan(words + l.geometry, b.geometry + at.y, 12 * geometries);
  copySpan(words + l.cellEnd, b.cellEnd + at.z, 2 * cells);
  copySpan(words + l.cellSlots, b.cellSlots + at.w, 2 * (end.w - at.w));
  for (int k = i; k < halo; k += kStepBlock) {  // the neighbours' positions, by index
    const float* from = reinterpret_cast<const float*>(m.x + (k == i ? outside : b.vertices[at.x + k]));
    float* to = reinterpret_cast<float*>(pos + count + k);
#pragma unroll
    for (int c = 0; c < 3; ++c) __pipeline_memcpy_async(to + c, from + c, 4);
  }
  __pipeline_commit();
  __pipeline_wait_prior(0);
  __syncthreads();
  // Where each span's first entry landed.
  const int* const geometry = reinterpret_cast<const int*>(words + l.geometry) + spanShift(b.geometry + at.y) / 4;
  const unsigned short* cellEnd = reinterpret_cast<const unsigned short*>(words + l.cellEnd) + spanShift(b.cellEnd + at.z) / 2;
  const unsigned short* cellSlots =
      reinterpret_cast<const unsigned short*>(words + l.cellSlots) + spanShift(b.cellSlots + at.w) / 2;
  // The cells' centres, each vertex added in the cell's order (centreAt's sum).
  for (int c = i; c < cells; c += kStepBlock) {
    const int from = c == 0 ? 0 : cellEnd[c - 1], to = cellEnd[c];
    float3 sum = make_float3(0, 0, 0);
    for (int k = from; k < to; ++k) sum = sum + pos[cellSlots[k]];
    centre[c] = sum / static_cast<float>(to - from);
  }
  __syncthreads();
  for (int g = i; g < geometries; g += kStepBlock) {
    const int3 packed = make_int3(geometry[3 * g], geometry[3 * g + 1], geometry[3 * g + 2]);
    const float3 p = pos[g], q[3] = {pos[slotPart(packed.x)], pos[slotPart(packed.y)], pos[slotPart(packed.z)]};
    const float3 c[3] = {centre[cellPart(packed.x)], centre[cellPart(packed.y)], centre[cellPart(packed.z)]};
    elevation[g] = vertexElevation(p, q, neighbourNormal(q[0], q[1], q[2]));
    area[g] = vertexArea(p, q, c);
  }
  __syncthreads();
  if (!mine) return;
  const int mesh = meshes[i];
  const int slot[3] = {slotPart(geometry[3 * i]), slotPart(geometry[3 * i + 1]), slotPart(geometry[3 * i + 2])};
  const float3 x = pos[i], q[3] = {pos[slot[0]], pos[slot[1]], pos[slot[2]]};
  constexpr int kMaxTerms = sizeof(t.terms) / sizeof(t.terms[0]);
  float weight[kMaxTerms];
#pragma unroll
  for (int k = 0; k < kMaxTerms; ++k) weight[k] = k < t.count ? param(t.terms[k].params, mesh, 0) : 0.0f;
  float3 f = make_float3(0, 0, 0);
#pragma unroll
  for (int k = 0; k < kMaxTerms; ++k) {
    if (!(weight[k] > 0.0f)) continue;
    const FusedTerm& term = t.terms[k];
    if (term.kind == FusedTerm::Smoothing) {
      const float a[3] = {area[slot[0]], area[slot[1]], area[slot[2]]};
      const float e[3] = {elevation[slot[0]], elevation[slot[1]], elevation[slot[2]]};
      f = f + smoothingFrom(x, neighbourNormal(q[0], q[1], q[2]), q, a, e, param(term.params, mesh, term.k0), weight[k]);
    } else {  // the shape prior (the lean geometry has no gradient term)
      f = f + shapePriorFrom(x, q[0], q[1], q[2], t.reference ? reference[i] : float4{}, weight[k]);
    }
  }
  if (m.force) m.force[v] = f;
  const float mass = massFromArea(m, mesh, area[i]);
  const float3 previous = make_float3(previousWords[3 * i], previousWords[3 * i + 1], previousWords[3 * i + 2]);
  m.prev[v] = verletStep(x, previous, f, move.dt, move.keep, mass);  // verletMoveAside
}

}  // namespace

void launchStepInBlocks(const MeshView& m, const StepBlocks& blocks, const FusedTerms& t, const VerletMove& move,
                        cudaStream_t s) {
  // The kernel has no gradient term's image search: such a term would be left out without a word.
  if (hasGradientTerm(t)) throw std::logic_error("launchStepInBlocks: a gradient term needs the separate passes");
  // Nor does it add another pass's term (FusedTerms::plus): no caller has one (case (a) keeps the
  // separate passes), so the kernel leaves it out rather than carry an untested path.
  if (t.plus) throw std::logic_error("launchStepInBlocks: another pass's term needs the separate passes");
  const unsigned grid = (m.vertices + kStepBlock - 1) / kStepBlock;
  stepInBlocks<<<grid, kStepBlock, 4 * blocks.layout.words, s>>>(m, blocks, t, move);
}

}  // namespace sinew::cuda
