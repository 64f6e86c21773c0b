// A reusable model: building it from the atlas (12 AAL structures, 3 levels, Colin27's
// mricron-data) against loading the saved model, side by side in one run; and the levels' topology
// of a large scene (BM_BuildLevels).
//   bench_model [--benchmark_filter=...]
#include "synthetic.h"
#include "sinew/core/model_builder.h"
#include "sinew/core/model_file.h"
#include "sinew/core/simulation.h"

#include <benchmark/benchmark.h>

#include <filesystem>

using namespace sinew;
namespace fs = std::filesystem;

namespace {

const fs::path kTemplates = "/usr/share/mricron/templates";
const char* kStructures[] = {"Hippocampus_L", "Hippocampus_R", "Amygdala_L", "Amygdala_R", "Caudate_L", "Caudate_R",
                             "Putamen_L", "Putamen_R", "Pallidum_L", "Pallidum_R", "Thalamus_L", "Thalamus_R"};
const int kLabels[] = {37, 38, 41, 42, 71, 72, 73, 74, 75, 76, 77, 78};

const Registry& registry() { return sinew::testing::builtinRegistry(); }

// What sinew-build-model does, from reading the label map to the finished reference shapes.
Model buildFromAtlas(const Executor& executor) {
  Model m;
  m.atlasImage = kTemplates / "ch2better.nii.gz";
  const LabelVolume labels = registry().imageIOFor("x.nii.gz").readLabels(kTemplates / "aal.nii.gz");
  for (int i = 0; i < 12; ++i) {
    BuiltModel b = buildModelFromLabel(registry(), labels, "aal.nii.gz", kLabels[i], kStructures[i], 4.0, 3, executor);
    m.structures.push_back({kStructures[i], kLabels[i], std::move(b.levels), std::move(b.positions)});
  }
  return m;
}

void BM_BuildModel(benchmark::State& state) {
  if (!fs::exists(kTemplates / "aal.nii.gz")) return state.SkipWithError("mricron-data is not installed");
  Executor executor(0);
  for (auto _ : state) benchmark::DoNotOptimize(buildFromAtlas(executor));
}

void BM_LoadModel(benchmark::State& state) {
  if (!fs::exists(kTemplates / "aal.nii.gz")) return state.SkipWithError("mricron-data is not installed");
  const fs::path folder = fs::temp_directory_path() / "sinew-bench-model";
  Executor executor(0);
  writeModel(registry(), buildFromAtlas(executor), folder);
  for (auto _ : state) benchmark::DoNotOptimize(readModel(registry(), folder));
  fs::remove_all(folder);
}

// Entering levels 1 and 2 with the loaded model's 12 structures, with the intensity-profile force
// (profiles trained on the atlas image at each level) and without it (range(0) = 1 / 0): what
// storing trained profiles in the model could save.
void BM_EnterLevels(benchmark::State& state) {
  if (!fs::exists(kTemplates / "aal.nii.gz")) return state.SkipWithError("mricron-data is not installed");
  const fs::path folder = fs::temp_directory_path() / "sinew-bench-model-levels";
  Executor executor(0);
  writeModel(registry(), buildFromAtlas(executor), folder);
  const Model model = readModel(registry(), folder);
  const auto atlas = std::make_shared<Image3D>(registry().imageIOFor(model.atlasImage).readImage(model.atlasImage));
  for (auto _ : state) {
    state.PauseTiming();
    Simulation sim(registry(), 0);
    for (const ModelStructure& m : model.structures) {
      StructureSpec spec;
      spec.name = m.name;
      spec.levels = m.levels;
      spec.referencePositions = spec.initialPositions = m.positions[0];
      spec.finerReferences.assign(m.positions.begin() + 1, m.positions.end());
      sim.addStructure(std::move(spec));
    }
    sim.addForce("shape_prior");
    if (state.range(0)) sim.addForce("intensity_profile");
    sim.setIntegrator("damped_verlet");
    sim.scene().setTargetImage(atlas);
    sim.initialize();
    state.ResumeTiming();
    sim.advanceLevel();
    sim.advanceLevel();
  }
  fs::remove_all(folder);
}

}  // namespace

// The topology of six levels of a 1,280-vertex sphere, up to 1,310,720 vertices: what a model's
// levels cost to build or load (LevelHierarchy::build, refine, dualOf) at a large scene's size.
void BM_BuildLevels(benchmark::State& state) {
  const SimplexTopology coarse = SimplexMesh::sphere(3).topology;
  for (auto _ : state) benchmark::DoNotOptimize(LevelHierarchy::build(coarse, 6));
}

BENCHMARK(BM_EnterLevels)->Arg(1)->Arg(0)->ArgName("profiles")->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(5);
BENCHMARK(BM_BuildModel)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK(BM_LoadModel)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(10);
BENCHMARK(BM_BuildLevels)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

BENCHMARK_MAIN();
