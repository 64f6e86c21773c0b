// The CUDA-OpenGL interop drawing path: the 3D view's vertex buffers are registered with CUDA and
// written by a kernel from the device store each frame; slice contours are computed on the device
// and only their segments come to the host. Built only with the CUDA backend.
#pragma once

#include "surface_drawing.h"

namespace sinew {

// Null when the session's backend is not the CUDA engine.
std::unique_ptr<SurfaceDrawing> makeInteropDrawing(SegmentationSession& session);

}  // namespace sinew
