// Which CUDA devices this build can use, and the first device's context started early
// (cuda_engine.h).
#include "sinew/cuda/cuda_engine.h"

#include <cuda_runtime.h>

#include <sstream>

namespace sinew::cuda {

DeviceStatus probeDevice() {
  DeviceStatus st;
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e != cudaSuccess) {
    st.reason = std::string("no usable CUDA device (") + cudaGetErrorString(e) + ")";
    return st;
  }
  if (count == 0) {
    st.reason = "no CUDA device found";
    return st;
  }
  cudaDeviceProp p{};
  if (cudaGetDeviceProperties(&p, 0) != cudaSuccess) {
    st.reason = "cannot query CUDA device 0";
    return st;
  }
  std::ostringstream d;
  d << p.name << " (sm_" << p.major << p.minor << ", " << std::fixed;
  d.precision(1);
  d << double(p.totalGlobalMem) / (1 << 30) << " GiB)";
  st.description = d.str();
  if (p.major < 9) {
    st.reason = st.description + " is older than this build's target (sm_90: Hopper)";
    return st;
  }
  st.usable = true;
  return st;
}

std::vector<int> usableDevices() {
  int count = 0;
  std::vector<int> usable;
  if (cudaGetDeviceCount(&count) != cudaSuccess) return usable;
  for (int d = 0; d < count; ++d) {
    cudaDeviceProp p{};
    if (cudaGetDeviceProperties(&p, d) == cudaSuccess && p.major >= 9) usable.push_back(d);
  }
  return usable;
}

DeviceStatus startDevice() {
  DeviceStatus st = probeDevice();
  if (!st.usable) return st;
  if (const cudaError_t e = cudaFree(nullptr); e != cudaSuccess) {
    st.usable = false;
    st.reason = st.description + ": cannot create a context (" + cudaGetErrorString(e) + ")";
  }
  return st;
}

}  // namespace sinew::cuda
