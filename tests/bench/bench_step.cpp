// One full simulation step (geometry refresh, every seed force, damped Verlet) at the seed's mesh
// sizes: 2,656 / 10,624 / 42,496 vertices in four structures, as in paper 000 Table 1.
//   bench_step [--benchmark_filter=...]   Arguments: level (0, 1, 2), threads (0 = all).
#include "synthetic.h"

#include <benchmark/benchmark.h>

using namespace sinew;
using namespace sinew::testing;

namespace {

// Four closed meshes totalling 2,656 vertices at level 0 (1,280 + 1,280 + 80 + 16), refined 1-to-4.
std::unique_ptr<Simulation> seedScene(int level, int threads) {
  static const auto image = [] {
    EllipsoidImageSpec spec;
    spec.size = 128;
    spec.centre = Vec3(64, 64, 64);
    spec.radii = Vec3(40, 30, 25);
    return std::make_shared<Image3D>(ellipsoidImage(spec));
  }();
  auto sim = std::make_unique<Simulation>(forceRegistry(), threads);
  const std::vector<std::pair<TriangleMesh, Vec3>> meshes = {
      {icosphere(3, 1.0f), Vec3(40, 64, 64)},
      {icosphere(3, 1.0f), Vec3(88, 64, 64)},
      {icosphere(1, 1.0f), Vec3(64, 40, 64)},
      {tetrasphere(1, 1.0f), Vec3(64, 88, 64)}};
  for (size_t i = 0; i < meshes.size(); ++i) {
    const SimplexMesh m = SimplexMesh::fromSphereTriangles(meshes[i].first, 1.0f, Vec3::Zero());
    StructureSpec s;
    s.name = "structure" + std::to_string(i);
    s.levels = LevelHierarchy::build(m.topology, 3);
    for (const Vec3& p : m.positions) {
      s.initialPositions.push_back(meshes[i].second + 14.0f * p);
      s.referencePositions.push_back(meshes[i].second + 15.0f * p);
    }
    sim->addStructure(std::move(s));
  }
  sim->addForce("smoothing");
  sim->addForce("shape_prior");
  sim->addForce("gradient");
  sim->addForce("intensity_profile");
  sim->addForce("attraction_points");
  sim->setIntegrator("damped_verlet");
  sim->scene().setTargetImage(image);
  for (Index m = 0; m < 4; ++m) sim->scene().attractionPoints()[m].push_back(meshes[m].second + Vec3(0, 0, 16));
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
