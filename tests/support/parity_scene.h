// The scene the GPU parity suites run (tst_cuda_parity, tst_cuda_profile): two structures, an
// ellipsoid and a noisy ball, on the synthetic ellipsoid image, with the given forces; and what
// they compare with (runOnBoth, also tst_cuda_collision's). Header only: each suite is its own
// program.
#pragma once

#include "sinew/core/simulation.h"
#include "sinew/cuda/cuda_engine.h"
#include "synthetic.h"

#include <algorithm>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace sinew::testing {

// configure: parameter changes before the scene starts (forces trained, layouts fixed).
inline std::unique_ptr<Simulation> scene(const std::vector<std::string>& forces, int levels,
                                         const std::string& integrator = "damped_verlet", double timeStep = 0.5,
                                         const std::function<void(Simulation&)>& configure = {}) {
  static const auto image = std::make_shared<Image3D>(ellipsoidImage({}));
  EllipsoidImageSpec spec;
  auto sim = std::make_unique<Simulation>(forceRegistry(), 0);
  StructureSpec a = sphereStructure("ellipsoid", 3, 15.0f, spec.centre + Vec3(3, 0, 0), levels);
  for (const Vec3& p : SimplexMesh::sphere(3, 1.0f).positions) a.referencePositions.push_back(onEllipsoid(p, spec.centre, spec.radii));
  StructureSpec b = sphereStructure("ball", 2, 6.0f, spec.centre + Vec3(-4, 2, 1), levels);
  b.referencePositions = withNoise(b.initialPositions, 0.2f, 4);
  sim->addStructure(std::move(a));
  sim->addStructure(std::move(b));
  for (const auto& f : forces) {
    ParamTable& t = sim->addForce(f);
    if (f == "gradient") t.setAll("search_depth", 4.0);
  }
  sim->setIntegrator(integrator).set(0, "time_step", timeStep);
  sim->scene().setTargetImage(image);
  sim->scene().attractionPoints()[1].push_back(spec.centre + Vec3(-4, 2, 10));
  // An include point 1.5 mm outside the first structure and an exclude point 1 mm inside it.
  sim->scene().constraintPoints()[0] = {{spec.centre + Vec3(3, 0, 16.5f), true}, {spec.centre + Vec3(3, 0, -14), false}};
  if (configure) configure(*sim);
  sim->initialize();
  return sim;
}

// The CPU runs without the stability guard: the device has none, so both take the same steps.
inline StabilityGuard noGuard() {
  StabilityGuard g;
  g.enabled = false;
  g.maxRetries = 0;
  return g;
}

inline double maxDifference(std::span<const Vec3> a, std::span<const Vec3> b) {
  double worst = 0;
  for (size_t v = 0; v < a.size(); ++v) worst = std::max(worst, double((a[v] - b[v]).norm()));
  return worst;
}
inline double maxDifference(MeshStore& a, MeshStore& b) { return maxDifference(a.positions(), b.positions()); }

// `steps` steps of four copies of one scene: on the CPU, on the device in two batches, on the
// device again in one, and none (the start). Largest CPU-CUDA difference, largest motion on the
// CPU, largest difference between the two device runs (mm).
struct ParityRun {
  double cpuCuda = 0, moved = 0, deviceRepeat = 0;
};
inline ParityRun runOnBoth(const std::function<std::unique_ptr<Simulation>()>& make, int steps) {
  auto cpu = make(), gpu = make(), again = make(), init = make();
  cpu->setStabilityGuard(noGuard());
  cpu->run(steps);
  cuda::CudaEngine engine(*gpu);
  engine.run(steps / 2);
  engine.run(steps - steps / 2);
  engine.download();
  cuda::CudaEngine engine2(*again);
  engine2.run(steps);
  engine2.download();
  return {maxDifference(cpu->store(), gpu->store()), maxDifference(cpu->store(), init->store()),
          maxDifference(gpu->store(), again->store())};
}

}  // namespace sinew::testing
