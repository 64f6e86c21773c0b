#include "builtin_plugins.h"

namespace sinew {
void registerSmoothingForce(Registry&);
void registerShapePriorForce(Registry&);
void registerGradientForce(Registry&);
void registerIntensityProfileForce(Registry&);
void registerAttractionPointsForce(Registry&);
void registerDampedVerlet(Registry&);
void registerImplicitEuler(Registry&);

void registerBuiltinForces(Registry& registry) {
  registerSmoothingForce(registry);
  registerShapePriorForce(registry);
  registerGradientForce(registry);
  registerIntensityProfileForce(registry);
  registerAttractionPointsForce(registry);
  registerDampedVerlet(registry);
  registerImplicitEuler(registry);
}
}  // namespace sinew
