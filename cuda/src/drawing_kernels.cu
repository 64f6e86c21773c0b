// Drawing straight from the device store (the workstation's CUDA-OpenGL interop path): the
// tessellation's points written into a vertex buffer, and slice contours as segments.
#include "device_math.cuh"

namespace sinew::cuda {

namespace {
__device__ float3 cellCentreOf(const float3* x, const int* offsets, const int* cellVertices, int c) {
  float3 sum = make_float3(0, 0, 0);
  const int begin = offsets[c], end = offsets[c + 1];
  for (int i = begin; i < end; ++i) sum = sum + x[cellVertices[i]];
  return (1.0f / float(end - begin)) * sum;
}

__global__ void surfacePoints(DrawRange r, const float3* x, const int* offsets, const int* cellVertices, float* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const int vertices = r.vertexEnd - r.vertexBegin, cells = r.cellEnd - r.cellBegin;
  if (i >= vertices + cells) return;
  const float3 p = i < vertices ? x[r.vertexBegin + i] : cellCentreOf(x, offsets, cellVertices, r.cellBegin + i - vertices);
  out[3 * i] = p.x;
  out[3 * i + 1] = p.y;
  out[3 * i + 2] = p.z;
}

__device__ float3 crossing(float3 p, float dp, float3 q, float dq) { return p + (dp / (dp - dq)) * (q - p); }

// One thread per cell of every structure; the same case analysis as the host's hostContour().
// Structure m's segments go to its own region, which starts at segmentBase[m] (its first triangle:
// a plane crosses each triangle at most once) and holds segmentBase[m + 1] - segmentBase[m].
__global__ void contour(int cells, const float3* x, const int* offsets, const int* cellVertices, const int* meshOf,
                        float3 n, float d, const int* segmentBase, float3* out, int* counts) {
  const int c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= cells) return;
  const float3 centre = cellCentreOf(x, offsets, cellVertices, c);
  const float dc = dot(n, centre) - d;
  const int begin = offsets[c], end = offsets[c + 1];
  const int mesh = meshOf[cellVertices[begin]];
  const int base = segmentBase[mesh], capacity = segmentBase[mesh + 1] - base;
  for (int i = begin; i < end; ++i) {
    const float3 a = x[cellVertices[i]], b = x[cellVertices[i + 1 == end ? begin : i + 1]];
    const float da = dot(n, a) - d, db = dot(n, b) - d;
    const bool sa = da >= 0, sb = db >= 0, sc = dc >= 0;
    if (sa == sb && sb == sc) continue;
    float3 p, q;
    if (sa == sb) p = crossing(b, db, centre, dc), q = crossing(centre, dc, a, da);
    else if (sb == sc) p = crossing(a, da, b, db), q = crossing(centre, dc, a, da);
    else p = crossing(a, da, b, db), q = crossing(b, db, centre, dc);
    const int slot = atomicAdd(&counts[mesh], 1);
    if (slot < capacity) {
      out[2 * (base + slot)] = p;
      out[2 * (base + slot) + 1] = q;
    }
  }
}
}  // namespace

void launchSurfacePoints(const DrawRange& r, const float3* x, const int* offsets, const int* cellVertices, float* out,
                         cudaStream_t s) {
  const int n = (r.vertexEnd - r.vertexBegin) + (r.cellEnd - r.cellBegin);
  if (n > 0) surfacePoints<<<(n + 255) / 256, 256, 0, s>>>(r, x, offsets, cellVertices, out);
}

void launchContour(int cells, const float3* x, const int* offsets, const int* cellVertices, const int* meshOf,
                   float3 n, float d, const int* segmentBase, float3* out, int* counts, cudaStream_t s) {
  if (cells > 0) contour<<<(cells + 127) / 128, 128, 0, s>>>(cells, x, offsets, cellVertices, meshOf, n, d, segmentBase, out, counts);
}

}  // namespace sinew::cuda
