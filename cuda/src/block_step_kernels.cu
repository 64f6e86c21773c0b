// The lean step in one pass (launchStepInBlocks, kernels.h): the geometry, smoothing, the shape
// prior and the damped Verlet move, per block of kStepBlock consecutive vertices. The separate
// passes (cellCentres, vertexGeometry, fusedForces) each go through memory; here a block reads the
// positions it needs once, with its connectivity as indices into its own shared arrays, and keeps
// the cell centres, areas and elevations in shared memory. Every value comes from the expressions
// those passes use (mesh_geometry.cuh, force_terms.cuh), in the same order: the same bits.
#include "force_terms.cuh"
#include "mesh_geometry.cuh"

#include <stdexcept>

namespace sinew::cuda {

namespace {

__device__ __forceinline__ int slotPart(int packed) { return packed & 0xffff; }
__device__ __forceinline__ int cellPart(int packed) { return packed >> 16; }

// The terms' sum is fusedSum's (every weight read first, the terms in the scene's order, no
// gradient term), the force kept and the move written aside as fusedForces<false, true, true> does.
// Held to 48 registers, 5 blocks an SM (60 bytes spilled). Each thread's first cell and geometry
// entries are requested before the positions' barrier, so that the next phases wait on shared
// memory only. On an H100 (2026-11-27, case (b) at 2,719,744 vertices, us a step; docs/benchmarks.md):
// - without those early requests: 64 registers and 4 blocks 173.5-174.3, 48 and 5 167.1-168.9 (the
//   separate passes 181.2-182.8); 320 threads for 256 vertices 176.6, blocks of 128 vertices 175.7,
//   128 vertices with 160 threads 184.2;
// - with them 152.9-153.2; with the terms' weights requested early too, 169.9-170.0.
constexpr int kBlocksPerSM = 5;
__global__ void __launch_bounds__(kStepBlock, kBlocksPerSM) stepInBlocks(MeshView m, StepBlocks b, FusedTerms t, VerletMove move) {
  extern __shared__ float shared[];
  const int4 at = b.start[blockIdx.x], end = b.start[blockIdx.x + 1];
  const int first = blockIdx.x * kStepBlock, count = min(kStepBlock, m.vertices - first);
  const int positions = count + end.x - at.x, geometries = end.y - at.y, cells = end.z - at.z;
  float3* pos = reinterpret_cast<float3*>(shared);
  float3* centre = pos + positions;
  float* area = reinterpret_cast<float*>(centre + cells);
  float* elevation = area + geometries;
  const int i = threadIdx.x, v = first + i;
  const bool mine = i < count;
  // What the vertex's own terms and move read, in flight while the block gathers its positions.
  int mesh = 0;
  float3 previous{};
  float4 reference{};
  if (mine) {
    pos[i] = m.x[v];
    mesh = m.meshOf[v];
    previous = m.prev[v];
    if (t.reference) reference = t.reference[v];
  }
  // This thread's first cell and geometry entries, which do not wait for the positions.
  constexpr int kEarly = 8;
  int early[kEarly];
  int cellFrom = 0, cellTo = 0;
  if (i < cells) cellFrom = i == 0 ? 0 : b.cellEnd[at.z + i - 1], cellTo = b.cellEnd[at.z + i];
#pragma unroll
  for (int k = 0; k < kEarly; ++k) early[k] = cellFrom + k < cellTo ? b.cellSlots[at.w + cellFrom + k] : 0;
  const int3 firstGeometry = i < geometries ? b.geometry[at.y + i] : int3{};
  for (int k = i; k < positions - count; k += kStepBlock) pos[count + k] = m.x[b.vertices[at.x + k]];
  __syncthreads();
  // The cells' centres, each vertex added in the cell's order (centreAt's sum).
  for (int c = i; c < cells; c += kStepBlock) {
    const int from = c == i ? cellFrom : b.cellEnd[at.z + c - 1], to = c == i ? cellTo : b.cellEnd[at.z + c];
    float3 sum = make_float3(0, 0, 0);
    if (c == i) {
#pragma unroll
      for (int k = 0; k < kEarly; ++k)
        if (from + k < to) sum = sum + pos[early[k]];
      for (int k = from + kEarly; k < to; ++k) sum = sum + pos[b.cellSlots[at.w + k]];
    } else {
      for (int k = from; k < to; ++k) sum = sum + pos[b.cellSlots[at.w + k]];
    }
    centre[c] = sum / static_cast<float>(to - from);
  }
  __syncthreads();
  int3 mineAt{};  // the vertex's own neighbours and cells, kept for its terms
  for (int g = i; g < geometries; g += kStepBlock) {
    const int3 packed = g == i ? firstGeometry : b.geometry[at.y + g];
    if (g == i) mineAt = packed;
    const float3 p = pos[g], q[3] = {pos[slotPart(packed.x)], pos[slotPart(packed.y)], pos[slotPart(packed.z)]};
    const float3 c[3] = {centre[cellPart(packed.x)], centre[cellPart(packed.y)], centre[cellPart(packed.z)]};
    elevation[g] = vertexElevation(p, q, neighbourNormal(q[0], q[1], q[2]));
    area[g] = vertexArea(p, q, c);
  }
  __syncthreads();
  if (!mine) return;
  const int slot[3] = {slotPart(mineAt.x), slotPart(mineAt.y), slotPart(mineAt.z)};
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
      f = f + shapePriorFrom(x, q[0], q[1], q[2], reference, weight[k]);
    }
  }
  // No caller passes a term of another pass yet (case (a) keeps the separate passes), but the
  // kernel honours FusedTerms::plus as fusedForces does. Without this line the compiler spilled 80
  // bytes instead of 60 and the step took 160.6 us instead of 153.1 at 2.7 M (H100, 2026-11-27).
  if (t.plus) f = f + t.plus[v];
  if (m.force) m.force[v] = f;
  const float mass = massFromArea(m, mesh, area[i]);
  m.prev[v] = verletStep(x, previous, f, move.dt, move.keep, mass);  // verletMoveAside
}

}  // namespace

void launchStepInBlocks(const MeshView& m, const StepBlocks& blocks, const FusedTerms& t, const VerletMove& move,
                        cudaStream_t s) {
  // The kernel has no gradient term's image search: such a term would be left out without a word.
  if (hasGradientTerm(t)) throw std::logic_error("launchStepInBlocks: a gradient term needs the separate passes");
  const unsigned grid = (m.vertices + kStepBlock - 1) / kStepBlock;
  stepInBlocks<<<grid, kStepBlock, blocks.sharedBytes, s>>>(m, blocks, t, move);
}

}  // namespace sinew::cuda
