// CPU and CUDA backends side by side, per iteration, at the seed's sizes and beyond: four closed
// meshes of 2,656 vertices refined 1-to-4 up to ~11 M vertices, on a 128^3 synthetic image.
// Cases: (a) the seed's full set (smoothing, shape prior, intensity profile, damped Verlet);
// (b) smoothing, shape prior, damped Verlet; (c) (a) with what subject scenes add: the affine
// regularisation of the image forces (share 0.6) and, from level 1, the coarser levels' shape
// forces (weight 0.5); (d) (a) with the radial force (paper 001; its cost against (a) is issue 18's
// target), (e) the same with 3 medial relaxations per step instead of 1. Plain program (no Google Benchmark) so it runs on a
// GPU machine with nothing but the CUDA driver.
//   bench_cuda [max_level=6] [cpu_max_level=3] [min_level=0] [integrator=damped_verlet] [cases=abcde]
#include "sinew/core/scene_runner.h"
#include "sinew/cuda/cuda_engine.h"
#include "synthetic.h"

#include <cuda_runtime.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

using namespace sinew;
using namespace sinew::testing;
using Clock = std::chrono::steady_clock;

namespace {

std::string integrator = "damped_verlet";

enum class Case { Seed, ShapeOnly, Subject, Radial, Radial3 };

std::unique_ptr<Simulation> seedScene(const std::vector<StructureSpec>& specs, Case c, int level) {
  const bool profile = c != Case::ShapeOnly;
  auto sim = std::make_unique<Simulation>(forceRegistry(), 0);
  for (const auto& s : specs) sim->addStructure(s);
  sim->addForce("smoothing");
  sim->addForce("shape_prior");
  if (profile) sim->addForce("intensity_profile");
  if (c == Case::Radial || c == Case::Radial3) sim->addForce("radial");
  if (c == Case::Radial3) sim->forceParams("radial").setAll("medial_iterations", 3);
  sim->setIntegrator(integrator);
  sim->scene().setTargetImage(seedImage());
  sim->initialize();
  for (int l = 0; l < level; ++l) sim->advanceLevel();
  if (c == Case::Subject) {
    sim->setAffineRegularisation(0.6f);
    if (level > 0) sim->setCoarseForceWeight(0.5f);
  }
  return sim;
}

double deviceCopyBandwidth() {
  const size_t bytes = size_t(1) << 30;
  void *a = nullptr, *b = nullptr;
  if (cudaMalloc(&a, bytes) != cudaSuccess || cudaMalloc(&b, bytes) != cudaSuccess) return 0;
  cudaMemcpy(b, a, bytes, cudaMemcpyDeviceToDevice);
  cudaDeviceSynchronize();
  const auto t0 = Clock::now();
  for (int i = 0; i < 10; ++i) cudaMemcpy(b, a, bytes, cudaMemcpyDeviceToDevice);
  cudaDeviceSynchronize();
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  cudaFree(a);
  cudaFree(b);
  return 10.0 * 2.0 * bytes / s;  // read + write
}

}  // namespace

int main(int argc, char** argv) {
  const int maxLevel = argc > 1 ? std::atoi(argv[1]) : 6;
  const int cpuMaxLevel = argc > 2 ? std::atoi(argv[2]) : 3;
  const int minLevel = argc > 3 ? std::atoi(argv[3]) : 0;  // e.g. to profile only the large sizes
  if (argc > 4) integrator = argv[4];                       // damped_verlet (default) or implicit_euler
  const std::string cases = argc > 5 ? argv[5] : "abcde";   // e.g. "ab" for the seed set and (b) only
  const cuda::DeviceStatus st = cuda::probeDevice();
  if (!st.usable) {
    std::printf("no CUDA device: %s\n", st.reason.c_str());
    return 0;
  }
  std::printf("device: %s; CPU: %s; integrator %s\n", st.description.c_str(),
              cpuDescription(Executor().threads()).c_str(), integrator.c_str());
  std::printf("device-to-device copy: %.0f GB/s (read + write)\n\n", deviceCopyBandwidth() / 1e9);
  std::printf("| case | vertices | CUDA us/iter | CUDA G vertex-iter/s | CPU ms/iter | CPU M vertex-iter/s | CUDA/CPU |\n");
  std::printf("| --- | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  const auto specs = seedStructures(maxLevel + 1).structures;
  for (Case c : {Case::Seed, Case::ShapeOnly, Case::Subject, Case::Radial, Case::Radial3}) {
    if (cases.find(static_cast<char>('a' + static_cast<int>(c))) == std::string::npos) continue;
    for (int level = minLevel; level <= maxLevel; ++level) {
      auto sim = seedScene(specs, c, level);
      const Index n = sim->store().vertexCount();
      double cpuMs = 0;
      if (level <= cpuMaxLevel) {
        auto cpu = seedScene(specs, c, level);
        cpu->run(2);
        const int iters = level < 2 ? 50 : 5;
        const auto t0 = Clock::now();
        cpu->run(iters);
        cpuMs = 1e3 * std::chrono::duration<double>(Clock::now() - t0).count() / iters;
      }
      cuda::CudaEngine engine(*sim);
      engine.run(64);  // warm-up, graph capture
      int iters = 64;
      double seconds = 0;
      for (;;) {
        const auto t0 = Clock::now();
        engine.run(iters);
        seconds = std::chrono::duration<double>(Clock::now() - t0).count();
        if (seconds > 0.3 || iters >= (1 << 16)) break;
        iters *= 4;
      }
      const double us = 1e6 * seconds / iters;
      const char* name = c == Case::Seed        ? "(a) seed set"
                         : c == Case::ShapeOnly ? "(b) smooth+prior"
                         : c == Case::Subject   ? "(c) seed set + affine + coarse"
                         : c == Case::Radial    ? "(d) seed set + radial"
                                                : "(e) seed set + radial, 3 relaxations";
      std::printf("| %s | %d | %.2f | %.2f | ", name, n, us, n / us * 1e-3);
      if (cpuMs > 0)
        std::printf("%.2f | %.2f | %.0fx |\n", cpuMs, n / cpuMs * 1e-3, cpuMs * 1e3 / us);
      else
        std::printf("- | - | - |\n");
      std::fflush(stdout);
    }
  }
  return 0;
}
