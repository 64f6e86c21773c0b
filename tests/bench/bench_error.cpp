// The error against the ground truth on a real run: at every report sample of a scene's run, the
// sampled error on the host (sampled_error.h, the timeline's) and the exact evaluation
// (surface_distance.h, the final result's) timed side by side on the same positions, summed per
// level, with the largest differences between the two (ASSD, HD95) over the structures and the mean
// of HD95's (sampled minus exact: its bias, which the largest hides). For the
// query's cost behind sample_error and evaluate_* in report.json's stage_seconds.
//   bench_error SCENE.json [REPEATS (default 3)]
#include "synthetic.h"
#include "sinew/core/scene.h"
#include "sinew/core/scene_runner.h"
#include "sinew/core/simulation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>

using namespace sinew;

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_error SCENE.json [REPEATS]\n");
    return 2;
  }
  const int repeats = argc > 2 ? std::atoi(argv[2]) : 3;
  using Clock = std::chrono::steady_clock;
  struct Sum {
    int samples = 0;
    double sampled = 0, exact = 0, worstAssd = 0, worstHd95 = 0, hd95Bias = 0;
    int compared = 0;
  };
  std::map<int, Sum> perLevel;
  SceneRunner* current = nullptr;
  RunOptions options;
  options.progress = [&](const RunProgress& p) {
    Sum& s = perLevel[p.level];
    auto t0 = Clock::now();
    std::vector<std::optional<SurfaceDistanceStats>> sampled;
    for (int r = 0; r < repeats; ++r) sampled = current->sampledError();
    s.sampled += std::chrono::duration<double>(Clock::now() - t0).count() / repeats;
    t0 = Clock::now();
    std::vector<StructureResult> exact;
    for (Index i = 0; i < current->simulation().structureCount(); ++i) exact.push_back(current->evaluate(i, false));
    s.exact += std::chrono::duration<double>(Clock::now() - t0).count();
    for (size_t i = 0; i < exact.size(); ++i)
      if (sampled[i]) {
        s.worstAssd = std::max(s.worstAssd, std::abs(sampled[i]->assd - exact[i].assdFinalMm));
        s.worstHd95 = std::max(s.worstHd95, std::abs(sampled[i]->hd95 - exact[i].hd95Mm));
        s.hd95Bias += sampled[i]->hd95 - exact[i].hd95Mm, s.compared++;
      }
    s.samples++;
  };
  try {
    SceneRunner runner(testing::builtinRegistry(), readScene(argv[1]), options);
    current = &runner;
    runner.load();
    runner.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_error: %s\n", e.what());
    return 1;
  }
  std::printf("| level | samples | sampled ms per sample | exact ms per sample | exact / sampled | largest ASSD difference (mm) | largest HD95 difference (mm) | mean HD95 difference (mm) |\n"
              "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  Sum all;
  for (const auto& [level, s] : perLevel) {
    std::printf("| %d | %d | %.2f | %.2f | %.1f | %.4f | %.4f | %+.4f |\n", level, s.samples, 1e3 * s.sampled / s.samples,
                1e3 * s.exact / s.samples, s.exact / s.sampled, s.worstAssd, s.worstHd95, s.hd95Bias / std::max(s.compared, 1));
    all.samples += s.samples, all.sampled += s.sampled, all.exact += s.exact;
    all.worstAssd = std::max(all.worstAssd, s.worstAssd), all.worstHd95 = std::max(all.worstHd95, s.worstHd95);
    all.hd95Bias += s.hd95Bias, all.compared += s.compared;
  }
  std::printf("| all | %d | %.2f | %.2f | %.1f | %.4f | %.4f | %+.4f |\n", all.samples, 1e3 * all.sampled / all.samples,
              1e3 * all.exact / all.samples, all.exact / all.sampled, all.worstAssd, all.worstHd95, all.hd95Bias / std::max(all.compared, 1));
  return 0;
}
