#include "sinew/cuda/gl_buffer_link.h"

#include "cuda_check.h"

#include <GL/gl.h>
#include <cuda_gl_interop.h>

#include <stdexcept>
#include <vector>

namespace sinew::cuda {

GlBufferLink::GlBufferLink(unsigned int glBuffer) : buffer_(glBuffer) {
  cudaGraphicsResource_t r = nullptr;
  SINEW_CUDA(cudaGraphicsGLRegisterBuffer(&r, glBuffer, cudaGraphicsRegisterFlagsWriteDiscard));
  resource_ = r;
}

GlBufferLink::~GlBufferLink() {
  if (resource_) cudaGraphicsUnregisterResource(static_cast<cudaGraphicsResource_t>(resource_));
}

void writeSurfaces(CudaEngine& engine, const std::vector<SurfaceWrite>& writes) {
  if (writes.empty()) return;
  auto stream = static_cast<cudaStream_t>(engine.nativeStream());
  std::vector<cudaGraphicsResource_t> resources;
  for (const SurfaceWrite& w : writes) resources.push_back(static_cast<cudaGraphicsResource_t>(w.link->resource()));
  // One map and one unmap per frame: each is a synchronisation point with OpenGL.
  SINEW_CUDA(cudaGraphicsMapResources(int(resources.size()), resources.data(), stream));
  try {
    for (std::size_t i = 0; i < writes.size(); ++i) {
      void* ptr = nullptr;
      size_t bytes = 0;
      SINEW_CUDA(cudaGraphicsResourceGetMappedPointer(&ptr, &bytes, resources[i]));
      if (bytes < writes[i].pointCount * 3 * sizeof(float))
        throw std::runtime_error("CUDA: the OpenGL vertex buffer is too small");
      engine.writeSurfacePoints(writes[i].mesh, static_cast<float*>(ptr));
    }
  } catch (...) {
    cudaGraphicsUnmapResources(int(resources.size()), resources.data(), stream);
    throw;
  }
  SINEW_CUDA(cudaGraphicsUnmapResources(int(resources.size()), resources.data(), stream));
}

}  // namespace sinew::cuda
