#pragma once

#include "sinew/core/registry.h"

namespace sinew {
// Registers the built-in forces and integrators (no IO: no ITK or VTK needed).
void registerBuiltinForces(Registry& registry);
// Registers every built-in plugin: forces, integrators, image IO (ITK), mesh IO (VTK).
void registerBuiltinPlugins(Registry& registry);
}  // namespace sinew
