// Wall time of a step on the GPU (or, with --cpu, the CPU) at the finest level of real scenes, side
// by side in one process. Each scene's schedule is run on the CUDA backend as sinew-run runs it (in
// chunks of the report's sample interval under the stability and shape guards, without the samples
// themselves). Then
// rounds of STEPS steps are timed on each scene in turn, each round from the state the schedule
// left (so every round does the same work, and the unguarded steps cannot drift into a swing), and
// the median of the rounds is reported per scene with its ratio to the first scene's. With and
// without a force (collisions) this is what the force adds to a step as the device runs it, the
// step's kernels overlapping where they may: Nsight Compute's kernel durations
// (scripts/collision-kernel-time.sh) are serialised and cannot show that.
// scripts/collision-step-time.sh makes the scenes; docs/benchmarks.md. With --cpu the same on the
// CPU backend (all hardware threads), each round from the schedule's end state put back
// (Simulation::restoreState), each step as sinew-run steps it (with the numerical guard's check).
// With --warmup N, each round first runs N steps untimed: putting the state back is a rollback to
// the forces, so the collision's first full search after it finds no clearance left (every vertex
// searches), which a run pays once a level and after a rollback, not every STEPS steps.
//   bench_steps [--cpu] [--warmup N] STEPS ROUNDS SCENE.json...
#include "synthetic.h"
#include "sinew/core/scene.h"
#include "sinew/core/scene_runner.h"
#include "sinew/cuda/cuda_engine.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

using namespace sinew;

int main(int argc, char** argv) {
  bool cpu = false, usable = true;
  int warmup = 0;
  while (usable && argc > 1 && std::string(argv[1]).rfind("--", 0) == 0) {
    const std::string flag = argv[1];
    const int taken = flag == "--warmup" ? 2 : 1;
    if (flag == "--cpu") cpu = true;
    else if (flag == "--warmup" && argc > 2) warmup = std::atoi(argv[2]);
    else usable = false;
    argc -= taken, argv += taken;
  }
  if (!usable || argc < 4 || warmup < 0) {
    std::fprintf(stderr, "usage: bench_steps [--cpu] [--warmup N] STEPS ROUNDS SCENE.json...\n");
    return 2;
  }
  const int steps = std::atoi(argv[1]), rounds = std::atoi(argv[2]);
  std::string device = "CPU backend";
  if (!cpu) {
    const cuda::DeviceStatus st = cuda::probeDevice();
    if (!st.usable) {
      std::printf("no CUDA device: %s\n", st.reason.c_str());
      return 0;
    }
    device = st.description;
  }
  struct Run {
    const char* path;
    std::unique_ptr<SceneRunner> runner;
    std::unique_ptr<cuda::CudaEngine> engine;  // null: the CPU backend
    std::vector<double> us;
    std::vector<Vec3> positions, previous;  // the CPU's rounds start from these
  };
  std::vector<Run> runs;
  try {
    for (int a = 3; a < argc; ++a) {
      Run r{argv[a], std::make_unique<SceneRunner>(testing::builtinRegistry(), readScene(argv[a])), nullptr, {}, {}, {}};
      r.runner->load();
      Simulation& sim = r.runner->simulation();
      if (!cpu) r.engine = std::make_unique<cuda::CudaEngine>(sim);
      const auto& schedule = r.runner->scene().schedule;
      for (size_t level = 0; level < schedule.size(); ++level) {
        if (level > 0) {
          r.runner->enterNextLevel();
          if (r.engine) r.engine->levelChanged();
        }
        const int interval = std::max(1, r.runner->scene().sampleInterval);
        for (int done = 0; done < schedule[level].iterations; done += interval) {
          const std::string failure =
              r.runner->runGuardedChunk(r.engine.get(), std::min(interval, schedule[level].iterations - done));
          if (!failure.empty()) throw std::runtime_error(std::string(argv[a]) + ": " + failure);
        }
      }
      if (r.engine) {
        r.engine->download();  // the host store keeps the state every round starts from
      } else {
        MeshStore& store = sim.store();
        r.positions.assign(store.positions().begin(), store.positions().end());
        r.previous.assign(store.previousPositions().begin(), store.previousPositions().end());
        device = "CPU backend, " + std::to_string(sim.executor().threads()) + " threads";
      }
      runs.push_back(std::move(r));
    }
    using Clock = std::chrono::steady_clock;
    for (int round = 0; round < rounds; ++round)
      for (Run& r : runs) {
        Simulation& sim = r.runner->simulation();
        if (r.engine) r.engine->restoreState();
        else sim.restoreState(r.positions, r.previous);
        if (warmup > 0 && r.engine) r.engine->run(warmup);  // (it waits for the device)
        else if (warmup > 0) sim.run(warmup);
        const auto t0 = Clock::now();
        if (r.engine) r.engine->run(steps);
        else sim.run(steps);
        r.us.push_back(1e6 * std::chrono::duration<double>(Clock::now() - t0).count() / steps);
      }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_steps: %s\n", e.what());
    return 1;
  }
  std::printf("device: %s; %d rounds of %d steps a scene (each after %d untimed), alternated\n\n", device.c_str(), rounds,
              steps, warmup);
  std::printf("| scene | vertices | us a step (median) | fastest round | ratio to the first |\n| --- | ---: | ---: | ---: | ---: |\n");
  double first = 0;
  for (Run& r : runs) {
    std::sort(r.us.begin(), r.us.end());
    const double median = r.us[r.us.size() / 2];
    if (first == 0) first = median;
    std::printf("| %s | %ld | %.2f | %.2f | %.3f |\n", r.path, long(r.runner->simulation().store().vertexCount()), median,
                r.us.front(), median / first);
  }
  return 0;
}
