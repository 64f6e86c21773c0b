// GPU wall time of a step at the finest level of real scenes, side by side in one process. Each
// scene's schedule is run on the CUDA backend as sinew-run runs it (in chunks of the report's
// sample interval under the stability and shape guards, without the samples themselves). Then
// rounds of STEPS steps are timed on each scene in turn, each round from the state the schedule
// left (so every round does the same work, and the unguarded steps cannot drift into a swing), and
// the median of the rounds is reported per scene with its ratio to the first scene's. With and
// without a force (collisions) this is what the force adds to a step as the device runs it, the
// step's kernels overlapping where they may: Nsight Compute's kernel durations
// (scripts/collision-kernel-time.sh) are serialised and cannot show that.
// scripts/collision-step-time.sh makes the scenes; docs/benchmarks.md.
//   bench_steps STEPS ROUNDS SCENE.json...
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
  if (argc < 4) {
    std::fprintf(stderr, "usage: bench_steps STEPS ROUNDS SCENE.json...\n");
    return 2;
  }
  const int steps = std::atoi(argv[1]), rounds = std::atoi(argv[2]);
  const cuda::DeviceStatus st = cuda::probeDevice();
  if (!st.usable) {
    std::printf("no CUDA device: %s\n", st.reason.c_str());
    return 0;
  }
  struct Run {
    const char* path;
    std::unique_ptr<SceneRunner> runner;
    std::unique_ptr<cuda::CudaEngine> engine;
    std::vector<double> us;
  };
  std::vector<Run> runs;
  try {
    for (int a = 3; a < argc; ++a) {
      Run r{argv[a], std::make_unique<SceneRunner>(testing::builtinRegistry(), readScene(argv[a])), nullptr, {}};
      r.runner->load();
      r.engine = std::make_unique<cuda::CudaEngine>(r.runner->simulation());
      const auto& schedule = r.runner->scene().schedule;
      for (size_t level = 0; level < schedule.size(); ++level) {
        if (level > 0) {
          r.runner->enterNextLevel();
          r.engine->levelChanged();
        }
        const int interval = std::max(1, r.runner->scene().sampleInterval);
        for (int done = 0; done < schedule[level].iterations; done += interval) {
          const std::string failure =
              r.runner->runGuardedChunk(r.engine.get(), std::min(interval, schedule[level].iterations - done));
          if (!failure.empty()) throw std::runtime_error(std::string(argv[a]) + ": " + failure);
        }
      }
      r.engine->download();  // the host store keeps the state every round starts from
      runs.push_back(std::move(r));
    }
    using Clock = std::chrono::steady_clock;
    for (int round = 0; round < rounds; ++round)
      for (Run& r : runs) {
        r.engine->restoreState();
        const auto t0 = Clock::now();
        r.engine->run(steps);
        r.us.push_back(1e6 * std::chrono::duration<double>(Clock::now() - t0).count() / steps);
      }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_steps: %s\n", e.what());
    return 1;
  }
  std::printf("device: %s; %d rounds of %d steps a scene, alternated\n\n", st.description.c_str(), rounds, steps);
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
