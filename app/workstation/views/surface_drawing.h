// How the views get the meshes from the store. The host path copies positions into VTK's arrays
// (downloading them first when a GPU backend runs the steps); the CUDA interop path
// (interop_drawing.h) writes the 3D view's vertex buffers from the device and computes contours
// there, so no mesh crosses to the host.
#pragma once

#include "display_scene.h"
#include "segmentation_session.h"

#include <vtkSmartPointer.h>

#include <memory>
#include <string>

class vtkPolyDataMapper;

namespace sinew {

class SurfaceDrawing {
public:
  virtual ~SurfaceDrawing() = default;
  virtual std::string name() const = 0;
  // The mapper that draws structure s's surface in the 3D view.
  virtual vtkSmartPointer<vtkPolyDataMapper> makeMapper(Index structure);
  // Brings the surfaces up to date with the session (called when its revision moved).
  virtual void updateSurfaces(SegmentationSession& session, DisplayScene& display) = 0;
  // Right before the 3D view renders (its context is current).
  virtual void beforeRender(SegmentationSession&, DisplayScene&) {}
  // Where every structure's surface crosses the plane (segments per structure).
  virtual std::vector<std::vector<ContourSegment>> contours(SegmentationSession& session, const SlicePlane& plane) = 0;
};

std::unique_ptr<SurfaceDrawing> makeHostDrawing();

}  // namespace sinew
