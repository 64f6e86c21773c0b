// Synthetic shapes and images with known answers, shared by the test suites and the benchmark.
#pragma once

#include "builtin_plugins.h"
#include "sinew/core/image.h"
#include "sinew/core/simulation.h"
#include "sinew/core/surface_distance.h"

#include <vector>

namespace sinew::testing {

// Built-in forces and integrators only (synthetic.cpp), and every built-in plugin, IO included
// (builtin_registry.cpp, in sinew_test_support_io).
const Registry& forceRegistry();
const Registry& builtinRegistry();

// Adds independent Gaussian noise (sigma per axis) with a fixed seed.
std::vector<Vec3> withNoise(std::vector<Vec3> points, float sigma, unsigned seed);

// A structure of `levels` levels whose coarsest mesh is the dual of an icosphere of `level`.
StructureSpec sphereStructure(const std::string& name, int level, float radius, const Vec3& centre,
                              int levels = 1);

// A 20 mm sphere (the dual of a level-3 icosphere), its own reference shape, with a spike: vertex 0
// pushed `edges` of its mean edge lengths outward at the start, or in the reference. `limit`: the
// shape prior's largest pull there at the start, kPriorReach times the longest edge of vertex 0's
// neighbours' triangle (limitedPriorPull).
struct SpikedSphere {
  StructureSpec spec;
  float limit = 0.0f;
};
SpikedSphere spikedSphere(float edges, bool inReference = false);

// Two spheres (level-3 icosphere duals), "a" of radius 10 mm at the origin and "b" of `radiusB`
// `gap` mm along +x, each its own reference shape, added to `sim` in that order (the collision
// tests' pair).
void addSpherePair(Simulation& sim, float gap, float radiusB = 10.0f);

// Maps a point of the unit sphere around `centre` onto the ellipsoid with these radii.
Vec3 onEllipsoid(const Vec3& unitDirection, const Vec3& centre, const Vec3& radii);
// Dense triangle surface of the ellipsoid (icosphere of `level` mapped onto it).
TriangleMesh ellipsoidSurface(const Vec3& centre, const Vec3& radii, int level = 5);

// A capsule (a tube with hemispherical ends) of this radius, its cylinder `length` long along z
// around `centre`: rings of `around` points about `around / (2 pi)` per radius apart, outward.
TriangleMesh capsuleSurface(float radius, float length, int around, const Vec3& centre = Vec3::Zero());

struct EllipsoidImageSpec {
  int size = 64;
  float spacing = 1.0f;
  Vec3 centre{32.0f, 32.0f, 32.0f};
  Vec3 radii{20.0f, 15.0f, 12.0f};
  float inside = 100.0f;
  float outside = 30.0f;
  float edgeWidth = 1.0f;   // mm, width of the smooth step across the boundary
  float biasAmplitude = 0.2f;  // multiplicative smooth bias, 1 +- amplitude across the image
  float noiseSigma = 8.0f;
  unsigned seed = 1;
};
Image3D ellipsoidImage(const EllipsoidImageSpec& spec);

// Mean distance of the points to their least-squares sphere, and that sphere's radius.
struct SphereFit {
  Vec3 centre;
  double radius = 0.0;
  double meanDeviation = 0.0;
};
SphereFit fitSphere(std::span<const Vec3> points);

// The benchmarks' stand-in for the seed's four bones: closed meshes of 1,280 + 1,280 + 80 + 16 =
// 2,656 vertices at level 0 (so levels 1 and 2 have the seed's 10,624 and 42,496), spheres of
// radius 14 mm with a reference of radius 15 mm, placed in seedImage() (128^3 voxels).
struct SeedScene {
  std::vector<StructureSpec> structures;
  std::vector<Vec3> centres;
};
SeedScene seedStructures(int levels);
std::shared_ptr<const Image3D> seedImage();

// Fig. 1b tessellation of one structure of the store.
TriangleMesh tessellationOf(MeshStore& store, Index mesh);

}  // namespace sinew::testing
