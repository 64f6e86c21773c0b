// Finding, checking and loading plugins. Built-in plugins (linked in) and run-time plugins (shared
// libraries named sinew-plugin-NAME.so) go through the same path: the plugin registers into a
// scratch registry, what it registered is checked against its declared kind, and only then is it
// merged, so a broken plugin leaves nothing behind and the others still load.
#pragma once

#include "sinew/core/plugin_api.h"
#include "sinew/core/registry.h"

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace sinew {

struct PluginRecord {
  std::string name, version, summary;
  PluginKind kind = PluginKind::Force;
  std::filesystem::path file;           // empty for a built-in plugin
  std::vector<PluginComponent> components;  // what it registered
};

struct PluginFailure {
  std::filesystem::path file;
  std::string message;  // names the plugin and the problem
};

class PluginLoader {
public:
  // tools: the workstation's tool registry, or null where tools cannot be used (sinew-run).
  explicit PluginLoader(Registry& registry, ToolRegistry* tools = nullptr);

  // SINEW_PLUGIN_PATH (colon-separated directories), then the user's data directory
  // ($XDG_DATA_HOME, else ~/.local/share, /sinew/plugins), then the installed plugin directory
  // (plugins/ beside the installed libsinew_core).
  static std::vector<std::filesystem::path> defaultSearchPath();
  void setSearchPath(std::vector<std::filesystem::path> directories) { searchPath_ = std::move(directories); }
  const std::vector<std::filesystem::path>& searchPath() const { return searchPath_; }
  // "sinew-plugin-NAME.so"
  static std::string fileNameFor(std::string_view pluginName);

  // A plugin linked into the program. Throws std::logic_error when it is refused (a build bug).
  const PluginRecord& addBuiltin(const PluginInfo& info);
  // The named plugin, from the first search directory that has it; already loaded: returned as is.
  // Throws InputError naming the plugin (and file) when it is missing, broken or refused.
  const PluginRecord& load(std::string_view name);
  // One plugin file. Throws InputError naming the file.
  const PluginRecord& loadFile(const std::filesystem::path& file);
  // Every plugin file on the search path (a name found twice: the first wins). Failures are
  // collected in failures(); the other plugins still load.
  void loadAll();

  const std::vector<PluginRecord>& plugins() const { return plugins_; }
  const std::vector<PluginFailure>& failures() const { return failures_; }
  const PluginRecord* find(std::string_view name) const;

private:
  PluginRecord registerChecked(const PluginInfo& info, const std::string& where);

  Registry& registry_;
  ToolRegistry* tools_;
  std::vector<std::filesystem::path> searchPath_;
  std::vector<PluginRecord> plugins_;
  std::vector<PluginFailure> failures_;
};

}  // namespace sinew
