// The soak (docs/reliability.md): a million steps of the seed's full set (four closed meshes,
// smoothing, shape prior, intensity profile, damped Verlet) on the CPU and on the device, with the
// process's resident memory and the device's used memory at every checkpoint. Memory must stay
// flat; positions must stay finite (exit 1 otherwise).
//   bench_soak [--steps 1000000] [--checkpoints 10] [--backend both|cpu|cuda] [--level 0] [-j 0]
//              [--cpu-forces full|shape]
#include "synthetic.h"
#ifdef SINEW_WITH_CUDA
#include "sinew/cuda/cuda_engine.h"

#include <cuda_runtime.h>
#endif

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <unistd.h>

using namespace sinew;
using namespace sinew::testing;

namespace {
double residentMb() {
  long pages = 0, resident = 0;
  std::ifstream("/proc/self/statm") >> pages >> resident;
  return double(resident) * double(::sysconf(_SC_PAGESIZE)) / (1 << 20);
}

double deviceUsedMb() {
#ifdef SINEW_WITH_CUDA
  std::size_t freeBytes = 0, total = 0;
  if (cudaMemGetInfo(&freeBytes, &total) == cudaSuccess) return double(total - freeBytes) / (1 << 20);
#endif
  return 0.0;
}

bool finite(Simulation& sim) {
  for (const Vec3& v : sim.store().positions())
    if (!v.allFinite()) return false;
  return true;
}

// Runs `steps` in `checkpoints` chunks; returns false on a non-finite position.
bool soak(const std::string& backend, long steps, int checkpoints, int level, int threads, bool profile) {
  auto sim = std::make_unique<Simulation>(forceRegistry(), threads);
  for (const auto& s : seedStructures(level + 1).structures) sim->addStructure(s);
  sim->addForce("smoothing");
  sim->addForce("shape_prior");
  if (profile) sim->addForce("intensity_profile");
  sim->setIntegrator("damped_verlet");
  sim->scene().setTargetImage(seedImage());
  sim->initialize();
  for (int l = 0; l < level; ++l) sim->advanceLevel();
  std::unique_ptr<ExecutionBackend> engine;
#ifdef SINEW_WITH_CUDA
  if (backend == "cuda") engine = std::make_unique<cuda::CudaEngine>(*sim);
#endif
  if (backend == "cuda" && !engine) {
    std::fprintf(stderr, "bench_soak: this build has no CUDA backend\n");
    return false;
  }
  std::printf("%s: %ld vertices, %s, %ld steps\n%10s %9s %12s %14s %16s\n", backend.c_str(), long(sim->store().vertexCount()),
              profile ? "smoothing + shape prior + intensity profile" : "smoothing + shape prior", steps, "steps", "seconds", "resident MB", "device MB used", "us per step");
  const auto t0 = std::chrono::steady_clock::now();
  double firstResident = 0, firstDevice = 0, lastSeconds = 0;
  long done = 0;
  for (int c = 0; c <= checkpoints; ++c) {
    const long target = steps * c / checkpoints;
    while (done < target) {
      const int n = int(std::min<long>(target - done, 10000));
      if (engine) engine->run(n);
      else sim->run(n);
      done += n;
    }
    if (engine) engine->download();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double resident = residentMb(), device = deviceUsedMb();
    if (c == 1) firstResident = resident, firstDevice = device;  // after the first chunk: warmed up
    const double perStep = c ? 1e6 * (seconds - lastSeconds) / double(steps / checkpoints) : 0.0;
    std::printf("%10ld %9.1f %12.1f %14.1f %16.2f\n", done, seconds, resident, device, perStep);
    std::fflush(stdout);
    lastSeconds = seconds;
    if (!finite(*sim)) {
      std::printf("%s: non-finite positions after %ld steps\n", backend.c_str(), done);
      return false;
    }
  }
  std::printf("%s: resident memory %+.1f MB and device memory %+.1f MB from the first checkpoint to the last; "
              "%ld stability events\n\n",
              backend.c_str(), residentMb() - firstResident, deviceUsedMb() - firstDevice, long(sim->stabilityEvents().size()));
  return true;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"bench_soak: a million steps on the CPU and the device, memory watched"};
  long steps = 1000000;
  int checkpoints = 10, level = 0, threads = 0;
  std::string backend = "both", cpuForces = "full";
  cli.add_option("--steps", steps)->check(CLI::PositiveNumber)->capture_default_str();
  cli.add_option("--checkpoints", checkpoints)->check(CLI::Range(1, 1000))->capture_default_str();
  cli.add_option("--backend", backend)->check(CLI::IsMember({"both", "cpu", "cuda"}))->capture_default_str();
  cli.add_option("--level", level)->check(CLI::Range(0, 4))->capture_default_str();
  cli.add_option("-j,--threads", threads)->check(CLI::NonNegativeNumber);
  cli.add_option("--cpu-forces", cpuForces, "full, or shape (no intensity profile: ten times faster on the CPU)")
      ->check(CLI::IsMember({"full", "shape"}))
      ->capture_default_str();
  CLI11_PARSE(cli, argc, argv);
  bool ok = true;
  if (backend != "cuda") ok &= soak("cpu", steps, checkpoints, level, threads, cpuForces == "full");
  if (backend != "cpu") ok &= soak("cuda", steps, checkpoints, level, threads, true);
  return ok ? 0 : 1;
}
