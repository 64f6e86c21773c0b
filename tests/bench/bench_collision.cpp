// What collisions cost per step, CPU and CUDA side by side: a scene of N spheres (12, then 100 for
// the broad phase's scaling) in a grid, each overlapping its neighbours by 2 mm (every structure
// in contact: the costly case), held by smoothing, shape prior and the intensity profile on the
// seed's synthetic image, stepped by damped Verlet, with and without the collision force; refined
// level by level from ~15 k (12 structures) or ~32 k (100) vertices to >= 1 M.
//   bench_collision [max_level=3] [cpu_max_level=1]
#include "sinew/core/scene_runner.h"
#include "sinew/cuda/cuda_engine.h"
#include "synthetic.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

using namespace sinew;
using namespace sinew::testing;
using Clock = std::chrono::steady_clock;

namespace {

std::unique_ptr<Simulation> grid(int count, int level, bool collision) {
  const int sphereLevel = count > 20 ? 2 : 3;  // 320 or 1,280 vertices per sphere at level 0
  const float radius = 10.0f, spacing = 18.0f;
  const int side = int(std::ceil(std::cbrt(double(count))));
  auto sim = std::make_unique<Simulation>(forceRegistry(), 0);
  for (int i = 0; i < count; ++i) {
    const Vec3 centre(spacing * float(i % side), spacing * float((i / side) % side), spacing * float(i / (side * side)));
    StructureSpec s = sphereStructure("s" + std::to_string(i), sphereLevel, radius, centre, level + 1);
    s.referencePositions = s.initialPositions;
    sim->addStructure(std::move(s));
  }
  sim->addForce("smoothing");
  sim->addForce("shape_prior");
  sim->addForce("intensity_profile");
  if (collision) sim->addForce("collision").setAll("weight", 1.0);
  sim->setIntegrator("damped_verlet");
  sim->scene().setTargetImage(seedImage());
  sim->initialize();
  for (int l = 0; l < level; ++l) sim->advanceLevel();
  return sim;
}

double cudaMicroseconds(Simulation& sim) {
  cuda::CudaEngine engine(sim);
  engine.run(64);  // warm-up, graph capture
  int iters = 64;
  for (;;) {
    const auto t0 = Clock::now();
    engine.run(iters);
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    if (s > 0.3 || iters >= (1 << 14)) return 1e6 * s / iters;
    iters *= 4;
  }
}

double cpuMilliseconds(Simulation& sim, int iters) {
  sim.run(2);
  const auto t0 = Clock::now();
  sim.run(iters);
  return 1e3 * std::chrono::duration<double>(Clock::now() - t0).count() / iters;
}

}  // namespace

int main(int argc, char** argv) {
  const int maxLevel = argc > 1 ? std::atoi(argv[1]) : 3;
  const int cpuMaxLevel = argc > 2 ? std::atoi(argv[2]) : 1;
  const cuda::DeviceStatus st = cuda::probeDevice();
  std::printf("device: %s; CPU: %s\n\n", st.usable ? st.description.c_str() : st.reason.c_str(),
              cpuDescription(Executor().threads()).c_str());
  std::printf("| structures | vertices | CUDA us/step without | with collisions | ratio | CPU ms/step without | with | ratio |\n");
  std::printf("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  for (int count : {12, 100}) {
    for (int level = 0; level <= maxLevel; ++level) {
      auto plain = grid(count, level, false), with = grid(count, level, true);
      std::printf("| %d | %d | ", count, int(plain->store().vertexCount()));
      if (st.usable) {
        const double a = cudaMicroseconds(*plain), b = cudaMicroseconds(*with);
        std::printf("%.1f | %.1f | %.2f | ", a, b, b / a);
      } else {
        std::printf("- | - | - | ");
      }
      if (level <= cpuMaxLevel) {
        auto cpuPlain = grid(count, level, false), cpuWith = grid(count, level, true);
        const int iters = level == 0 ? 10 : 3;
        const double a = cpuMilliseconds(*cpuPlain, iters), b = cpuMilliseconds(*cpuWith, iters);
        std::printf("%.2f | %.2f | %.2f |\n", a, b, b / a);
      } else {
        std::printf("- | - | - |\n");
      }
      std::fflush(stdout);
    }
  }
  return 0;
}
