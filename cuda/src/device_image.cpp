#include "device_image.h"

#include "kernels.h"

#include <string>

namespace sinew::cuda {

void DeviceImageTexture::upload(const float* voxels, int sx, int sy, int sz, cudaStream_t stream) {
  release();
  int device = 0;
  cudaDeviceProp prop{};
  SINEW_CUDA(cudaGetDevice(&device));
  SINEW_CUDA(cudaGetDeviceProperties(&prop, device));
  if (sx > prop.maxTexture3D[0] || sy > prop.maxTexture3D[1] || sz > prop.maxTexture3D[2])
    throw std::runtime_error("CUDA: the target image's " + std::to_string(sx) + "x" + std::to_string(sy) + "x" +
                             std::to_string(sz) + " voxels exceed this GPU's 3D texture size (" +
                             std::to_string(prop.maxTexture3D[0]) + "x" + std::to_string(prop.maxTexture3D[1]) + "x" +
                             std::to_string(prop.maxTexture3D[2]) + ")");
  const std::size_t n = static_cast<std::size_t>(sx) * sy * sz;
  DeviceArray<float> values, scratch(2 + 2 * kNormaliseParts);
  DeviceArray<unsigned short> mapped(n);
  values.upload(voxels, n, stream);
  launchNormalise16(values.get(), n, scratch.get(), mapped.get(), stream);
  const cudaChannelFormatDesc format = cudaCreateChannelDesc<unsigned short>();
  const cudaExtent extent = make_cudaExtent(sx, sy, sz);
  SINEW_CUDA(cudaMalloc3DArray(&array_, &format, extent));
  bytes_ = n * sizeof(unsigned short);
  cudaMemcpy3DParms copy{};
  copy.srcPtr = make_cudaPitchedPtr(mapped.get(), sx * sizeof(unsigned short), sx, sy);
  copy.dstArray = array_;
  copy.extent = extent;
  copy.kind = cudaMemcpyDeviceToDevice;
  SINEW_CUDA(cudaMemcpy3DAsync(&copy, stream));
  SINEW_CUDA(cudaStreamSynchronize(stream));  // before the temporaries go
  cudaResourceDesc resource{};
  resource.resType = cudaResourceTypeArray;
  resource.res.array.array = array_;
  cudaTextureDesc texture{};
  for (int a = 0; a < 3; ++a) texture.addressMode[a] = cudaAddressModeClamp;
  texture.filterMode = cudaFilterModeLinear;
  texture.readMode = cudaReadModeNormalizedFloat;
  texture.normalizedCoords = 0;
  SINEW_CUDA(cudaCreateTextureObject(&texture_, &resource, &texture, nullptr));
  source_ = voxels;
}

void DeviceImageTexture::release() {
  if (texture_) cudaDestroyTextureObject(texture_);
  if (array_) cudaFreeArray(array_);
  texture_ = 0;
  array_ = nullptr;
  bytes_ = 0;
  source_ = nullptr;
}

}  // namespace sinew::cuda
