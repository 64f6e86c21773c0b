#include "builtin_plugins.h"

namespace sinew {
void registerSmoothingForce(Registry&);
void registerShapePriorForce(Registry&);
void registerGradientForce(Registry&);
void registerIntensityProfileForce(Registry&);
void registerAttractionPointsForce(Registry&);
void registerDampedVerlet(Registry&);
void registerItkImageIO(Registry&);
void registerVtkMeshIO(Registry&);

void registerBuiltinPlugins(Registry& registry) {
  registerSmoothingForce(registry);
  registerShapePriorForce(registry);
  registerGradientForce(registry);
  registerIntensityProfileForce(registry);
  registerAttractionPointsForce(registry);
  registerDampedVerlet(registry);
  registerItkImageIO(registry);
  registerVtkMeshIO(registry);
}
}  // namespace sinew
