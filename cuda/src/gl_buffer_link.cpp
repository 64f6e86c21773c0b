#include "sinew/cuda/gl_buffer_link.h"

#include "cuda_check.h"

#include <GL/gl.h>
#include <cuda_gl_interop.h>

namespace sinew::cuda {

GlBufferLink::GlBufferLink(unsigned int glBuffer) : buffer_(glBuffer) {
  cudaGraphicsResource_t r = nullptr;
  SINEW_CUDA(cudaGraphicsGLRegisterBuffer(&r, glBuffer, cudaGraphicsRegisterFlagsWriteDiscard));
  resource_ = r;
}

GlBufferLink::~GlBufferLink() {
  if (resource_) cudaGraphicsUnregisterResource(static_cast<cudaGraphicsResource_t>(resource_));
}

void GlBufferLink::writeSurface(CudaEngine& engine, Index mesh, std::size_t pointCount) {
  auto r = static_cast<cudaGraphicsResource_t>(resource_);
  SINEW_CUDA(cudaGraphicsMapResources(1, &r, 0));
  void* ptr = nullptr;
  size_t bytes = 0;
  try {
    SINEW_CUDA(cudaGraphicsResourceGetMappedPointer(&ptr, &bytes, r));
    if (bytes < pointCount * 3 * sizeof(float)) throw std::runtime_error("CUDA: the OpenGL vertex buffer is too small");
    engine.writeSurfacePoints(mesh, static_cast<float*>(ptr));
  } catch (...) {
    cudaGraphicsUnmapResources(1, &r, 0);
    throw;
  }
  SINEW_CUDA(cudaGraphicsUnmapResources(1, &r, 0));
}

}  // namespace sinew::cuda
