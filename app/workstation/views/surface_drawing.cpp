#include "surface_drawing.h"

#include <vtkPolyDataMapper.h>

namespace sinew {

vtkSmartPointer<vtkPolyDataMapper> SurfaceDrawing::makeMapper(Index) {
  return vtkSmartPointer<vtkPolyDataMapper>::New();
}

namespace {
class HostDrawing final : public SurfaceDrawing {
public:
  std::string name() const override { return "host"; }
  void updateSurfaces(SegmentationSession& session, DisplayScene& display) override {
    if (display.surfaceLevel() != session.level()) display.rebuildSurfaces(session);
    else display.updateSurfacePointsFromHost(session);
  }
  std::vector<ContourSegment> contour(SegmentationSession& session, Index structure, const SlicePlane& plane) override {
    session.syncHost();
    return hostContour(session.simulation().store(), structure, plane);
  }
};
}  // namespace

std::unique_ptr<SurfaceDrawing> makeHostDrawing() { return std::make_unique<HostDrawing>(); }

}  // namespace sinew
