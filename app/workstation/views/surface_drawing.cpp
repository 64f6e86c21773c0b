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
  std::vector<std::vector<ContourSegment>> contours(SegmentationSession& session, const SlicePlane& plane) override {
    session.syncHost();
    MeshStore& store = session.simulation().store();
    std::vector<std::vector<ContourSegment>> out(store.meshCount());
    for (Index s = 0; s < store.meshCount(); ++s) out[s] = hostContour(store, s, plane);
    return out;
  }
};
}  // namespace

std::unique_ptr<SurfaceDrawing> makeHostDrawing() { return std::make_unique<HostDrawing>(); }

}  // namespace sinew
