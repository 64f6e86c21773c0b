#include "interop_drawing.h"

#include "interop_mapper.h"
#include "sinew/cuda/gl_buffer_link.h"

#include <vtkPoints.h>
#include <vtkPolyData.h>

#include <map>

namespace sinew {

namespace {
class InteropDrawing final : public SurfaceDrawing {
public:
  explicit InteropDrawing(cuda::CudaEngine& engine) : engine_(engine) {}
  std::string name() const override { return "interop"; }

  vtkSmartPointer<vtkPolyDataMapper> makeMapper(Index s) override {
    auto m = vtkSmartPointer<InteropPolyDataMapper>::New();
    mappers_[s] = {m, nullptr, 0, 0};
    return m;
  }

  // Only the topology goes through the host (after a level change); points are written on the GPU.
  void updateSurfaces(SegmentationSession& session, DisplayScene& display) override {
    if (display.surfaceLevel() != session.level()) display.rebuildSurfaces(session);
    revision_ = session.revision();
  }

  void beforeRender(SegmentationSession&, DisplayScene& display) override {
    std::vector<cuda::SurfaceWrite> writes;
    std::vector<Slot*> written;
    for (auto& [s, slot] : mappers_) {
      const unsigned int buffer = slot.mapper->positionBuffer();
      if (buffer == 0) continue;  // not built yet: VTK uploads the host points this time
      if (!slot.link || slot.link->buffer() != buffer || slot.builds != slot.mapper->buildCount()) {
        slot.link = std::make_unique<cuda::GlBufferLink>(buffer);
        slot.builds = slot.mapper->buildCount();
        slot.written = 0;  // a rebuild uploaded host points: write again
      }
      if (slot.written == revision_) continue;
      writes.push_back({slot.link.get(), s, static_cast<std::size_t>(display.surface(s)->GetNumberOfPoints())});
      written.push_back(&slot);
    }
    cuda::writeSurfaces(engine_, writes);
    for (Slot* slot : written) slot->written = revision_;  // only once the writes went through
  }

  std::vector<std::vector<ContourSegment>> contours(SegmentationSession&, const SlicePlane& plane) override {
    const std::vector<std::vector<Vec3>> points = engine_.contourSegments(plane.normal, plane.offset);
    std::vector<std::vector<ContourSegment>> out(points.size());
    for (size_t s = 0; s < points.size(); ++s) {
      out[s].resize(points[s].size() / 2);
      for (size_t i = 0; i < out[s].size(); ++i) out[s][i] = {points[s][2 * i], points[s][2 * i + 1]};
    }
    return out;
  }

private:
  struct Slot {
    vtkSmartPointer<InteropPolyDataMapper> mapper;
    std::unique_ptr<cuda::GlBufferLink> link;
    unsigned long builds = 0;
    std::uint64_t written = 0;
  };
  cuda::CudaEngine& engine_;
  std::map<Index, Slot> mappers_;
  std::uint64_t revision_ = 1;
};
}  // namespace

std::unique_ptr<SurfaceDrawing> makeInteropDrawing(SegmentationSession& session) {
  auto* engine = dynamic_cast<cuda::CudaEngine*>(session.backend());
  if (!engine) return nullptr;
  return std::make_unique<InteropDrawing>(*engine);
}

}  // namespace sinew
