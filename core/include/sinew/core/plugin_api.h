// The plugin entry point's contract. Every plugin, built in or loaded at run time, is described by
// one PluginInfo that sinew_add_plugin() (cmake/SinewPlugin.cmake) generates: the plugin author
// writes only a registration function. A run-time plugin exports two C symbols:
//   int sinew_plugin_abi_version(void);               read first, never changes shape
//   const sinew::PluginInfo* sinew_plugin_info(void); read only when the ABI version matches
// A built-in plugin has the same two functions with the plugin's name appended, linked statically.
#pragma once

// Raised whenever a change to an installed header changes what a compiled plugin relies on (a
// class layout, a virtual function, the PluginInfo fields). Plugins built for another value are
// refused at load time.
#define SINEW_PLUGIN_ABI_VERSION 10

#include <string>

namespace sinew {

class Registry;
class ToolRegistry;  // the workstation's interaction tools (app/workstation/tools)

enum class PluginKind { Force, Integrator, ImageIO, MeshIO, Tool };
// "force", "integrator", "image-io", "mesh-io", "tool".
const char* pluginKindName(PluginKind kind);

// What a plugin's registration may add to. `tools` is null outside the workstation: a tool plugin
// loaded by sinew-run registers nothing.
struct PluginHost {
  Registry& registry;
  ToolRegistry* tools = nullptr;
};

// One thing a plugin registered: a force, an integrator, an image or mesh IO.
struct PluginComponent {
  PluginKind kind;
  std::string name;
  bool operator==(const PluginComponent&) const = default;
};

struct PluginInfo {
  const char* name;     // unique; the scene's "plugins" list and the file name use it
  const char* version;  // the plugin's own version
  PluginKind kind;
  const char* summary;
  void (*registerComponents)(PluginHost& host);
};

}  // namespace sinew
