// Landmark pairs (paper 000 section 5, paper 001 section 3): press where the model has an
// anatomical point and drag to where that point is in the image; a press on a pair's image end
// picks it up to move it, Ctrl + click or Delete removes it. Simulation > Initialise from Landmarks
// then maps the model through the pairs (SegmentationSession::initialiseFromLandmarks).
#include "display_scene.h"
#include "interaction_tool.h"
#include "segmentation_session.h"

#include <cmath>

namespace sinew {

namespace {
class LandmarkTool final : public InteractionTool {
public:
  void press(ToolContext& ctx, const ViewPointerEvent& e) override {
    ctx.session.endEdit();  // a new gesture
    selected_ = nearest(ctx, e);
    if (e.control) {
      if (selected_ >= 0) ctx.session.removeLandmark(selected_);
      selected_ = -1;
    } else if (selected_ < 0) {
      ctx.session.addLandmark(e.world, e.world);
      selected_ = static_cast<int>(ctx.session.landmarks().size()) - 1;
    }
    dragging_ = false;
  }

  void drag(ToolContext& ctx, const ViewPointerEvent& e) override {
    if (selected_ < 0 || selected_ >= static_cast<int>(ctx.session.landmarks().size())) return;
    ctx.session.moveLandmark(selected_, e.world, dragging_);
    dragging_ = true;
  }

  void release(ToolContext& ctx, const ViewPointerEvent&) override {
    dragging_ = false;
    ctx.session.endEdit();
  }

  void deleteSelection(ToolContext& ctx) override {
    if (selected_ >= 0 && selected_ < static_cast<int>(ctx.session.landmarks().size()))
      ctx.session.removeLandmark(selected_);
    selected_ = -1;
  }

private:
  // The pair whose image end is nearest the click on this slice, within the pick radius.
  static int nearest(ToolContext& ctx, const ViewPointerEvent& e) {
    std::vector<Vec3> ends;
    for (const PlacedLandmark& l : ctx.session.landmarks()) ends.push_back(l.to);
    return nearestOnSlice(ctx.display, ends, e);
  }

  int selected_ = -1;
  bool dragging_ = false;
};
}  // namespace

void registerLandmarkTool(ToolRegistry& registry) {
  registry.add({"landmarks", "Landmarks",
                "Press where the model has a point and drag to where it is in the image; drag a pair's end to move it; "
                "Ctrl+click or Delete removes it; Simulation > Initialise from Landmarks maps the model through them",
                "K", [] { return std::make_unique<LandmarkTool>(); }});
}

}  // namespace sinew
