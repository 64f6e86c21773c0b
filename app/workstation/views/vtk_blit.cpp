#include "vtk_blit.h"

#include <vtk_glew.h>
#include <vtkGenericOpenGLRenderWindow.h>
#include <vtkOpenGLState.h>

namespace sinew {

void blitToFramebuffer(vtkGenericOpenGLRenderWindow* window, unsigned int target, int w, int h) {
  // Through VTK's state cache, so VTK's idea of the bound framebuffer stays right.
  vtkOpenGLState* state = window->GetState();
  state->PushDrawFramebufferBinding();
  state->vtkglBindFramebuffer(GL_DRAW_FRAMEBUFFER, target);
  state->vtkglViewport(0, 0, w, h);
  state->vtkglScissor(0, 0, w, h);
  window->BlitDisplayFramebuffer(0, 0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  state->PopDrawFramebufferBinding();
}

}  // namespace sinew
