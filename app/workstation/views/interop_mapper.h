// VTK's polydata mapper with its position buffer exposed, for CUDA to write (VTK 9.1 keeps it as
// the "vertexMC" buffer of the mapper's VBO group). Coordinates are uploaded as they are (no
// shift/scale), so what CUDA writes means the same as what VTK would upload; every rebuild may
// replace the buffer, so users re-register when buildCount() moves.
#pragma once

#include <vtkOpenGLPolyDataMapper.h>

namespace sinew {

class InteropPolyDataMapper : public vtkOpenGLPolyDataMapper {
public:
  static InteropPolyDataMapper* New();
  vtkTypeMacro(InteropPolyDataMapper, vtkOpenGLPolyDataMapper)

  // The OpenGL name of the position buffer; 0 before the first render built it.
  unsigned int positionBuffer();
  unsigned long buildCount() const { return builds_; }

protected:
  InteropPolyDataMapper();
  void BuildBufferObjects(vtkRenderer* ren, vtkActor* act) override;

private:
  unsigned long builds_ = 0;
};

}  // namespace sinew
