#include "sinew/core/scene_runner.h"

#include "sinew/core/model_builder.h"
#include "sinew/core/voxelize.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <map>

namespace sinew {

namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

[[noreturn]] void sceneError(const SceneDesc& s, const std::string& where, const std::string& problem) {
  throw InputError(s.file.string() + ": " + where + ": " + problem);
}

Eigen::Matrix3f rotation(const Placement& p) {
  const Vec3 axis = Eigen::Vector3d(p.rotationAxis[0], p.rotationAxis[1], p.rotationAxis[2]).normalized().cast<float>();
  return Eigen::AngleAxisf(static_cast<float>(p.rotationDeg * M_PI / 180.0), axis).toRotationMatrix();
}

// Applies one force's parameter values to all structures or to one (row >= 0), naming the JSON
// path on error.
void applyParams(const SceneDesc& scene, ParamTable& table, const std::vector<std::pair<std::string, double>>& values,
                 Index row, const std::string& where) {
  for (const auto& [name, value] : values) {
    try {
      if (row >= 0 && !table.decls()[table.indexOf(name)].perStructure)
        throw InputError("'" + name + "' is shared by all structures; set it in the scene's /forces or /schedule");
      if (row < 0) table.setAll(name, value);
      else table.set(row, name, value);
    } catch (const InputError& e) {
      sceneError(scene, where + "/" + name, e.what());
    }
  }
}
}  // namespace

struct SceneRunner::Loaded {
  std::unique_ptr<Simulation> sim;
  std::map<fs::path, std::shared_ptr<LabelVolume>> labelMaps;
  std::vector<std::unique_ptr<ReferenceSurface>> truth;  // per structure, null without one
  std::vector<std::vector<std::uint8_t>> truthMask;
  std::vector<const ImageGeometry*> truthGrid;
  std::shared_ptr<Image3D> target;
  std::vector<double> initialAssd, initialDice;
  Clock::time_point created = Clock::now();
};

bool RunReport::hasGroundTruth() const {
  for (const auto& s : structures)
    if (!std::isnan(s.assdFinalMm)) return true;
  return false;
}

SceneRunner::SceneRunner(const Registry& registry, SceneDesc scene, RunOptions options)
    : registry_(registry), scene_(std::move(scene)), options_(std::move(options)) {}
SceneRunner::~SceneRunner() = default;

Simulation& SceneRunner::simulation() { return *loaded_->sim; }

void SceneRunner::load() {
  loaded_ = std::make_unique<Loaded>();
  Loaded& L = *loaded_;
  const int levels = static_cast<int>(scene_.schedule.size());
  // Everything the scene names must exist before any file is read.
  for (size_t f = 0; f < scene_.forces.size(); ++f) {
    try {
      registry_.force(scene_.forces[f].first);
    } catch (const InputError& e) {
      sceneError(scene_, "/forces/" + scene_.forces[f].first, e.what());
    }
  }
  try {
    registry_.integrator(scene_.integrator);
  } catch (const InputError& e) {
    sceneError(scene_, "/integrator/name", e.what());
  }
  try {
    registry_.meshIOFor("mesh" + scene_.meshFormat);
  } catch (const InputError& e) {
    sceneError(scene_, "/outputs/mesh_format", e.what());
  }
  try {
    registry_.imageIOFor(scene_.labelMapName);
  } catch (const InputError& e) {
    sceneError(scene_, "/outputs/label_map", e.what());
  }
  for (size_t l = 0; l < scene_.schedule.size(); ++l)
    for (const auto& [force, values] : scene_.schedule[l].forces) {
      bool listed = false;
      for (const auto& f : scene_.forces) listed |= f.first == force;
      if (!listed)
        sceneError(scene_, "/schedule/" + std::to_string(l) + "/forces/" + force,
                   "force '" + force + "' is not listed in the scene's /forces");
      ParamTable probe(registry_.force(force).params, 1);  // names and ranges, checked now
      applyParams(scene_, probe, values, -1, "/schedule/" + std::to_string(l) + "/forces/" + force);
    }

  auto log = [&](const std::string& m) {
    if (options_.log) options_.log(m + " (" + std::to_string(since(L.created)).substr(0, 5) + " s)");
  };
  log("reading " + scene_.targetImage.string());
  L.target = std::make_shared<Image3D>(registry_.imageIOFor(scene_.targetImage).readImage(scene_.targetImage));
  auto labels = [&](const fs::path& p) -> const LabelVolume& {
    auto& slot = L.labelMaps[p];
    if (!slot) slot = std::make_shared<LabelVolume>(registry_.imageIOFor(p).readLabels(p));
    return *slot;
  };

  L.sim = std::make_unique<Simulation>(registry_, options_.threads);
  for (size_t i = 0; i < scene_.structures.size(); ++i) {
    const StructureDesc& d = scene_.structures[i];
    const std::string where = "/structures/" + std::to_string(i);
    log("structure " + std::to_string(i + 1) + "/" + std::to_string(scene_.structures.size()) + " '" + d.name +
        "': building the reference shape");
    TriangleMesh coarse, surface;
    if (d.reference.mesh) {
      const fs::path& p = *d.reference.mesh;
      coarse = registry_.meshIOFor(p).read(p);
      try {
        validateClosedManifold(coarse);
      } catch (const InputError& e) {
        throw InputError(p.string() + ": " + e.what());
      }
      surface = coarse;
    } else {
      const LabelRef& ref = *d.reference.label;
      const auto& builder = registry_.labelSurfaceBuilder();
      try {
        surface = builder.labelSurface(labels(ref.labelMap), ref.label, {20, 0});
        coarse = builder.labelSurface(labels(ref.labelMap), ref.label,
                                      {20, trianglesForSpacing(surface, scene_.coarseSpacingMm)});
        validateClosedManifold(coarse);
      } catch (const InputError& e) {
        throw InputError(ref.labelMap.string() + ": structure '" + d.name + "': " + e.what());
      }
    }
    log("structure '" + d.name + "': relaxing " + std::to_string(levels) + " levels of detail");
    BuiltModel model = buildModel(coarse, surface, levels, L.sim->executor());

    StructureSpec spec;
    spec.name = d.name;
    spec.levels = std::move(model.levels);
    spec.referencePositions = model.positions[0];
    spec.finerReferences.assign(model.positions.begin() + 1, model.positions.end());
    spec.density = static_cast<float>(d.density);
    if (d.initial.mesh) {
      const fs::path& p = *d.initial.mesh;
      SimplexMesh init;
      try {
        init = SimplexMesh::dualOf(registry_.meshIOFor(p).read(p));
      } catch (const InputError& e) {
        const std::string what = e.what();
        throw InputError(what.rfind(p.string(), 0) == 0 ? what : p.string() + ": " + what);
      }
      if (init.topology.neighbours != spec.levels.levels[0].neighbours)
        throw InputError(p.string() + ": the initial mesh does not have the topology of structure '" + d.name +
                         "' at level 0");
      spec.initialPositions = init.positions;
    } else if (d.initial.matrix) {
      const auto& m = *d.initial.matrix;
      Eigen::Matrix4f T;
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) T(r, c) = static_cast<float>(m[r * 4 + c]);
      for (const Vec3& p : spec.referencePositions) spec.initialPositions.push_back((T * p.homogeneous()).head<3>());
    } else {
      Vec3 centre = Vec3::Zero();
      for (const Vec3& p : spec.referencePositions) centre += p;
      centre /= static_cast<float>(spec.referencePositions.size());
      const Eigen::Matrix3f R = rotation(d.initial);
      const Vec3 t(float(d.initial.translationMm[0]), float(d.initial.translationMm[1]), float(d.initial.translationMm[2]));
      for (const Vec3& p : spec.referencePositions)
        spec.initialPositions.push_back(centre + float(d.initial.scale) * (R * (p - centre)) + t);
    }
    int inside = 0;
    for (const Vec3& p : spec.initialPositions) inside += L.target->containsIndex(L.target->worldToIndex(p));
    if (inside == 0)
      sceneError(scene_, where, "structure '" + d.name + "' lies entirely outside the target image " +
                                    scene_.targetImage.string());

    if (d.groundTruth) {
      log("structure '" + d.name + "': ground-truth surface");
      const LabelVolume& gt = labels(d.groundTruth->labelMap);
      try {
        L.truth.push_back(std::make_unique<ReferenceSurface>(
            registry_.labelSurfaceBuilder().labelSurface(gt, d.groundTruth->label, {0, 0}),
            static_cast<float>(scene_.surfaceSampleSpacingMm)));
      } catch (const InputError& e) {
        throw InputError(d.groundTruth->labelMap.string() + ": ground truth of '" + d.name + "': " + e.what());
      }
      std::vector<std::uint8_t> mask(gt.voxels().size());
      for (size_t v = 0; v < mask.size(); ++v) mask[v] = gt.voxels()[v] == d.groundTruth->label;
      L.truthMask.push_back(std::move(mask));
      L.truthGrid.push_back(&gt.geometry());
    } else {
      L.truth.push_back(nullptr);
      L.truthMask.emplace_back();
      L.truthGrid.push_back(nullptr);
    }
    L.sim->addStructure(std::move(spec));
  }

  for (size_t f = 0; f < scene_.forces.size(); ++f) {
    const auto& [name, values] = scene_.forces[f];
    ParamTable& table = L.sim->addForce(name);
    applyParams(scene_, table, values, -1, "/forces/" + name);
    for (size_t i = 0; i < scene_.structures.size(); ++i)
      for (const auto& [force, own] : scene_.structures[i].forces)
        if (force == name)
          applyParams(scene_, table, own, static_cast<Index>(i), "/structures/" + std::to_string(i) + "/forces/" + name);
  }
  // Level 0's schedule values apply before anything is trained or allocated.
  for (const auto& [name, values] : scene_.schedule[0].forces)
    applyParams(scene_, L.sim->forceParams(name), values, -1, "/schedule/0/forces/" + name);
  ParamTable& integ = L.sim->setIntegrator(scene_.integrator);
  applyParams(scene_, integ, scene_.integratorParams, -1, "/integrator");
  L.sim->scene().setTargetImage(L.target);
  for (size_t i = 0; i < scene_.structures.size(); ++i)
    for (const auto& p : scene_.structures[i].attractionPointsMm)
      L.sim->scene().attractionPoints()[i].push_back(Vec3(float(p[0]), float(p[1]), float(p[2])));
  if (scene_.trainingImage) log("reading " + scene_.trainingImage->string());
  if (scene_.trainingImage)
    L.sim->scene().setTrainingImage(
        std::make_shared<Image3D>(registry_.imageIOFor(*scene_.trainingImage).readImage(*scene_.trainingImage)));
  log("training and initialising the forces");
  L.sim->setStabilityGuard(scene_.stability);
  L.sim->initialize();
  log("ready");
}

StructureResult SceneRunner::evaluate(Index i, bool final) {
  Loaded& L = *loaded_;
  MeshStore& store = L.sim->store();
  StructureResult r;
  r.name = scene_.structures[i].name;
  r.label = scene_.structures[i].label;
  r.vertices = store.range(i).vertexCount();
  const auto x = store.mesh(store.positions(), i);
  r.surface = tessellate(store.topologyOf(i), std::vector<Vec3>(x.begin(), x.end()));
  if (L.truth[i]) {
    const SurfaceDistanceStats st = L.truth[i]->compare(r.surface, L.sim->executor());
    r.assdFinalMm = st.assd;
    r.hd95Mm = st.hd95;
    if (final) r.dice = dice(voxelize(r.surface, *L.truthGrid[i]), L.truthMask[i]);
  }
  return r;
}

void SceneRunner::sample(RunReport& report, double seconds) {
  Loaded& L = *loaded_;
  MeshStore& store = L.sim->store();
  const auto x = store.positions();
  const auto prev = store.previousPositions();
  const auto f = store.forces();
  for (Index i = 0; i < store.meshCount(); ++i) {
    const MeshRange& r = store.range(i);
    TimelineSample s;
    s.seconds = seconds;
    s.iteration = L.sim->iteration();
    s.level = L.sim->level();
    s.structure = i;
    double disp = 0, force = 0;
    for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) {
      if (!x[v].allFinite())
        throw NumericalError("structure '" + scene_.structures[i].name + "': non-finite vertex position at iteration " +
                             std::to_string(s.iteration) + "; no mesh was written");
      disp += (x[v] - prev[v]).norm();
      force += f[v].norm();
    }
    s.meanDisplacementMm = disp / r.vertexCount();
    s.meanForce = force / r.vertexCount();
    if (L.truth[i]) s.assdMm = evaluate(i, false).assdFinalMm;
    report.timeline.push_back(s);
  }
}

RunReport SceneRunner::run() {
  Loaded& L = *loaded_;
  Simulation& sim = *L.sim;
  RunReport report;
  report.threads = sim.executor().threads();
  report.device = cpuDescription(report.threads);
  std::vector<StructureResult> initial;
  for (Index i = 0; i < sim.structureCount(); ++i) initial.push_back(evaluate(i, true));

  std::unique_ptr<ExecutionBackend> backend = options_.backend ? options_.backend(sim) : nullptr;
  if (backend) {
    report.backend = backend->name();
    report.device = backend->device();
  }
  // A backend that fails mid-run (device memory, a lost device) hands over to the CPU, which goes on
  // from the last state the backend downloaded.
  auto onBackend = [&](const std::function<void(ExecutionBackend&)>& work) {
    if (!backend) return false;
    try {
      work(*backend);
      return true;
    } catch (const std::runtime_error& e) {
      if (options_.log) options_.log(backend->name() + " backend failed (" + e.what() + "); continuing on the CPU");
      backend.reset();
      report.backend += "+cpu";
      return false;
    }
  };
  const int levels = static_cast<int>(scene_.schedule.size());
  long total = 0, done = 0;
  for (const auto& l : scene_.schedule) total += l.iterations;
  double simSeconds = 0.0;
  sample(report, 0.0);
  for (int level = 0; level < levels && report.numericalFailure.empty(); ++level) {
    const LevelDesc& lv = scene_.schedule[level];
    if (level > 0) {
      const auto t0 = Clock::now();
      enterNextLevel();
      onBackend([](ExecutionBackend& b) { b.levelChanged(); });
      simSeconds += since(t0);
    }
    report.levelStartSeconds.push_back(simSeconds);
    // Steps run in chunks that end on the sample points; only samples bring state to the host.
    for (int it = 0; it < lv.iterations && report.numericalFailure.empty();) {
      const int chunk = std::min(scene_.sampleInterval - it % scene_.sampleInterval, lv.iterations - it);
      const auto t0 = Clock::now();
      if (!onBackend([&](ExecutionBackend& b) { runGuarded(b, chunk, report); })) {
        try {
          sim.run(chunk);
        } catch (const NumericalError& e) {
          // The stability guard gave up and left the last good state: the run ends here and keeps it.
          report.numericalFailure = e.what();
          if (options_.log) options_.log(std::string("numerical failure: ") + e.what());
        }
      }
      simSeconds += since(t0);
      it += chunk;
      done += chunk;
      sample(report, simSeconds);
      if (options_.progress) options_.progress({level, levels, it, lv.iterations, done, total, simSeconds});
    }
  }
  report.simulationSeconds = simSeconds;
  report.stability = sim.stabilityEvents();
  for (Index i = 0; i < sim.structureCount(); ++i) {
    StructureResult r = evaluate(i, true);
    r.assdInitialMm = initial[i].assdFinalMm;
    r.diceInitial = initial[i].dice;
    r.seconds = simSeconds;
    report.structures.push_back(std::move(r));
  }
  report.totalSeconds = since(L.created);
  return report;
}

// The stability guard for a backend: the chunk's steps are checked together when they come back
// (the host store holds the state the chunk started from), against the one-step limit; a failed chunk is undone on the host,
// the step halved, and the backend reloaded to run it again.
void SceneRunner::runGuarded(ExecutionBackend& backend, int chunk, RunReport& report) {
  Simulation& sim = *loaded_->sim;
  if (!sim.stabilityGuard().enabled) {
    backend.run(chunk);
    backend.download();
    return;
  }
  MeshStore& store = sim.store();
  const std::vector<Vec3> goodX(store.positions().begin(), store.positions().end());
  std::vector<Vec3> goodPrev;
  if (store.has(Attribute::PreviousPosition))
    goodPrev.assign(store.previousPositions().begin(), store.previousPositions().end());
  for (int attempt = 0;; ++attempt) {
    backend.run(chunk);
    backend.download();
    // A whole chunk may move a vertex no farther than one step may on the CPU: legitimate motion is
    // far slower, and a looser bound would let oscillation just below the explosion through.
    const std::string problem = sim.checkStep(goodX);
    if (problem.empty()) return;
    sim.countExternalSteps(-chunk);  // the chunk is undone
    try {
      sim.recover(goodX, goodPrev, problem, attempt);
    } catch (const NumericalError& e) {
      report.numericalFailure = e.what();
      if (options_.log) options_.log(std::string("numerical failure: ") + e.what());
      return;
    }
    backend.reload();
  }
}

bool SceneRunner::enterNextLevel() {
  Simulation& sim = *loaded_->sim;
  const int next = sim.level() + 1;
  if (next >= sim.levelCount()) return false;
  // The level's values first: profile training and the like read them on entering the level.
  for (const auto& [name, values] : scene_.schedule[next].forces)
    applyParams(scene_, sim.forceParams(name), values, -1, "/schedule/" + std::to_string(next) + "/forces/" + name);
  return sim.advanceLevel();
}

bool SceneRunner::hasGroundTruth(Index structure) const { return loaded_->truth[structure] != nullptr; }

LabelVolume SceneRunner::labelMap(const RunReport& report) const {
  LabelVolume out(loaded_->target->geometry(), 0);
  for (const StructureResult& s : report.structures) {
    const auto mask = voxelize(s.surface, out.geometry());
    for (size_t v = 0; v < mask.size(); ++v)
      if (mask[v]) out.voxels()[v] = s.label;
  }
  return out;
}

std::string cpuDescription(int threads) {
  std::ifstream in("/proc/cpuinfo");
  std::string line, model = "unknown CPU";
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  return model + " (" + std::to_string(threads) + " threads)";
}

}  // namespace sinew
