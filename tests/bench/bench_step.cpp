// One full simulation step (geometry refresh, every seed force, damped Verlet) at the seed's mesh
// sizes: 2,656 / 10,624 / 42,496 vertices in four structures, as in paper 000 Table 1.
//   bench_step [--benchmark_filter=...]   Arguments: level (0, 1, 2), threads (0 = all).
#include "synthetic.h"

#include <benchmark/benchmark.h>

using namespace sinew;
using namespace sinew::testing;

namespace {

std::unique_ptr<Simulation> seedScene(int level, int threads) {
  const SeedScene seed = seedStructures(3);
  auto sim = std::make_unique<Simulation>(forceRegistry(), threads);
  for (const auto& s : seed.structures) sim->addStructure(s);
  sim->addForce("smoothing");
  sim->addForce("shape_prior");
  sim->addForce("gradient");
  sim->addForce("intensity_profile");
  sim->addForce("attraction_points");
  sim->setIntegrator("damped_verlet");
  sim->scene().setTargetImage(seedImage());
  for (Index m = 0; m < 4; ++m) sim->scene().attractionPoints()[m].push_back(seed.centres[m] + Vec3(0, 0, 16));
  sim->initialize();
  for (int l = 0; l < level; ++l) sim->advanceLevel();
  sim->run(2);  // warm: gradient volume built, caches touched
  return sim;
}

void BM_FullSeedStep(benchmark::State& state) {
  auto sim = seedScene(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  for (auto _ : state) sim->step();
  state.counters["vertices"] = sim->store().vertexCount();
  state.counters["threads"] = sim->executor().threads();
  state.counters["vertex_iter_per_s"] =
      benchmark::Counter(static_cast<double>(sim->store().vertexCount()), benchmark::Counter::kIsIterationInvariantRate);
}

}  // namespace

BENCHMARK(BM_FullSeedStep)
    ->ArgsProduct({{0, 1, 2}, {1, 0}})
    ->ArgNames({"level", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
