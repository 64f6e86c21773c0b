// The default tool: click or drag in a slice view to move the crosshair, which moves the other
// views to the clicked point.
#include "display_scene.h"
#include "interaction_tool.h"

namespace sinew {

namespace {
class NavigateTool final : public InteractionTool {
public:
  void press(ToolContext& ctx, const ViewPointerEvent& e) override { move(ctx, e); }
  void drag(ToolContext& ctx, const ViewPointerEvent& e) override { move(ctx, e); }
  void release(ToolContext&, const ViewPointerEvent&) override {}

private:
  static void move(ToolContext& ctx, const ViewPointerEvent& e) {
    for (int a = 0; a < 3; ++a)
      if (a != e.axis) ctx.display.cursor[a] = ctx.display.snapToSlice(a, e.display[a]);
    ctx.cursorChanged();
  }
};
}  // namespace

void registerNavigateTool(ToolRegistry& registry) {
  registry.add({"navigate", "Navigate", "Click or drag to move the crosshair; the other views follow", "N",
                [] { return std::make_unique<NavigateTool>(); }});
}

}  // namespace sinew
