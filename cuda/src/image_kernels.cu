// The target image mapped to 16-bit normalised integers for its texture (device_image.h): the
// range by a fixed two-pass reduction (deterministic), then one thread per voxel.
#include "kernels.h"

#include <cfloat>

namespace sinew::cuda {

namespace {
constexpr int kThreads = 256, kParts = kNormaliseParts;

// The block's least and greatest of its threads' (a, b), valid in thread 0.
__device__ float2 blockRange(float a, float b) {
  __shared__ float lo[kThreads], hi[kThreads];
  lo[threadIdx.x] = a;
  hi[threadIdx.x] = b;
  __syncthreads();
  for (int s = kThreads / 2; s > 0; s /= 2) {
    if (threadIdx.x < s) {
      lo[threadIdx.x] = fminf(lo[threadIdx.x], lo[threadIdx.x + s]);
      hi[threadIdx.x] = fmaxf(hi[threadIdx.x], hi[threadIdx.x + s]);
    }
    __syncthreads();
  }
  return make_float2(lo[0], hi[0]);
}

// Block b's least and greatest finite value of a grid-stride share (NaN and infinities skipped).
__global__ void rangeParts(const float* __restrict__ v, size_t n, float2* __restrict__ parts) {
  float a = FLT_MAX, b = -FLT_MAX;
  for (size_t i = blockIdx.x * size_t(kThreads) + threadIdx.x; i < n; i += size_t(gridDim.x) * kThreads)
    if (isfinite(v[i])) {
      a = fminf(a, v[i]);
      b = fmaxf(b, v[i]);
    }
  const float2 r = blockRange(a, b);
  if (threadIdx.x == 0) parts[blockIdx.x] = r;
}

// One block: the parts' range into range[0] (least) and range[1] (greatest).
__global__ void rangeTotal(const float2* __restrict__ parts, int count, float* __restrict__ range) {
  float a = FLT_MAX, b = -FLT_MAX;
  for (int i = threadIdx.x; i < count; i += kThreads) {
    a = fminf(a, parts[i].x);
    b = fmaxf(b, parts[i].y);
  }
  const float2 r = blockRange(a, b);
  if (threadIdx.x == 0) {
    range[0] = r.x;
    range[1] = r.y;
  }
}

// (v - least) / (greatest - least) in steps of 1/65535; a constant image maps to 0, and values
// that are not finite to the nearest end of the range (NaN to 0).
__global__ void toUnorm16(const float* __restrict__ v, size_t n, const float* __restrict__ range,
                          unsigned short* __restrict__ out) {
  const size_t i = blockIdx.x * size_t(kThreads) + threadIdx.x;
  if (i >= n) return;
  const float lo = range[0], width = range[1] - range[0];
  const float scaled = width > 0.0f ? (v[i] - lo) / width * 65535.0f : 0.0f;
  out[i] = static_cast<unsigned short>(__float2uint_rn(fminf(fmaxf(scaled, 0.0f), 65535.0f)));
}
}  // namespace

void launchNormalise16(const float* values, size_t n, float* scratch, unsigned short* out, cudaStream_t s) {
  float2* parts = reinterpret_cast<float2*>(scratch + 2);  // scratch[0..1]: the range
  rangeParts<<<kParts, kThreads, 0, s>>>(values, n, parts);
  rangeTotal<<<1, kThreads, 0, s>>>(parts, kParts, scratch);
  toUnorm16<<<static_cast<unsigned>((n + kThreads - 1) / kThreads), kThreads, 0, s>>>(values, n, scratch, out);
}

}  // namespace sinew::cuda
