// The profile force's target image on the device: a 3D texture sampled by the texture units'
// trilinear filter (profile_kernels.cu). Host-only header.
#pragma once

#include "cuda_check.h"

namespace sinew::cuda {

// The image's values mapped linearly so that its range is [0, 1], held as 16-bit normalised
// integers (steps of 1/65535 of the range). The profile force's NCC does not change under an
// affine change of intensities, so the kernels use the mapped values as they come; 16 bits filter
// at twice the rate of 32-bit floats and take half the memory. Clamped at the border (border voxels
// extend outside, as Volume::sample does); unnormalised coordinates (voxel i's centre at i + 0.5).
class DeviceImageTexture {
public:
  DeviceImageTexture() = default;
  ~DeviceImageTexture() { release(); }
  DeviceImageTexture(const DeviceImageTexture&) = delete;
  DeviceImageTexture& operator=(const DeviceImageTexture&) = delete;

  // voxels: x fastest, then y, then z (host memory, read before this returns). The range and the
  // conversion are computed on the device.
  void upload(const float* voxels, int sx, int sy, int sz, cudaStream_t stream);
  cudaTextureObject_t get() const { return texture_; }
  std::size_t bytes() const { return bytes_; }
  // The host data the texture was made from (to skip uploading the same image again).
  const float* source() const { return source_; }

private:
  void release();
  cudaArray_t array_ = nullptr;
  cudaTextureObject_t texture_ = 0;
  std::size_t bytes_ = 0;
  const float* source_ = nullptr;
};

}  // namespace sinew::cuda
