#include "builtin_plugins.h"

const sinew::PluginInfo* sinew_plugin_info_image_io_itk();
const sinew::PluginInfo* sinew_plugin_info_mesh_io_vtk();

namespace sinew {
void addBuiltinPlugins(PluginLoader& loader) {
  addBuiltinForces(loader);
  loader.addBuiltin(*sinew_plugin_info_image_io_itk());
  loader.addBuiltin(*sinew_plugin_info_mesh_io_vtk());
}

void registerBuiltinPlugins(Registry& registry) {
  PluginLoader loader(registry);
  addBuiltinPlugins(loader);
}
}  // namespace sinew
