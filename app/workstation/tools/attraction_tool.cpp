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
  static int nearest(ToolContext& ctx, Index s, const ViewPointerEvent& e) {
    return nearestOnSlice(ctx.display, ctx.session.attractionPoints(s), e);
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
