#include "builtin_plugins.h"

namespace sinew {
void registerItkImageIO(Registry&);
void registerVtkMeshIO(Registry&);

void registerBuiltinPlugins(Registry& registry) {
  registerBuiltinForces(registry);
  registerItkImageIO(registry);
  registerVtkMeshIO(registry);
}
}  // namespace sinew
