// Attraction points (paper 000 section 4.5): click in a slice view to place one for the selected
// structure, press on one and drag to move it, Ctrl + click or Delete to remove it. The closest
// vertex and its p-ring are pulled live by the attraction_points force.
#include "point_tool.h"

namespace sinew {

namespace {
class AttractionTool final : public PointTool {
protected:
  std::vector<Vec3> points(ToolContext& ctx, Index s) override { return ctx.session.attractionPoints(s); }
  void add(ToolContext& ctx, Index s, const Vec3& at) override { ctx.session.addAttractionPoint(s, at); }
  void move(ToolContext& ctx, Index s, int i, const Vec3& to, bool continuing) override {
    ctx.session.moveAttractionPoint(s, i, to, continuing);
  }
  void remove(ToolContext& ctx, Index s, int i) override { ctx.session.removeAttractionPoint(s, i); }
};
}  // namespace

void registerAttractionTool(ToolRegistry& registry) {
  registry.add({"attraction_points", "Attraction points",
                "Click to place a point that pulls the selected structure; drag to move it; Ctrl+click or "
                "Delete removes it",
                "A", [] { return std::make_unique<AttractionTool>(); }});
}

}  // namespace sinew
