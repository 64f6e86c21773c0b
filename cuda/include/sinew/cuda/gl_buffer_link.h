// An OpenGL buffer object registered with CUDA, so the engine writes vertex positions straight
// into what OpenGL draws (no host copy). Host-only header without OpenGL types: the translation
// unit that includes CUDA's GL interop header must not also include VTK's GLEW.
#pragma once

#include "sinew/cuda/cuda_engine.h"

#include <vector>

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
  void* resource() const { return resource_; }

private:
  unsigned int buffer_ = 0;
  void* resource_ = nullptr;  // cudaGraphicsResource_t
};

// One structure's surface points to write into a linked buffer.
struct SurfaceWrite {
  GlBufferLink* link = nullptr;
  Index mesh = 0;
  std::size_t pointCount = 0;
};

// Maps every link's buffer at once, has the engine write each structure's surface points into its
// buffer, and unmaps them, all on the engine's stream: OpenGL draws only after the writes, and the
// host does not wait. Throws when a buffer is smaller than its points.
void writeSurfaces(CudaEngine& engine, const std::vector<SurfaceWrite>& writes);

}  // namespace sinew::cuda
