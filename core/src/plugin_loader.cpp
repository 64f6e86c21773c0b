#include "sinew/core/plugin_loader.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <set>
#include <sstream>

namespace fs = std::filesystem;

namespace sinew {

const char* pluginKindName(PluginKind kind) {
  switch (kind) {
    case PluginKind::Force: return "force";
    case PluginKind::Integrator: return "integrator";
    case PluginKind::ImageIO: return "image-io";
    case PluginKind::MeshIO: return "mesh-io";
    case PluginKind::Tool: return "tool";
  }
  return "unknown";
}

namespace {
constexpr std::string_view kPrefix = "sinew-plugin-", kSuffix = ".so";

// "sinew-plugin-NAME.so" -> "NAME"; "" for any other file name.
std::string pluginNameOf(const fs::path& file) {
  const std::string f = file.filename().string();
  if (f.size() <= kPrefix.size() + kSuffix.size() || !f.starts_with(kPrefix) || !f.ends_with(kSuffix)) return {};
  return f.substr(kPrefix.size(), f.size() - kPrefix.size() - kSuffix.size());
}

// How many components of each kind a registry holds, for the declared-kind check.
std::string kindProblem(const Registry& r, PluginKind kind) {
  const std::size_t counts[] = {r.forces().size(), r.integrators().size(), r.imageIOs().size(), r.meshIOs().size()};
  const PluginKind kinds[] = {PluginKind::Force, PluginKind::Integrator, PluginKind::ImageIO, PluginKind::MeshIO};
  for (int k = 0; k < 4; ++k)
    if (kinds[k] != kind && counts[k] > 0)
      return std::string("it declares kind ") + pluginKindName(kind) + " but registered a " + pluginKindName(kinds[k]);
  if (kind != PluginKind::Tool && r.empty())
    return std::string("it declares kind ") + pluginKindName(kind) + " but registered nothing";
  return {};
}

// The directory of the shared library this function is in (libsinew_core).
fs::path coreLibraryDirectory() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<const void*>(&pluginNameOf), &info) == 0 || !info.dli_fname) return {};
  std::error_code ec;
  const fs::path lib = fs::canonical(info.dli_fname, ec);
  return ec ? fs::path() : lib.parent_path();
}
}  // namespace

PluginLoader::PluginLoader(Registry& registry, ToolRegistry* tools)
    : registry_(registry), tools_(tools), searchPath_(defaultSearchPath()) {}

std::vector<fs::path> PluginLoader::defaultSearchPath() {
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("SINEW_PLUGIN_PATH")) {
    std::istringstream in(env);
    for (std::string d; std::getline(in, d, ':');)
      if (!d.empty()) dirs.emplace_back(d);
  }
  if (const char* data = std::getenv("XDG_DATA_HOME"); data && *data)
    dirs.push_back(fs::path(data) / "sinew" / "plugins");
  else if (const char* home = std::getenv("HOME"); home && *home)
    dirs.push_back(fs::path(home) / ".local" / "share" / "sinew" / "plugins");
  if (const fs::path lib = coreLibraryDirectory(); !lib.empty()) dirs.push_back(lib / "plugins");
  return dirs;
}

std::string PluginLoader::fileNameFor(std::string_view pluginName) {
  return std::string(kPrefix) + std::string(pluginName) + std::string(kSuffix);
}

const PluginRecord* PluginLoader::find(std::string_view name) const {
  for (const PluginRecord& p : plugins_)
    if (p.name == name) return &p;
  return nullptr;
}

PluginRecord PluginLoader::registerChecked(const PluginInfo& info, const std::string& where) {
  const std::string who = "plugin '" + std::string(info.name ? info.name : "?") + "'" + where;
  if (!info.name || !*info.name || !info.registerComponents) throw InputError(who + ": its PluginInfo is incomplete");
  if (find(info.name)) throw InputError(who + ": a plugin of that name is already loaded");
  Registry scratch;
  PluginHost host{scratch, tools_};
  try {
    info.registerComponents(host);
  } catch (const std::exception& e) {
    throw InputError(who + ": registration failed: " + e.what());
  }
  if (const std::string problem = kindProblem(scratch, info.kind); !problem.empty())
    throw InputError(who + ": " + problem);
  PluginRecord record{info.name, info.version ? info.version : "", info.summary ? info.summary : "", info.kind, {},
                      scratch.components()};
  try {
    registry_.merge(std::move(scratch));
  } catch (const InputError& e) {
    throw InputError(who + ": " + e.what());
  }
  return record;
}

const PluginRecord& PluginLoader::addBuiltin(const PluginInfo& info) {
  try {
    plugins_.push_back(registerChecked(info, " (built in)"));
  } catch (const InputError& e) {
    throw std::logic_error(e.what());
  }
  return plugins_.back();
}

const PluginRecord& PluginLoader::loadFile(const fs::path& file) {
  const std::string fileName = pluginNameOf(file);
  const std::string label = fileName.empty() ? file.filename().string() : fileName;
  const std::string where = file.string() + ": plugin '" + label + "'";
  void* handle = ::dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* why = ::dlerror();
    throw InputError(where + " cannot be loaded: " + (why ? why : "unknown dlopen error"));
  }
  auto refuse = [&](const std::string& message) {
    ::dlclose(handle);
    throw InputError(where + " " + message);
  };
  using AbiFn = int (*)();
  using InfoFn = const PluginInfo* (*)();
  auto abi = reinterpret_cast<AbiFn>(::dlsym(handle, "sinew_plugin_abi_version"));
  if (!abi) refuse("is not a Sinew plugin: it has no sinew_plugin_abi_version entry point (declare it with sinew_add_plugin)");
  if (const int theirs = abi(); theirs != SINEW_PLUGIN_ABI_VERSION)
    refuse("was built for Sinew plugin ABI " + std::to_string(theirs) + ", but this Sinew provides ABI " +
           std::to_string(SINEW_PLUGIN_ABI_VERSION) + ": rebuild it against this Sinew's SDK");
  auto infoFn = reinterpret_cast<InfoFn>(::dlsym(handle, "sinew_plugin_info"));
  const PluginInfo* info = infoFn ? infoFn() : nullptr;
  if (!info) refuse("has no sinew_plugin_info entry point");
  if (!fileName.empty() && fileName != (info->name ? info->name : ""))
    refuse("declares the name '" + std::string(info->name ? info->name : "") + "', which does not match its file name");
  // The code stays loaded from here on, even when refused: a failed registration may have made
  // objects whose destructors live in it.
  PluginRecord record = registerChecked(*info, " (" + file.string() + ")");
  record.file = file;
  plugins_.push_back(std::move(record));
  return plugins_.back();
}

const PluginRecord& PluginLoader::load(std::string_view name) {
  if (const PluginRecord* p = find(name)) return *p;
  const std::string fileName = fileNameFor(name);
  std::error_code ec;
  for (const fs::path& dir : searchPath_)
    if (fs::is_regular_file(dir / fileName, ec)) return loadFile(dir / fileName);
  std::string searched;
  for (const fs::path& dir : searchPath_) searched += (searched.empty() ? "" : ", ") + dir.string();
  throw InputError("plugin '" + std::string(name) + "' not found: no " + fileName + " in " +
                   (searched.empty() ? std::string("(no directories)") : searched) +
                   " (SINEW_PLUGIN_PATH adds directories)");
}

void PluginLoader::loadAll() {
  // As load(): of the files of one name, the first on the search path is the plugin, whether it
  // loads or is refused; later ones are never tried.
  std::set<std::string> seen;
  for (const PluginRecord& p : plugins_) seen.insert(p.name);
  for (const fs::path& dir : searchPath_) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) continue;
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(dir, ec))
      if (!pluginNameOf(entry.path()).empty()) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    for (const fs::path& file : files) {
      const std::string name = pluginNameOf(file);
      if (const PluginRecord* p = find(name); p && p->file.empty()) {
        failures_.push_back({file, file.string() + ": plugin '" + name + "' has the name of a built-in plugin"});
        continue;
      }
      if (!seen.insert(name).second) continue;  // an earlier directory has it
      try {
        loadFile(file);
      } catch (const std::exception& e) {
        failures_.push_back({file, e.what()});
      }
    }
  }
}

}  // namespace sinew
