#pragma once

#include "sinew/core/plugin_loader.h"

namespace sinew {
// Adds the built-in forces and integrators (no IO: no ITK or VTK needed) through the loader, as
// built-in plugins.
void addBuiltinForces(PluginLoader& loader);
// Adds every built-in plugin: forces, integrators, image IO (ITK), mesh IO (VTK).
void addBuiltinPlugins(PluginLoader& loader);

// The same, for code that needs only the registry (tests, benchmarks).
void registerBuiltinForces(Registry& registry);
void registerBuiltinPlugins(Registry& registry);
}  // namespace sinew
