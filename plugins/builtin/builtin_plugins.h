#pragma once

#include "sinew/core/registry.h"

namespace sinew {
// Registers every built-in force and integrator.
void registerBuiltinPlugins(Registry& registry);
}  // namespace sinew
