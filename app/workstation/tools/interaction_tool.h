// Interaction tools: what a left click and drag in a slice view does. Each tool is a plugin of kind
// tool, registered explicitly by one function (registerNavigateTool, registerAttractionTool); the
// main window lists what the registry holds. Tools edit through the session, so every edit is undoable.
#pragma once

#include "slice_view.h"

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace sinew {

class SegmentationSession;
class DisplayScene;

struct ToolContext {
  SegmentationSession& session;
  DisplayScene& display;
  std::function<void()> cursorChanged;  // the crosshair moved: views follow
};

class InteractionTool {
public:
  virtual ~InteractionTool() = default;
  virtual void press(ToolContext& ctx, const ViewPointerEvent& e) = 0;
  virtual void drag(ToolContext& ctx, const ViewPointerEvent& e) = 0;
  virtual void release(ToolContext& ctx, const ViewPointerEvent& e) = 0;
  // The Delete key: remove what the tool has selected, if anything.
  virtual void deleteSelection(ToolContext&) {}
};

struct ToolDescriptor {
  std::string name;     // "attraction_points"
  std::string label;    // "Attraction points"
  std::string summary;  // tooltip
  std::string shortcut; // e.g. "A"
  std::function<std::unique_ptr<InteractionTool>()> create;
};

class ToolRegistry {
public:
  void add(ToolDescriptor d) { tools_.push_back(std::move(d)); }
  // Moves every tool of `other` here; throws std::invalid_argument naming the first name already
  // taken, before anything is moved.
  void merge(ToolRegistry&& other) {
    for (const auto& t : other.tools_)
      if (find(t.name)) throw std::invalid_argument("tool '" + t.name + "' is already registered");
    for (auto& t : other.tools_) tools_.push_back(std::move(t));
    other.tools_.clear();
  }
  const std::vector<ToolDescriptor>& tools() const { return tools_; }
  const ToolDescriptor* find(const std::string& name) const {
    for (const auto& t : tools_)
      if (t.name == name) return &t;
    return nullptr;
  }

private:
  std::vector<ToolDescriptor> tools_;
};

class PluginLoader;
void registerNavigateTool(ToolRegistry& registry);
void registerAttractionTool(ToolRegistry& registry);
void registerConstraintTools(ToolRegistry& registry);  // include points, exclude points
void registerLandmarkTool(ToolRegistry& registry);
// The built-in tools, added as built-in tool plugins (tools/builtin_tools.cpp); the loader must
// have been given the tool registry.
void addBuiltinTools(PluginLoader& loader);
// The same, for code that has only a tool registry (tests).
void registerBuiltinTools(ToolRegistry& registry);

}  // namespace sinew
