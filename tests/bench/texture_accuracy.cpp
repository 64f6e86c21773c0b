// Is hardware trilinear filtering (texture units, 8-bit interpolation weights) accurate enough for
// the intensity-profile force? texture_accuracy_kernels.cu samples the same search lines with exact
// trilinear interpolation and through a 3D texture, and compares the NCC scores and chosen offsets.
//   texture_accuracy IMAGE [lines=200000]
#include "builtin_plugins.h"

#include <cstdio>
#include <cstdlib>

void compareTextureSampling(const char* name, const float* image, const int size[3], const float spacing[3], int count);

int main(int argc, char** argv) {
  if (argc < 2) {
    std::printf("usage: texture_accuracy IMAGE [lines]\n");
    return 2;
  }
  sinew::Registry registry;
  sinew::registerBuiltinPlugins(registry);
  const sinew::Image3D im = registry.imageIOFor(argv[1]).readImage(argv[1]);
  const auto& g = im.geometry();
  const float spacing[3] = {float(g.spacing[0]), float(g.spacing[1]), float(g.spacing[2])};
  compareTextureSampling(argv[1], im.voxels().data(), g.size.data(), spacing, argc > 2 ? std::atoi(argv[2]) : 200000);
  return 0;
}
