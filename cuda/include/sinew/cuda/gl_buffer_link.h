// An OpenGL buffer object registered with CUDA, so the engine writes vertex positions straight
// into what OpenGL draws (no host copy). Host-only header without OpenGL types: the translation
// unit that includes CUDA's GL interop header must not also include VTK's GLEW.
#pragma once

#include "sinew/cuda/cuda_engine.h"

namespace sinew::cuda {

class GlBufferLink {
public:
  // Registers the buffer for write-discard; the buffer's GL context must be current and on the
  // CUDA device. Throws std::runtime_error when CUDA cannot register it.
  explicit GlBufferLink(unsigned int glBuffer);
  ~GlBufferLink();
  GlBufferLink(const GlBufferLink&) = delete;
  GlBufferLink& operator=(const GlBufferLink&) = delete;

  unsigned int buffer() const { return buffer_; }
  // Maps the buffer, has the engine write structure mesh's surface points into it, unmaps. Throws
  // when the buffer is smaller than the points.
  void writeSurface(CudaEngine& engine, Index mesh, std::size_t pointCount);

private:
  unsigned int buffer_ = 0;
  void* resource_ = nullptr;  // cudaGraphicsResource_t
};

}  // namespace sinew::cuda
