// Geometry refresh on the device: cell centres, then per vertex normal, elevation, area and mass
// (mirrors MeshStore::refreshCurrent).
#include "mesh_geometry.cuh"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;

__device__ __forceinline__ int pick(const int3& v, int k) { return k == 0 ? v.x : (k == 1 ? v.y : v.z); }

__global__ void cellCentres(MeshView m) {
  const int c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= m.cells) return;
  m.cellCentre[c] = centreOf(m, c);
}

// The centre of v's cell j as v computes it, written back when v is the cell's first vertex, so
// that later kernels of the step find every centre, each written once. spans: null, or the
// vertices' cell spans (launchGeometry), read instead of the cell's offsets: the cell's vertices
// are then one dependent load from v instead of two (H100, smoothing + shape prior at 2,656 /
// 42,496 vertices 7.50 -> 7.33 / 10.07 -> 9.80-9.87 us a step).
__device__ __forceinline__ float3 ownCentre(const MeshView& m, const int4* __restrict__ spans, int j, int v) {
  const int c = pick(m.vertexCells[v], j);
  int b, e;
  if (spans) {
    const int4 s = spans[v];
    b = pick(make_int3(s.x, s.y, s.z), j);
    e = b + ((s.w >> (kCellSpanBits * j)) & ((1 << kCellSpanBits) - 1));
  } else {
    b = m.cellOffsets[c];
    e = m.cellOffsets[c + 1];
  }
  const float3 centre = centreAt(m, b, e);
  if (m.cellVertices[b] == v) m.cellCentre[c] = centre;
  return centre;
}
// Vertex v's normal and elevation from its neighbours q (when required).
__device__ __forceinline__ void storeFrame(const MeshView& m, int v, float3 p, const float3 (&q)[3]) {
  // neighbourNormal: the expression the lean geometry's pass uses for the normals it computes itself.
  const float3 normal = neighbourNormal(q[0], q[1], q[2]);
  if (m.normal) m.normal[v] = normal;
  if (m.elevation) m.elevation[v] = vertexElevation(p, q, normal);
}
// Vertex v's area (the Fig. 1b triangles with its neighbours q and its cells' centres) and mass.
__device__ __forceinline__ void storeAreaAndMass(const MeshView& m, int v, float3 p, const float3 (&q)[3],
                                                 const float3 (&centre)[3]) {
  const float a = vertexArea(p, q, centre);
  m.area[v] = a;
  if (m.mass) m.mass[v] = massFromArea(m, m.meshOf[v], a);
}

// kOwnCentres: each vertex computes its three cells' centres itself (the same sums as
// cellCentres) instead of reading them from the pass before (ownCentre). One launch fewer, for
// scenes small enough that launches, not memory, set the step's time (launchGeometry).
template <bool kOwnCentres>
__global__ void vertexGeometry(MeshView m, const int4* __restrict__ spans) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const int3 n = m.neighbours[v];
  const float3 p = m.x[v], q[3] = {m.x[n.x], m.x[n.y], m.x[n.z]};
  storeFrame(m, v, p, q);
  if (m.area) {
    float3 centre[3];
#pragma unroll
    for (int j = 0; j < 3; ++j)
      centre[j] = kOwnCentres ? ownCentre(m, spans, j, v) : m.cellCentre[pick(m.vertexCells[v], j)];
    storeAreaAndMass(m, v, p, q, centre);
  }
}

// The smallest scenes: four lanes a vertex, lanes 0-2 each computing one of its cells' centres
// (and writing it as vertexGeometry<true> does), lane 0 then the rest from the three centres in
// vertexGeometry's order (the same values). The centres' loads, the chain that sets these launches'
// time, run side by side (H200, smoothing + shape prior at 2,656 / 10,624 vertices 8.7 -> 7.6-7.7 /
// 8.8 -> 8.2 us a step; at 42,496 11.0-11.1 against 10.2: there the threads outnumber the work).
__global__ void vertexGeometryLanes(MeshView m, const int4* __restrict__ spans) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  const int v = t / 4, part = t % 4;
  const bool real = v < m.vertices;  // every lane takes part in the shuffles below
  float3 p{}, q[3]{};
  if (real && part == 0) {  // in flight beside the centres
    const int3 n = m.neighbours[v];
    p = m.x[v], q[0] = m.x[n.x], q[1] = m.x[n.y], q[2] = m.x[n.z];
  }
  const float3 mine = real && part < 3 ? ownCentre(m, spans, part, v) : make_float3(0, 0, 0);
  float3 centre[3];
#pragma unroll
  for (int j = 0; j < 3; ++j) {
    const int from = (threadIdx.x % 32 & ~3) + j;
    centre[j] = make_float3(__shfl_sync(0xffffffffu, mine.x, from), __shfl_sync(0xffffffffu, mine.y, from),
                            __shfl_sync(0xffffffffu, mine.z, from));
  }
  if (!real || part != 0) return;
  storeFrame(m, v, p, q);
  storeAreaAndMass(m, v, p, q, centre);
}
constexpr int kLanesBelow = 16384;

// vertexGeometry<true>'s blocks: 64 threads spread its few warps over every SM (at 42,496 vertices
// 664 blocks instead of 166 on 132 SMs; H100, case (a) 20.30-20.41 -> 19.65-19.80 us a step, 128
// threads 19.86-20.02; docs/benchmarks.md).
constexpr unsigned kOwnCentresThreads = 64;

// Below this many vertices the centres are computed inside vertexGeometry: H100, 2026-11-24,
// smoothing + shape prior per step 11.3 against 12.2 us at 42,496 vertices, equal at 169,984, and
// 296 against 273 us at 2.7 M, where recomputing each centre three times costs more than its pass.
constexpr int kOwnCentresBelow = 131072;
}  // namespace

bool geometryReadsCellSpans(int vertices) { return vertices < kOwnCentresBelow; }

void launchGeometry(const MeshView& m, const int4* cellSpans, cudaStream_t s) {
  const unsigned vertexBlocks = (m.vertices + kThreads - 1) / kThreads;
  if (m.area && m.cellCentre && m.vertices < kLanesBelow) {
    vertexGeometryLanes<<<(4 * m.vertices + kThreads - 1) / kThreads, kThreads, 0, s>>>(m, cellSpans);
    return;
  }
  if (m.area && m.cellCentre && m.vertices < kOwnCentresBelow) {
    vertexGeometry<true><<<(m.vertices + kOwnCentresThreads - 1) / kOwnCentresThreads, kOwnCentresThreads, 0, s>>>(
        m, cellSpans);
    return;
  }
  if (m.cellCentre) cellCentres<<<(m.cells + kThreads - 1) / kThreads, kThreads, 0, s>>>(m);
  if (m.normal || m.elevation || m.area) vertexGeometry<false><<<vertexBlocks, kThreads, 0, s>>>(m, nullptr);
}

}  // namespace sinew::cuda
