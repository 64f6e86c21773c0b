// bench_profile_fetch: the profile pass's image fetches alone (case (a) of bench_cuda: about 2.7 M
// vertices on 12 spheres in a 128^3 image of 16-bit values, 50 samples 0.5 voxel apart along each
// normal, two lanes a vertex), fetched several ways, to tell whether a sample's eight corners from
// one 16-byte fetch, interpolated in the SMs, cost Hopper less than the texture units' trilinear
// filter (docs/benchmarks.md, issue 15). Each kernel sums its samples per vertex; every 97th
// vertex's sum is compared with an exact one (double, the 16-bit values):
//   texture   tex3D<float> on the 16-bit image, trilinear in the texture units (what the pass does)
//   corners   a copy holding each voxel's 2 x 2 x 2 corners in 16 bytes (as halves, as 16-bit
//             integers, or as a 16-bit corner and half differences from it), by an unfiltered
//             texture fetch or a 16-byte load through L1, blended in halves or in floats
//   mixed     every n-th of a lane's samples from the corners (base and half differences, 16-byte
//             load), the rest from the texture: the texture units and the load-store pipe side by
//             side (faster alone; in the profile pass it was slower too: docs/benchmarks.md)
//   layers    a layered 2D texture whose texel holds a voxel and its neighbour one slice up (one
//             bilinear fetch, the slices blended in the SM), single slices fetched twice, or a 3D
//             texture of the pairs fetched at its layers' centres; the texture and the slice pairs
//             with the profile pass's registers and shared memory, in batches of fetches, and with
//             the vertices shuffled
//             (faster alone; in the pass it was slower: docs/benchmarks.md)
// Only the fetches: in the profile pass itself the fastest accurate variant was slower (the
// measurements are in docs/benchmarks.md).
//   bench_profile_fetch [REPEATS (default 20)]
#include <cuda_fp16.h>
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace {

#define CHECK(call)                                                                        \
  do {                                                                                     \
    const cudaError_t e = (call);                                                          \
    if (e != cudaSuccess) {                                                                \
      std::fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__, #call, cudaGetErrorString(e)); \
      std::exit(1);                                                                        \
    }                                                                                      \
  } while (0)

constexpr int kSize = 128, kSamples = 50, kLanes = 2;
constexpr float kSpacing = 0.5f, kFirst = -34.5f;  // 25 inside + 5 outside, reach 10 each way

struct Vertex {
  float3 x, n;
};

// A sample's texel-space position (voxel centres at integers).
__device__ __forceinline__ float3 position(const Vertex& v, float s) {
  const float t = (kFirst + s) * kSpacing;
  return make_float3(fmaf(t, v.n.x, v.x.x), fmaf(t, v.n.y, v.x.y), fmaf(t, v.n.z, v.x.z));
}

// The eight corners (x fastest) as four pairs of halves: (000, 100), (010, 110), (001, 101), (011, 111).
__device__ __forceinline__ float blend(uint4 c, float3 f) {
  const __half2 fz = __float2half2_rn(f.z), fy = __float2half2_rn(f.y);
  const __half2 h0 = *reinterpret_cast<__half2*>(&c.x), h1 = *reinterpret_cast<__half2*>(&c.y);
  const __half2 h2 = *reinterpret_cast<__half2*>(&c.z), h3 = *reinterpret_cast<__half2*>(&c.w);
  const __half2 y0 = __hfma2(fz, __hsub2(h2, h0), h0), y1 = __hfma2(fz, __hsub2(h3, h1), h1);
  const float2 x = __half22float2(__hfma2(fy, __hsub2(y1, y0), y0));
  return fmaf(f.x, x.y - x.x, x.x);
}

// The same corners blended in float (each half widened first): exact weights.
__device__ __forceinline__ float blendWide(uint4 c, float3 f) {
  const float2 a = __half22float2(*reinterpret_cast<__half2*>(&c.x)), b = __half22float2(*reinterpret_cast<__half2*>(&c.y));
  const float2 d = __half22float2(*reinterpret_cast<__half2*>(&c.z)), e = __half22float2(*reinterpret_cast<__half2*>(&c.w));
  const float y0x0 = fmaf(f.z, d.x - a.x, a.x), y0x1 = fmaf(f.z, d.y - a.y, a.y);
  const float y1x0 = fmaf(f.z, e.x - b.x, b.x), y1x1 = fmaf(f.z, e.y - b.y, b.y);
  const float x0 = fmaf(f.y, y1x0 - y0x0, y0x0), x1 = fmaf(f.y, y1x1 - y0x1, y0x1);
  return fmaf(f.x, x1 - x0, x0);
}
// Corners as 16-bit integers (the texture's values), widened exactly (2^23 + v as a float's bits).
__device__ __forceinline__ float low16(unsigned w) { return __uint_as_float(0x4B000000u | (w & 0xffffu)) - 8388608.0f; }
__device__ __forceinline__ float high16(unsigned w) { return __uint_as_float(0x4B000000u | (w >> 16)) - 8388608.0f; }
__device__ __forceinline__ float blendIntegers(uint4 c, float3 f) {
  const float y0x0 = fmaf(f.z, low16(c.z) - low16(c.x), low16(c.x)), y0x1 = fmaf(f.z, high16(c.z) - high16(c.x), high16(c.x));
  const float y1x0 = fmaf(f.z, low16(c.w) - low16(c.y), low16(c.y)), y1x1 = fmaf(f.z, high16(c.w) - high16(c.y), high16(c.y));
  const float x0 = fmaf(f.y, y1x0 - y0x0, y0x0), x1 = fmaf(f.y, y1x1 - y0x1, y0x1);
  return fmaf(f.x, x1 - x0, x0) * (1.0f / 65535.0f);
}

// Corner 000 as a 16-bit integer (exact), the other seven as half differences from it (small where
// the image is smooth, so exact to about 2^-11 of the cell's range): blended in halves, the base
// added in float.
__device__ __forceinline__ float blendDeltas(uint4 c, float3 f) {
  const unsigned base = c.x & 0xffffu;
  c.x &= 0xffff0000u;  // (0, d100)
  return blend(c, f) + low16(base) * (1.0f / 65535.0f);
}

// The cell of p (clamped to the image, as the texture clamps) and the position in it.
__device__ __forceinline__ int3 cellOf(float3 p, float3& f) {
  p = make_float3(fminf(fmaxf(p.x, 0.0f), kSize - 1.0f), fminf(fmaxf(p.y, 0.0f), kSize - 1.0f), fminf(fmaxf(p.z, 0.0f), kSize - 1.0f));
  const int3 c = make_int3(min(int(p.x), kSize - 2), min(int(p.y), kSize - 2), min(int(p.z), kSize - 2));
  f = make_float3(p.x - c.x, p.y - c.y, p.z - c.z);
  return c;
}

// The ways a sample is fetched: each takes the sample's texel-space position.
struct ViaTexture {
  cudaTextureObject_t image;
  __device__ float operator()(float3 p) const { return tex3D<float>(image, p.x + 0.5f, p.y + 0.5f, p.z + 0.5f); }
};
// The slice below z (clamped to the image, as the texture clamps) and z's fraction past it.
__device__ __forceinline__ int sliceOf(float z, float& fraction) {
  z = fminf(fmaxf(z, 0.0f), kSize - 1.0f);
  const int slice = min(int(z), kSize - 2);
  fraction = z - float(slice);
  return slice;
}
// A layered 2D texture, layer k holding slices k and k + 1 as a pair of 16-bit values: one bilinear
// fetch gives both slices' bilinear values, blended along z in the SM (kPairs), or a layered
// texture of single slices fetched twice (!kPairs).
template <bool kPairs>
struct ViaLayers {
  cudaTextureObject_t layers;
  __device__ float operator()(float3 p) const {
    float fz;
    const int layer = sliceOf(p.z, fz);
    if constexpr (kPairs) {
      const float2 v = tex2DLayered<float2>(layers, p.x + 0.5f, p.y + 0.5f, layer);
      return fmaf(fz, v.y - v.x, v.x);
    } else {
      const float a = tex2DLayered<float>(layers, p.x + 0.5f, p.y + 0.5f, layer);
      const float b = tex2DLayered<float>(layers, p.x + 0.5f, p.y + 0.5f, layer + 1);
      return fmaf(fz, b - a, a);
    }
  }
};
// A 3D texture of the same slice pairs, fetched at the centre of its layer along z (the filter's z
// weight 0): whether the texture units then filter at the bilinear rate, with 3D tiles' locality.
struct ViaPairVolume {
  cudaTextureObject_t pairs;
  __device__ float operator()(float3 p) const {
    float fz;
    const int layer = sliceOf(p.z, fz);
    const float2 v = tex3D<float2>(pairs, p.x + 0.5f, p.y + 0.5f, float(layer) + 0.5f);
    return fmaf(fz, v.y - v.x, v.x);
  }
};
struct ViaCornerTexture {
  cudaTextureObject_t corners;
  __device__ float operator()(float3 p) const {
    float3 f;
    const int3 c = cellOf(p, f);
    return blend(tex3D<uint4>(corners, c.x + 0.5f, c.y + 0.5f, c.z + 0.5f), f);
  }
};
// kBlend: 0 halves blended in halves (y, z) then float (x), 1 halves widened, 2 16-bit integers,
// 3 a 16-bit base and half differences.
template <int kBlend>
struct ViaGlobal {
  const uint4* __restrict__ corners;
  __device__ float operator()(float3 p) const {
    float3 f;
    const int3 c = cellOf(p, f);
    const uint4 corner = __ldg(corners + (c.z * kSize + c.y) * kSize + c.x);
    return kBlend == 0 ? blend(corner, f) : kBlend == 1 ? blendWide(corner, f) : kBlend == 2 ? blendIntegers(corner, f) : blendDeltas(corner, f);
  }
};

// Each vertex's samples, fetched by `fetch` on kLanes lanes, summed.
template <class Fetch>
__global__ void sumSamples(const Vertex* vs, int n, Fetch fetch, float* out) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x, v = t / kLanes, part = t % kLanes;
  if (v >= n) return;
  const Vertex vx = vs[v];
  float sum = 0.0f;
#pragma unroll
  for (int s = part; s < kSamples; s += kLanes) sum += fetch(position(vx, float(s)));
  sum += __shfl_xor_sync(0xffffffffu, sum, 1);
  if (part == 0) out[v] = sum;
}

// The same as the profile pass holds it: at most 80 registers (6 blocks of 128 an SM) and 18 KB of
// shared memory a block (its lines and reference profiles), so that L1 keeps the rest for the
// texture; the samples stored to shared memory in kBatches batches, each before the next is
// fetched (a barrier between them): above 1, fewer fetches in flight at once, the registers a
// pair's fetches take in the pass.
template <int kBatches, class Fetch>
__global__ void __launch_bounds__(128, 6) sumSamplesInBatches(const Vertex* vs, int n, Fetch fetch, float* out) {
  extern __shared__ float lines[];
  const int t = blockIdx.x * blockDim.x + threadIdx.x, v = t / kLanes, part = t % kLanes;
  if (v >= n) return;
  const Vertex vx = vs[v];
  float* line = lines + (threadIdx.x / kLanes) * 51 + part;
  constexpr int kPerLane = kSamples / kLanes, kPerBatch = (kPerLane + kBatches - 1) / kBatches;
#pragma unroll
  for (int b = 0; b < kBatches; ++b) {
#pragma unroll
    for (int s = b * kPerBatch; s < (b + 1) * kPerBatch && s < kPerLane; ++s)
      line[kLanes * s] = fetch(position(vx, float(part + kLanes * s)));
    __syncwarp();
  }
  float sum = 0.0f;
#pragma unroll
  for (int s = 0; s < kPerLane; ++s) sum += line[kLanes * s];
  sum += __shfl_xor_sync(0xffffffffu, sum, 1);
  if (part == 0) out[v] = sum;
}

// The same, every kEvery-th of a lane's samples (its last of each kEvery) fetched by `other`, the
// rest by `fetch`: the texture units and the load-store pipe working side by side.
template <int kEvery, class Fetch, class Other>
__global__ void sumSamplesMixed(const Vertex* vs, int n, Fetch fetch, Other other, float* out) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x, v = t / kLanes, part = t % kLanes;
  if (v >= n) return;
  const Vertex vx = vs[v];
  float sum = 0.0f;
#pragma unroll
  for (int k = 0; k < kSamples / kLanes; ++k) {
    const float3 at = position(vx, float(part + kLanes * k));
    sum += k % kEvery == kEvery - 1 ? other(at) : fetch(at);
  }
  sum += __shfl_xor_sync(0xffffffffu, sum, 1);
  if (part == 0) out[v] = sum;
}

// Vertices on 12 spheres (radius 14 voxels, a 3 x 2 x 2 grid of centres), ring by ring so that a
// warp's vertices are neighbours, with outward normals.
std::vector<Vertex> sphereVertices(int total) {
  std::vector<Vertex> out;
  const int perSphere = total / 12;
  const int rings = int(std::sqrt(perSphere * M_PI / 4.0));
  for (int s = 0; s < 12; ++s) {
    const float3 c = make_float3(24.0f + 40.0f * (s % 3), 40.0f + 48.0f * ((s / 3) % 2), 40.0f + 48.0f * (s / 6));
    std::vector<Vertex> sphere;
    for (int r = 0; r < rings && int(sphere.size()) < perSphere; ++r) {
      const double theta = M_PI * (r + 0.5) / rings;
      const int around = std::max(1, int(std::lround(2.0 * rings * std::sin(theta))));
      for (int m = 0; m < around; ++m) {
        const double phi = 2.0 * M_PI * (m + 0.5 * (r % 2)) / around;
        const float3 nrm = make_float3(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)), float(std::cos(theta)));
        sphere.push_back({make_float3(c.x + 14.0f * nrm.x, c.y + 14.0f * nrm.y, c.z + 14.0f * nrm.z), nrm});
      }
    }
    sphere.resize(std::min<std::size_t>(sphere.size(), perSphere));
    out.insert(out.end(), sphere.begin(), sphere.end());
  }
  return out;
}

template <class Launch>
double microseconds(Launch launch, int repeats) {
  launch();
  CHECK(cudaDeviceSynchronize());
  cudaEvent_t a, b;
  CHECK(cudaEventCreate(&a));
  CHECK(cudaEventCreate(&b));
  CHECK(cudaEventRecord(a));
  for (int r = 0; r < repeats; ++r) launch();
  CHECK(cudaEventRecord(b));
  CHECK(cudaEventSynchronize(b));
  float ms = 0;
  CHECK(cudaEventElapsedTime(&ms, a, b));
  return 1e3 * ms / repeats;
}

}  // namespace

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::atoi(argv[1]) : 20;
  cudaDeviceProp prop;
  CHECK(cudaGetDeviceProperties(&prop, 0));
  // The image: smooth structure (bright spheres' walls) and noise, 16-bit.
  const std::size_t voxels = std::size_t(kSize) * kSize * kSize;
  std::vector<unsigned short> image(voxels);
  unsigned state = 12345u;
  for (int k = 0; k < kSize; ++k)
    for (int j = 0; j < kSize; ++j)
      for (int i = 0; i < kSize; ++i) {
        state = state * 1664525u + 1013904223u;
        const double wave = std::sin(i * 0.21) * std::cos(j * 0.17) + std::sin(k * 0.13);
        image[(std::size_t(k) * kSize + j) * kSize + i] = static_cast<unsigned short>(30000 + 12000 * wave + (state >> 22));
      }
  std::vector<uint4> corners(voxels), integerCorners(voxels), deltaCorners(voxels);
  const auto at = [&](int i, int j, int k) {
    i = std::min(i, kSize - 1), j = std::min(j, kSize - 1), k = std::min(k, kSize - 1);
    return __half_as_ushort(__float2half(image[(std::size_t(k) * kSize + j) * kSize + i] / 65535.0f));
  };
  for (int k = 0; k < kSize; ++k)
    for (int j = 0; j < kSize; ++j)
      for (int i = 0; i < kSize; ++i) {
        const auto pair = [&](int dj, int dk) { return unsigned(at(i, j + dj, k + dk)) | unsigned(at(i + 1, j + dj, k + dk)) << 16; };
        corners[(std::size_t(k) * kSize + j) * kSize + i] = make_uint4(pair(0, 0), pair(1, 0), pair(0, 1), pair(1, 1));
        const auto raw = [&](int di, int dj, int dk) {
          return unsigned(image[(std::size_t(std::min(k + dk, kSize - 1)) * kSize + std::min(j + dj, kSize - 1)) * kSize +
                                std::min(i + di, kSize - 1)]);
        };
        const auto pair16 = [&](int dj, int dk) { return raw(0, dj, dk) | raw(1, dj, dk) << 16; };
        integerCorners[(std::size_t(k) * kSize + j) * kSize + i] = make_uint4(pair16(0, 0), pair16(1, 0), pair16(0, 1), pair16(1, 1));
        const auto delta = [&](int di, int dj, int dk) {
          return unsigned(__half_as_ushort(__float2half((float(raw(di, dj, dk)) - float(raw(0, 0, 0))) / 65535.0f)));
        };
        const auto pairDelta = [&](int dj, int dk) { return delta(0, dj, dk) | delta(1, dj, dk) << 16; };
        deltaCorners[(std::size_t(k) * kSize + j) * kSize + i] =
            make_uint4(raw(0, 0, 0) | delta(1, 0, 0) << 16, pairDelta(1, 0), pairDelta(0, 1), pairDelta(1, 1));
      }

  const cudaExtent extent = make_cudaExtent(kSize, kSize, kSize);
  // A 3D texture, or with `flags` cudaArrayLayered a layered 2D one (the third extent its layers).
  const auto texture3d = [&](const void* data, cudaChannelFormatDesc format, std::size_t bytes, bool linear, unsigned flags = 0) {
    cudaArray_t array;
    CHECK(cudaMalloc3DArray(&array, &format, extent, flags));
    cudaMemcpy3DParms copy{};
    copy.srcPtr = make_cudaPitchedPtr(const_cast<void*>(data), kSize * bytes, kSize, kSize);
    copy.dstArray = array;
    copy.extent = extent;
    copy.kind = cudaMemcpyHostToDevice;
    CHECK(cudaMemcpy3D(&copy));
    cudaResourceDesc resource{};
    resource.resType = cudaResourceTypeArray;
    resource.res.array.array = array;
    cudaTextureDesc desc{};
    for (auto& mode : desc.addressMode) mode = cudaAddressModeClamp;
    desc.filterMode = linear ? cudaFilterModeLinear : cudaFilterModePoint;
    desc.readMode = linear ? cudaReadModeNormalizedFloat : cudaReadModeElementType;
    cudaTextureObject_t object;
    CHECK(cudaCreateTextureObject(&object, &resource, &desc, nullptr));
    return object;
  };
  const cudaTextureObject_t imageTexture = texture3d(image.data(), cudaCreateChannelDesc<unsigned short>(), 2, true);
  const cudaTextureObject_t cornerTexture = texture3d(corners.data(), cudaCreateChannelDesc<uint4>(), 16, false);
  std::vector<ushort2> slicePairs(voxels);
  for (std::size_t k = 0; k < std::size_t(kSize); ++k)
    for (std::size_t r = 0; r < std::size_t(kSize) * kSize; ++r)
      slicePairs[k * kSize * kSize + r] = make_ushort2(image[k * kSize * kSize + r], image[std::min<std::size_t>(k + 1, kSize - 1) * kSize * kSize + r]);
  const cudaTextureObject_t pairLayers = texture3d(slicePairs.data(), cudaCreateChannelDesc<ushort2>(), 4, true, cudaArrayLayered);
  const cudaTextureObject_t sliceLayers = texture3d(image.data(), cudaCreateChannelDesc<unsigned short>(), 2, true, cudaArrayLayered);
  const cudaTextureObject_t pairVolume = texture3d(slicePairs.data(), cudaCreateChannelDesc<ushort2>(), 4, true);
  uint4 *cornersGlobal, *integersGlobal;
  CHECK(cudaMalloc(&cornersGlobal, voxels * sizeof(uint4)));
  CHECK(cudaMemcpy(cornersGlobal, corners.data(), voxels * sizeof(uint4), cudaMemcpyHostToDevice));
  CHECK(cudaMalloc(&integersGlobal, voxels * sizeof(uint4)));
  CHECK(cudaMemcpy(integersGlobal, integerCorners.data(), voxels * sizeof(uint4), cudaMemcpyHostToDevice));
  uint4* deltasGlobal;
  CHECK(cudaMalloc(&deltasGlobal, voxels * sizeof(uint4)));
  CHECK(cudaMemcpy(deltasGlobal, deltaCorners.data(), voxels * sizeof(uint4), cudaMemcpyHostToDevice));

  const std::vector<Vertex> vertices = sphereVertices(2719744);
  const int n = int(vertices.size());
  Vertex* vs;
  float *outTexture, *outOther;
  CHECK(cudaMalloc(&vs, n * sizeof(Vertex)));
  CHECK(cudaMalloc(&outTexture, n * sizeof(float)));
  CHECK(cudaMalloc(&outOther, n * sizeof(float)));
  CHECK(cudaMemcpy(vs, vertices.data(), n * sizeof(Vertex), cudaMemcpyHostToDevice));
  const int threads = 128, blocks = (n * kLanes + threads - 1) / threads;
  // The same vertices in an order without locality (a fixed shuffle), as a mesh's numbering far
  // from its surface's neighbourhoods would give the warps.
  std::vector<Vertex> mixed = vertices;
  for (std::size_t i = mixed.size() - 1; i > 0; --i) {
    state = state * 1664525u + 1013904223u;
    std::swap(mixed[i], mixed[state % (i + 1)]);
  }
  Vertex* shuffled;
  float* outShuffled;
  CHECK(cudaMalloc(&shuffled, n * sizeof(Vertex)));
  CHECK(cudaMalloc(&outShuffled, n * sizeof(float)));
  CHECK(cudaMemcpy(shuffled, mixed.data(), n * sizeof(Vertex), cudaMemcpyHostToDevice));

  std::printf("device: %s; %d vertices, %d samples each, %d lanes a vertex; us per launch (%d launches)\n\n", prop.name, n,
              kSamples, kLanes, repeats);
  // Exact trilinear sums (double, the 16-bit values) of every 97th vertex, the same positions.
  const auto exactSum = [&](int v) {
    double sum = 0;
    for (int s = 0; s < kSamples; ++s) {
      const float t = (kFirst + float(s)) * kSpacing;
      const Vertex& x = vertices[v];
      float p[3] = {std::fma(t, x.n.x, x.x.x), std::fma(t, x.n.y, x.x.y), std::fma(t, x.n.z, x.x.z)};
      int c[3];
      double f[3];
      for (int a = 0; a < 3; ++a) {
        p[a] = std::min(std::max(p[a], 0.0f), kSize - 1.0f);
        c[a] = std::min(int(p[a]), kSize - 2);
        f[a] = p[a] - c[a];
      }
      for (int corner = 0; corner < 8; ++corner) {
        const int di = corner & 1, dj = corner >> 1 & 1, dk = corner >> 2;
        const double w = (di ? f[0] : 1 - f[0]) * (dj ? f[1] : 1 - f[1]) * (dk ? f[2] : 1 - f[2]);
        sum += w * image[(std::size_t(c[2] + dk) * kSize + c[1] + dj) * kSize + c[0] + di] / 65535.0;
      }
    }
    return sum;
  };
  std::vector<double> exact;
  for (int v = 0; v < n; v += 97) exact.push_back(exactSum(v));
  std::printf("| fetch | us | G samples/s | largest error of a vertex's sum of 50 samples (values in [0, 1]) |\n| --- | ---: | ---: | ---: |\n");
  std::vector<float> got(n);
  const auto report = [&](const char* name, double us, float* out) {
    if (!out) {  // the shuffled vertices: their sums are not checked
      std::printf("| %s | %.1f | %.1f | - |\n", name, us, double(n) * kSamples / us / 1e3);
      return;
    }
    CHECK(cudaMemcpy(got.data(), out, n * sizeof(float), cudaMemcpyDeviceToHost));
    double worst = 0;
    for (int v = 0, e = 0; v < n; v += 97, ++e) worst = std::max(worst, std::abs(double(got[v]) - exact[e]));
    std::printf("| %s | %.1f | %.1f | %.2e |\n", name, us, double(n) * kSamples / us / 1e3, worst);
  };
  for (int round = 0; round < 2; ++round) {
    report("texture (trilinear filter)", microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaTexture{imageTexture}, outTexture); }, repeats), outTexture);
    report("layers of slice pairs (16-bit x 2), bilinear, z blended in the SM",
           microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaLayers<true>{pairLayers}, outOther); }, repeats), outOther);
    report("3D texture of slice pairs at its layers' centres, z blended in the SM",
           microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaPairVolume{pairVolume}, outOther); }, repeats), outOther);
    report("layers of slices (16-bit), two bilinear fetches, z blended in the SM",
           microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaLayers<false>{sliceLayers}, outOther); }, repeats), outOther);
    constexpr int kPassShared = 18 * 1024;  // (under the 48 KB a launch may ask for without opting in)
    report("as in the pass (80 registers, 18 KB shared): texture",
           microseconds([&] { sumSamplesInBatches<1><<<blocks, threads, kPassShared>>>(vs, n, ViaTexture{imageTexture}, outOther); }, repeats), outOther);
    report("as in the pass (80 registers, 18 KB shared): layers of slice pairs",
           microseconds([&] { sumSamplesInBatches<1><<<blocks, threads, kPassShared>>>(vs, n, ViaLayers<true>{pairLayers}, outOther); }, repeats), outOther);
    report("as in the pass, in 2 batches: texture",
           microseconds([&] { sumSamplesInBatches<2><<<blocks, threads, kPassShared>>>(vs, n, ViaTexture{imageTexture}, outOther); }, repeats), outOther);
    report("as in the pass, in 2 batches: layers of slice pairs",
           microseconds([&] { sumSamplesInBatches<2><<<blocks, threads, kPassShared>>>(vs, n, ViaLayers<true>{pairLayers}, outOther); }, repeats), outOther);
    report("as in the pass, in 3 batches: layers of slice pairs",
           microseconds([&] { sumSamplesInBatches<3><<<blocks, threads, kPassShared>>>(vs, n, ViaLayers<true>{pairLayers}, outOther); }, repeats), outOther);
    report("vertices shuffled: texture",
           microseconds([&] { sumSamplesInBatches<1><<<blocks, threads, kPassShared>>>(shuffled, n, ViaTexture{imageTexture}, outShuffled); }, repeats), nullptr);
    report("vertices shuffled: layers of slice pairs",
           microseconds([&] { sumSamplesInBatches<1><<<blocks, threads, kPassShared>>>(shuffled, n, ViaLayers<true>{pairLayers}, outShuffled); }, repeats), nullptr);
    report("vertices shuffled: 3D texture of slice pairs",
           microseconds([&] { sumSamplesInBatches<1><<<blocks, threads, kPassShared>>>(shuffled, n, ViaPairVolume{pairVolume}, outShuffled); }, repeats), nullptr);
    report("corners as halves, unfiltered texture fetch, half blend",
           microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaCornerTexture{cornerTexture}, outOther); }, repeats), outOther);
    report("corners as halves, 16-byte global load, half blend",
           microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaGlobal<0>{cornersGlobal}, outOther); }, repeats), outOther);
    report("corners as halves, 16-byte global load, float blend",
           microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaGlobal<1>{cornersGlobal}, outOther); }, repeats), outOther);
    report("corners as 16-bit integers, 16-byte global load, float blend",
           microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaGlobal<2>{integersGlobal}, outOther); }, repeats), outOther);
    report("a 16-bit corner and half differences, 16-byte global load, half blend",
           microseconds([&] { sumSamples<<<blocks, threads>>>(vs, n, ViaGlobal<3>{deltasGlobal}, outOther); }, repeats), outOther);
    const ViaTexture tex{imageTexture};
    const ViaGlobal<3> deltas{deltasGlobal};
    report("mixed: every 2nd sample by half differences, the rest by the texture",
           microseconds([&] { sumSamplesMixed<2><<<blocks, threads>>>(vs, n, tex, deltas, outOther); }, repeats), outOther);
    report("mixed: every 3rd", microseconds([&] { sumSamplesMixed<3><<<blocks, threads>>>(vs, n, tex, deltas, outOther); }, repeats), outOther);
    report("mixed: every 4th", microseconds([&] { sumSamplesMixed<4><<<blocks, threads>>>(vs, n, tex, deltas, outOther); }, repeats), outOther);
    report("mixed: every 6th", microseconds([&] { sumSamplesMixed<6><<<blocks, threads>>>(vs, n, tex, deltas, outOther); }, repeats), outOther);
  }
  return 0;
}
