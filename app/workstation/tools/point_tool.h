// What the point-placing tools share (attraction points; include and exclude points): click in a
// slice view to place a point for the selected structure, press on one of the tool's points and
// drag to move it (one undo step per drag), Ctrl + click or Delete removes it. Subclasses say which
// points are the tool's and how the session edits them.
#pragma once

#include "display_scene.h"
#include "interaction_tool.h"
#include "segmentation_session.h"

namespace sinew {

class PointTool : public InteractionTool {
public:
  void press(ToolContext& ctx, const ViewPointerEvent& e) override {
    ctx.session.endEdit();  // a new gesture
    const Index s = ctx.display.selected;
    structure_ = s;
    dragging_ = false;
    selected_ = nearestOnSlice(ctx.display, points(ctx, s), e);
    if (e.control) {
      if (selected_ >= 0) remove(ctx, s, selected_);
      selected_ = -1;
    } else if (selected_ < 0) {
      add(ctx, s, e.world);
      selected_ = static_cast<int>(points(ctx, s).size()) - 1;
    }
  }

  void drag(ToolContext& ctx, const ViewPointerEvent& e) override {
    if (selected_ < 0 || structure_ != ctx.display.selected) return;
    move(ctx, structure_, selected_, e.world, dragging_);
    dragging_ = true;
  }

  void release(ToolContext& ctx, const ViewPointerEvent&) override {
    dragging_ = false;
    ctx.session.endEdit();
  }

  void deleteSelection(ToolContext& ctx) override {
    if (selected_ < 0 || structure_ >= ctx.session.structureCount()) return;
    if (selected_ < static_cast<int>(points(ctx, structure_).size())) remove(ctx, structure_, selected_);
    selected_ = -1;
  }

protected:
  // The tool's points of structure s (world mm); the index i below is into this list.
  virtual std::vector<Vec3> points(ToolContext& ctx, Index s) = 0;
  virtual void add(ToolContext& ctx, Index s, const Vec3& at) = 0;
  virtual void move(ToolContext& ctx, Index s, int i, const Vec3& to, bool continuing) = 0;
  virtual void remove(ToolContext& ctx, Index s, int i) = 0;

private:
  int selected_ = -1;
  Index structure_ = 0;
  bool dragging_ = false;
};

}  // namespace sinew
