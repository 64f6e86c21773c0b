// The one VTK OpenGL call the Qt widget needs, in its own translation unit: VTK's GLEW and Qt's
// OpenGL headers cannot be included together.
#pragma once

class vtkGenericOpenGLRenderWindow;

namespace sinew {

// Copies what VTK rendered (its display framebuffer) into framebuffer object `target`.
void blitToFramebuffer(vtkGenericOpenGLRenderWindow* window, unsigned int target, int width, int height);

}  // namespace sinew
