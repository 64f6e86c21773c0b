// Attraction points (paper 000 section 4.5): click in a slice view to place one for the selected
// structure, press on one and drag to move it, Ctrl + click or Delete to remove it. The closest
// vertex and its p-ring are pulled live by the attraction_points force.
#include "display_scene.h"
#include "interaction_tool.h"
#include "segmentation_session.h"

#include <cmath>

namespace sinew {

namespace {
class AttractionTool final : public InteractionTool {
public:
  void press(ToolContext& ctx, const ViewPointerEvent& e) override {
    ctx.session.endEdit();  // a new gesture
    const Index s = ctx.display.selected;
    structure_ = s;
    dragging_ = false;
    selected_ = nearest(ctx, s, e);
    if (e.control) {
      if (selected_ >= 0) ctx.session.removeAttractionPoint(s, selected_);
      selected_ = -1;
    } else if (selected_ < 0) {
      ctx.session.addAttractionPoint(s, e.world);
      selected_ = static_cast<int>(ctx.session.attractionPoints(s).size()) - 1;
    }
  }

  void drag(ToolContext& ctx, const ViewPointerEvent& e) override {
    if (selected_ < 0 || structure_ != ctx.display.selected) return;
    ctx.session.moveAttractionPoint(structure_, selected_, e.world, dragging_);
    dragging_ = true;
  }

  void release(ToolContext& ctx, const ViewPointerEvent&) override {
    dragging_ = false;
    ctx.session.endEdit();
  }

  void deleteSelection(ToolContext& ctx) override {
    if (selected_ < 0 || structure_ >= ctx.session.structureCount()) return;
    if (selected_ < static_cast<int>(ctx.session.attractionPoints(structure_).size()))
      ctx.session.removeAttractionPoint(structure_, selected_);
    selected_ = -1;
  }

private:
  // The selected structure's point nearest to the click on this slice, within the pick radius.
  static int nearest(ToolContext& ctx, Index s, const ViewPointerEvent& e) {
    const auto& points = ctx.session.attractionPoints(s);
    const double sliceHalf = ctx.display.geometry().spacing[e.axis];
    int best = -1;
    double bestD = e.pickRadiusMm;
    for (size_t i = 0; i < points.size(); ++i) {
      const Vec3 p = ctx.display.toDisplay(points[i]);
      if (std::abs(p[e.axis] - e.display[e.axis]) > sliceHalf) continue;
      Vec3 d = p - e.display;
      d[e.axis] = 0;
      if (d.norm() <= bestD) {
        bestD = d.norm();
        best = static_cast<int>(i);
      }
    }
    return best;
  }

  int selected_ = -1;
  Index structure_ = 0;
  bool dragging_ = false;
};
}  // namespace

void registerAttractionTool(ToolRegistry& registry) {
  registry.add({"attraction_points", "Attraction points",
                "Click to place a point that pulls the selected structure; drag to move it; Ctrl+click or "
                "Delete removes it",
                "A", [] { return std::make_unique<AttractionTool>(); }});
}

}  // namespace sinew
