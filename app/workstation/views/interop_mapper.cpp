#include "interop_mapper.h"

#include <vtkObjectFactory.h>
#include <vtkOpenGLVertexBufferObject.h>
#include <vtkOpenGLVertexBufferObjectGroup.h>

namespace sinew {

vtkStandardNewMacro(InteropPolyDataMapper);

InteropPolyDataMapper::InteropPolyDataMapper() {
  SetVBOShiftScaleMethod(vtkOpenGLVertexBufferObject::DISABLE_SHIFT_SCALE);
}

unsigned int InteropPolyDataMapper::positionBuffer() {
  vtkOpenGLVertexBufferObject* vbo = VBOs->GetVBO("vertexMC");
  return vbo ? static_cast<unsigned int>(vbo->GetHandle()) : 0u;
}

void InteropPolyDataMapper::BuildBufferObjects(vtkRenderer* ren, vtkActor* act) {
  Superclass::BuildBufferObjects(ren, act);
  ++builds_;
}

}  // namespace sinew
