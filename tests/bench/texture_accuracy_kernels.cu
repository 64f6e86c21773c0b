// Is hardware trilinear filtering (texture units, 8-bit interpolation weights) accurate enough for
// the intensity-profile force? Samples the same search lines once with exact trilinear
// interpolation (what the kernels use) and once through a 3D texture with linear filtering, then
// compares the NCC scores and the chosen offsets, as the profile force computes them.
// Device part; texture_accuracy.cpp loads the image.
#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace {
constexpr int kInside = 25, kOutside = 5, kLength = kInside + kOutside, kReach = 10, kLine = kLength + 2 * kReach;

__device__ float exactSample(const float* img, int sx, int sy, int sz, float x, float y, float z) {
  const float c[3] = {fminf(fmaxf(x, 0.f), sx - 1.f), fminf(fmaxf(y, 0.f), sy - 1.f), fminf(fmaxf(z, 0.f), sz - 1.f)};
  const int s[3] = {sx, sy, sz};
  int i0[3], i1[3];
  float f[3];
  for (int a = 0; a < 3; ++a) {
    i0[a] = min(int(c[a]), max(s[a] - 2, 0));
    f[a] = c[a] - i0[a];
    i1[a] = min(i0[a] + 1, s[a] - 1);
  }
  auto at = [&](int i, int j, int k) { return img[(size_t(k) * sy + j) * sx + i]; };
  auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
  const float c00 = lerp(at(i0[0], i0[1], i0[2]), at(i1[0], i0[1], i0[2]), f[0]);
  const float c10 = lerp(at(i0[0], i1[1], i0[2]), at(i1[0], i1[1], i0[2]), f[0]);
  const float c01 = lerp(at(i0[0], i0[1], i1[2]), at(i1[0], i0[1], i1[2]), f[0]);
  const float c11 = lerp(at(i0[0], i1[1], i1[2]), at(i1[0], i1[1], i1[2]), f[0]);
  return lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2]);
}

// Per line: the reference profile is the exact profile at the line's centre; the search scores
// windows along the line shifted by a random sub-voxel offset, with both samplers.
__global__ void compare(const float* img, cudaTextureObject_t tex, int sx, int sy, int sz, const float4* lines, int count,
                        float* maxDiff, int* sameChoice, float* sumDiff) {
  const int l = blockIdx.x * blockDim.x + threadIdx.x;
  if (l >= count) return;
  const float4 o = lines[2 * l], d = lines[2 * l + 1];  // origin (w: shift), direction (voxel units)
  float exact[kLine], hw[kLine], ref[kLength];
  for (int q = 0; q < kLine; ++q) {
    const float t = (q - kReach - kInside + 0.5f) * 0.5f + o.w;
    const float x = o.x + t * d.x, y = o.y + t * d.y, z = o.z + t * d.z;
    exact[q] = exactSample(img, sx, sy, sz, x, y, z);
    hw[q] = tex3D<float>(tex, x + 0.5f, y + 0.5f, z + 0.5f);
  }
  float mean = 0, norm = 0;
  for (int k = 0; k < kLength; ++k) {
    const float t = (k - kInside + 0.5f) * 0.5f;
    ref[k] = exactSample(img, sx, sy, sz, o.x + t * d.x, o.y + t * d.y, o.z + t * d.z);
    mean += ref[k];
  }
  mean /= kLength;
  for (int k = 0; k < kLength; ++k) norm += (ref[k] - mean) * (ref[k] - mean);
  const float inv = norm > 1e-12f ? rsqrtf(norm) : 0.f;
  for (int k = 0; k < kLength; ++k) ref[k] = (ref[k] - mean) * inv;
  float bestE = -2, bestH = -2, worst = 0, total = 0;
  int jE = 0, jH = 0;
  for (int j = 0; j <= 2 * kReach; ++j) {
    float ncc[2];
    const float* src[2] = {exact, hw};
    for (int s = 0; s < 2; ++s) {
      float sum = 0, sum2 = 0, dot = 0;
      for (int k = 0; k < kLength; ++k) {
        const float w = src[s][j + k];
        sum += w;
        sum2 += w * w;
        dot += w * ref[k];
      }
      const float var = sum2 - sum * sum / kLength;
      ncc[s] = var > 1e-12f ? dot / sqrtf(var) : -1.f;
    }
    worst = fmaxf(worst, fabsf(ncc[0] - ncc[1]));
    total += fabsf(ncc[0] - ncc[1]);
    if (ncc[0] > bestE) bestE = ncc[0], jE = j;
    if (ncc[1] > bestH) bestH = ncc[1], jH = j;
  }
  maxDiff[l] = worst;
  sumDiff[l] = total / (2 * kReach + 1);
  sameChoice[l] = jE == jH ? 1 : (abs(jE - jH) == 1 ? 2 : 0);
}
}  // namespace

void compareTextureSampling(const char* name, const float* image, const int size[3], const float spacing[3], int count) {
  const size_t voxels = size_t(size[0]) * size[1] * size[2];
  float* dImg;
  cudaMalloc(&dImg, voxels * 4);
  cudaMemcpy(dImg, image, voxels * 4, cudaMemcpyHostToDevice);
  cudaArray_t array;
  const cudaChannelFormatDesc desc = cudaCreateChannelDesc<float>();
  const cudaExtent extent = make_cudaExtent(size[0], size[1], size[2]);
  cudaMalloc3DArray(&array, &desc, extent);
  cudaMemcpy3DParms copy{};
  copy.srcPtr = make_cudaPitchedPtr((void*)image, size[0] * 4, size[0], size[1]);
  copy.dstArray = array;
  copy.extent = extent;
  copy.kind = cudaMemcpyHostToDevice;
  cudaMemcpy3D(&copy);
  cudaResourceDesc res{};
  res.resType = cudaResourceTypeArray;
  res.res.array.array = array;
  cudaTextureDesc td{};
  td.addressMode[0] = td.addressMode[1] = td.addressMode[2] = cudaAddressModeClamp;
  td.filterMode = cudaFilterModeLinear;
  td.readMode = cudaReadModeElementType;
  cudaTextureObject_t tex;
  cudaCreateTextureObject(&tex, &res, &td, nullptr);
  // Lines through the central half of the volume (the brain), random directions, random shifts.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  std::normal_distribution<float> n(0.f, 1.f);
  std::vector<float4> lines;
  for (int l = 0; l < count; ++l) {
    float dx = n(rng), dy = n(rng), dz = n(rng);
    const float len = std::sqrt(dx * dx + dy * dy + dz * dz);
    lines.push_back(make_float4(size[0] * (0.25f + 0.5f * u(rng)), size[1] * (0.25f + 0.5f * u(rng)),
                                size[2] * (0.25f + 0.5f * u(rng)), 2.f * u(rng) - 1.f));
    lines.push_back(make_float4(dx / len / spacing[0], dy / len / spacing[1], dz / len / spacing[2], 0));
  }
  float4* dLines;
  float *dMax, *dSum;
  int* dSame;
  cudaMalloc(&dLines, lines.size() * sizeof(float4));
  cudaMalloc(&dMax, count * 4);
  cudaMalloc(&dSum, count * 4);
  cudaMalloc(&dSame, count * 4);
  cudaMemcpy(dLines, lines.data(), lines.size() * sizeof(float4), cudaMemcpyHostToDevice);
  compare<<<(count + 127) / 128, 128>>>(dImg, tex, size[0], size[1], size[2], dLines, count, dMax, dSame, dSum);
  std::vector<float> mx(count), sm(count);
  std::vector<int> same(count);
  cudaMemcpy(mx.data(), dMax, count * 4, cudaMemcpyDeviceToHost);
  cudaMemcpy(sm.data(), dSum, count * 4, cudaMemcpyDeviceToHost);
  cudaMemcpy(same.data(), dSame, count * 4, cudaMemcpyDeviceToHost);
  double worst = 0, mean = 0;
  long equal = 0, adjacent = 0;
  for (int l = 0; l < count; ++l) {
    worst = std::max(worst, double(mx[l]));
    mean += sm[l];
    equal += same[l] == 1;
    adjacent += same[l] == 2;
  }
  std::printf("%s: %d search lines (50 samples, 21 windows, 0.5 mm)\n", name, count);
  std::printf("NCC |texture - exact|: mean %.2e, max %.2e\n", mean / count, worst);
  std::printf("chosen offset: same %.3f %%, one step (0.5 mm) apart %.3f %%, further %.3f %%\n",
              100.0 * equal / count, 100.0 * adjacent / count, 100.0 * (count - equal - adjacent) / count);
}
