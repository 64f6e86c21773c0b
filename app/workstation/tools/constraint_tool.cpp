// Include points and exclude points (paper 001 section 4), two tools of one class: click in a slice
// view to place a point the selected structure must include (or exclude); press on one of the
// tool's points and drag to move it; Ctrl + click or Delete removes it. The attraction_points force
// pushes the structure live until each point lies on its side (the session adds the force when the
// scene lacks it). Shift + drag stays the slice views' window / level.
#include "display_scene.h"
#include "interaction_tool.h"
#include "segmentation_session.h"

namespace sinew {

namespace {
class ConstraintTool final : public InteractionTool {
public:
  explicit ConstraintTool(bool include) : include_(include) {}

  void press(ToolContext& ctx, const ViewPointerEvent& e) override {
    ctx.session.endEdit();  // a new gesture
    const Index s = ctx.display.selected;
    structure_ = s;
    dragging_ = false;
    selected_ = nearest(ctx, s, e);
    if (e.control) {
      if (selected_ >= 0) ctx.session.removeConstraintPoint(s, selected_);
      selected_ = -1;
    } else if (selected_ < 0) {
      ctx.session.addConstraintPoint(s, {e.world, include_});
      selected_ = static_cast<int>(ctx.session.constraintPoints(s).size()) - 1;
    }
  }

  void drag(ToolContext& ctx, const ViewPointerEvent& e) override {
    if (selected_ < 0 || structure_ != ctx.display.selected) return;
    ctx.session.moveConstraintPoint(structure_, selected_, e.world, dragging_);
    dragging_ = true;
  }

  void release(ToolContext& ctx, const ViewPointerEvent&) override {
    dragging_ = false;
    ctx.session.endEdit();
  }

  void deleteSelection(ToolContext& ctx) override {
    if (selected_ < 0 || structure_ >= ctx.session.structureCount()) return;
    if (selected_ < static_cast<int>(ctx.session.constraintPoints(structure_).size()))
      ctx.session.removeConstraintPoint(structure_, selected_);
    selected_ = -1;
  }

private:
  // The nearest of this tool's kind of points, as an index into all the structure's points.
  int nearest(ToolContext& ctx, Index s, const ViewPointerEvent& e) const {
    std::vector<Vec3> at;
    std::vector<int> index;
    const auto& points = ctx.session.constraintPoints(s);
    for (size_t i = 0; i < points.size(); ++i)
      if (points[i].include == include_) {
        at.push_back(points[i].at);
        index.push_back(int(i));
      }
    const int k = nearestOnSlice(ctx.display, at, e);
    return k < 0 ? -1 : index[k];
  }

  bool include_;
  int selected_ = -1;
  Index structure_ = 0;
  bool dragging_ = false;
};
}  // namespace

void registerConstraintTools(ToolRegistry& registry) {
  registry.add({"include_points", "Include points",
                "Click to place a point the selected structure must include; drag to move it; Ctrl+click or Delete "
                "removes it",
                "I", [] { return std::make_unique<ConstraintTool>(true); }});
  registry.add({"exclude_points", "Exclude points",
                "Click to place a point the selected structure must exclude; drag to move it; Ctrl+click or Delete "
                "removes it",
                "E", [] { return std::make_unique<ConstraintTool>(false); }});
}

}  // namespace sinew
