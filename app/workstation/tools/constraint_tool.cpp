// Include points and exclude points (paper 001 section 4), two tools of one class: click in a slice
// view to place a point the selected structure must include (or exclude); press on one of the
// tool's points and drag to move it; Ctrl + click or Delete removes it. The attraction_points force
// pushes the structure live until each point lies on its side (the session adds the force when the
// scene lacks it). Shift + drag stays the slice views' window / level.
#include "point_tool.h"

namespace sinew {

namespace {
class ConstraintTool final : public PointTool {
public:
  explicit ConstraintTool(bool include) : include_(include) {}

protected:
  std::vector<Vec3> points(ToolContext& ctx, Index s) override {
    std::vector<Vec3> at;
    for (const ConstraintPoint& c : ctx.session.constraintPoints(s))
      if (c.include == include_) at.push_back(c.at);
    return at;
  }
  void add(ToolContext& ctx, Index s, const Vec3& at) override { ctx.session.addConstraintPoint(s, {at, include_}); }
  void move(ToolContext& ctx, Index s, int i, const Vec3& to, bool continuing) override {
    ctx.session.moveConstraintPoint(s, indexInSession(ctx, s, i), to, continuing);
  }
  void remove(ToolContext& ctx, Index s, int i) override {
    ctx.session.removeConstraintPoint(s, indexInSession(ctx, s, i));
  }

private:
  // The i-th point of this tool's kind, as an index into all the structure's points.
  int indexInSession(ToolContext& ctx, Index s, int i) const {
    const auto& all = ctx.session.constraintPoints(s);
    for (size_t k = 0; k < all.size(); ++k)
      if (all[k].include == include_ && i-- == 0) return int(k);
    return -1;
  }

  bool include_;
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
