#include "sinew/core/scene_runner.h"
#include "scene_runner_loaded.h"

#include "sinew/core/sampled_error.h"

#include "sinew/core/model_builder.h"
#include "sinew/core/model_file.h"
#include "sinew/core/voxelize.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <exception>
#include <functional>
#include <optional>
#include <cmath>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <thread>

namespace sinew {

namespace {
namespace fs = std::filesystem;

// The truth sampled for the timeline's error (sampled_error.h): at 2 mm, a label surface from a
// 1 mm grid is sampled once per triangle, at its centroid. Measured against the exact evaluation on
// Colin27 (tst_sampled_error): 0.004 mm of ASSD at most, the same as at 1 mm, in half the time.
constexpr float kSampledSpacingMm = 2.0f;

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

// The last sample's mean ASSD and Dice over the structures that have them, for progress reports.
void meanOfLastSample(const RunReport& report, Index structures, RunProgress& p) {
  double assd = 0.0, dice = 0.0;
  int withAssd = 0, withDice = 0;
  for (std::size_t k = report.timeline.size() - std::size_t(structures); k < report.timeline.size(); ++k) {
    const TimelineSample& s = report.timeline[k];
    if (std::isfinite(s.assdMm)) assd += s.assdMm, ++withAssd;
    if (std::isfinite(s.dice)) dice += s.dice, ++withDice;
  }
  if (withAssd) p.meanAssdMm = assd / withAssd;
  if (withDice) p.meanDice = dice / withDice;
}
}  // namespace

void sceneError(const SceneDesc& s, const std::string& where, const std::string& problem) {
  throw InputError(s.file.string() + ": " + where + ": " + problem);
}

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
  if (options_.start) L.clock = StageClock(*options_.start);
  L.clock.lap("startup");
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
  // Every file the scene names starts reading now, in the background, when threads allow: the
  // images' decompression then overlaps the model building. The read_* stages are the waits.
  if (options_.threads != 1 && std::thread::hardware_concurrency() > 1) L.reading = std::launch::async;
  L.startImage(registry_, scene_.targetImage);
  if (scene_.trainingImage) L.startImage(registry_, *scene_.trainingImage);
  for (const StructureDesc& d : scene_.structures) {
    if (d.reference.label && !d.reference.mesh) L.startLabels(registry_, d.reference.label->labelMap);
    if (d.groundTruth) L.startLabels(registry_, d.groundTruth->labelMap);
  }
  auto labels = [&](const fs::path& p) -> const LabelVolume& { return *L.startLabels(registry_, p).get(); };
  if (scene_.model) {
    log("reading the model " + scene_.model->string());
    L.model = readModel(registry_, *scene_.model);
    if (L.model->levelCount() < levels)
      sceneError(scene_, "/schedule", std::to_string(levels) + " levels, but the model " + scene_.model->string() +
                                          " has " + std::to_string(L.model->levelCount()));
    L.clock.lap("read_model");
    if (!scene_.trainingImage) L.startImage(registry_, L.model->atlasImage);
  }
  L.startRegistration(registry_, scene_, log, std::launch::async);

  L.sim = std::make_unique<Simulation>(registry_, options_.threads);
  std::vector<StructureSpec> specs;
  for (const auto& [a, b] : scene_.contactPairs) {
    std::array<Index, 2> pair{-1, -1};
    for (size_t i = 0; i < scene_.structures.size(); ++i) {
      if (scene_.structures[i].name == a) pair[0] = Index(i);
      if (scene_.structures[i].name == b) pair[1] = Index(i);
    }
    L.sim->scene().contactPairs().push_back(pair);  // the parser checked both names
  }
  const auto indexOf = [&](const std::string& name) {
    for (size_t i = 0; i < scene_.structures.size(); ++i)
      if (scene_.structures[i].name == name) return Index(i);
    return Index(-1);  // not for a name the parser checked
  };
  for (const SceneDesc::CollisionShare& c : scene_.collisionShares)
    L.sim->scene().collisionShares().push_back(
        {indexOf(c.pair[0]), indexOf(c.pair[1]), float(c.shares[0]), float(c.shares[1])});
  std::vector<AttachmentSpec> attachments;
  for (const SceneDesc::Attachment& a : scene_.attachments) {
    AttachmentSpec spec;
    spec.kind = a.kind == "fixed" ? AttachmentSpec::Kind::Fixed : a.kind == "merge" ? AttachmentSpec::Kind::Merge : AttachmentSpec::Kind::Surface;
    spec.structure = indexOf(a.structure);
    spec.other = a.kind == "fixed" ? -1 : indexOf(a.other);
    spec.distanceMm = float(a.distanceMm);
    spec.centre = Vec3(float(a.centreMm[0]), float(a.centreMm[1]), float(a.centreMm[2]));
    spec.radiusMm = float(a.radiusMm);
    attachments.push_back(spec);
  }
  L.sim->setAttachments(std::move(attachments));
  // The reference shapes from label maps and the ground-truth surfaces, every structure at once:
  // each one's iso-surface, decimation and relaxation are independent of the others', and one after
  // the other they were the longest stages of a run on the GPU. The first failure in the scene's
  // order is the one reported.
  const size_t n = scene_.structures.size();
  std::map<fs::path, const LabelVolume*> labelMap;  // shared inputs, read once, before the threads
  for (const StructureDesc& d : scene_.structures) {
    if (d.reference.label && !d.reference.mesh) labelMap[d.reference.label->labelMap] = &labels(d.reference.label->labelMap);
    if (d.groundTruth) labelMap[d.groundTruth->labelMap] = &labels(d.groundTruth->labelMap);
  }
  // Tasks 0 .. n-1 build the reference shapes, n .. 2n-1 the ground truths: one pool, so that a
  // large structure's task does not hold the others back at a barrier between the two.
  std::vector<std::optional<BuiltModel>> builtFromLabel(n);
  std::vector<std::unique_ptr<ReferenceSurface>> truthSurfaces(n);
  std::vector<std::size_t> truthCounts(n, 0);
  std::vector<char> truthAbsent(n, 0);  // the label map has no voxel of the label: decided once placed (below)
  // Every label's extent, one pass over each label map (which the surfaces then need not scan, each
  // for its own label, twice for a reference): its own task, beside each other's.
  std::map<fs::path, std::unordered_map<std::int32_t, LabelExtent>> extents;
  for (const auto& [path, map] : labelMap) extents[path];
  L.sim->executor().forEach(
      Index(extents.size()), [&](Index k) {
        auto it = std::next(extents.begin(), k);
        it->second = labelExtents(*labelMap.at(it->first));
      },
      1);
  const auto extentOf = [&](const fs::path& map, std::int32_t label) -> const LabelExtent* {
    const auto& all = extents.at(map);
    const auto it = all.find(label);
    return it == all.end() ? nullptr : &it->second;  // absent: the builder says so
  };
  const auto buildReference = [&](size_t i) {
    const StructureDesc& d = scene_.structures[i];
    if (d.reference.mesh || !d.reference.label) return;
    const fs::path& map = d.reference.label->labelMap;
    builtFromLabel[i] = buildModelFromLabel(registry_, *labelMap.at(map), map, d.reference.label->label, d.name,
                                            scene_.coarseSpacingMm, levels, L.sim->executor(),
                                            extentOf(map, d.reference.label->label));
  };
  const auto buildTruth = [&](size_t i) {
    const StructureDesc& d = scene_.structures[i];
    if (!d.groundTruth) return;
    const LabelExtent* extent = extentOf(d.groundTruth->labelMap, d.groundTruth->label);
    if (!extent || extent->count == 0) {
      truthAbsent[i] = 1;
      return;
    }
    try {
      truthSurfaces[i] = std::make_unique<ReferenceSurface>(
          registry_.labelSurfaceBuilder().labelSurface(*labelMap.at(d.groundTruth->labelMap), d.groundTruth->label,
                                                       {0, 0, extent}),
          static_cast<float>(scene_.surfaceSampleSpacingMm));
    } catch (const InputError& e) {
      throw InputError(d.groundTruth->labelMap.string() + ": ground truth of '" + d.name + "': " + e.what());
    }
    truthCounts[i] = extent->count;
  };
  if (std::any_of(scene_.structures.begin(), scene_.structures.end(),
                  [](const StructureDesc& d) { return (d.reference.label && !d.reference.mesh) || d.groundTruth; }))
    log("building the reference shapes at " + std::to_string(levels) + " levels of detail and the ground-truth surfaces");
  {
    std::vector<std::exception_ptr> failed(2 * n);
    L.sim->executor().forEach(
        Index(2 * n),
        [&](Index k) {
          try {
            if (size_t(k) < n) buildReference(size_t(k));
            else buildTruth(size_t(k) - n);
          } catch (...) {
            failed[k] = std::current_exception();
          }
        },
        1);
    for (const auto& f : failed)
      if (f) std::rethrow_exception(f);
  }
  for (size_t i = 0; i < scene_.structures.size(); ++i) {
    const StructureDesc& d = scene_.structures[i];
    const std::string where = "/structures/" + std::to_string(i);
    StructureSpec spec;
    spec.name = d.name;
    spec.density = static_cast<float>(d.density);
    spec.massFloor = static_cast<float>(d.massFloor);
    if (!d.reference.mesh && !d.reference.label) {
      const ModelStructure* ms = L.model->find(d.name);
      if (!ms) sceneError(scene_, where + "/name", "the model " + scene_.model->string() + " has no structure '" + d.name + "'");
      spec.levels = ms->levels;
      spec.levels.levels.resize(levels);
      spec.levels.prolongations.resize(levels - 1);
      spec.referencePositions = ms->positions[0];
      spec.finerReferences.assign(ms->positions.begin() + 1, ms->positions.begin() + levels);
      // One side of a label split by side, scored against that label whole: its scores mean little.
      if (!ms->side.empty() && d.groundTruth && d.groundTruth->label == ms->label)
        log("note: structure '" + d.name + "' is the " + ms->side + " side of label " + std::to_string(ms->label) +
            " (sinew-build-model --split-parts), but its ground truth is that label whole, both sides: its scores "
            "are against both (sinew-make-scene --model --ground-truth splits the truth by side)");
    } else {
      if (d.reference.mesh)
        log("structure " + std::to_string(i + 1) + "/" + std::to_string(scene_.structures.size()) + " '" + d.name +
            "': building the reference shape at " + std::to_string(levels) + " levels of detail");
      BuiltModel model = d.reference.mesh ? buildModelFromMesh(registry_.meshIOFor(*d.reference.mesh).read(*d.reference.mesh),
                                                               *d.reference.mesh, levels, L.sim->executor())
                                          : std::move(*builtFromLabel[i]);
      if (!d.reference.mesh)
        if (const std::string note = model.partNote(d.name, d.reference.label->label); !note.empty()) log(note);
      spec.levels = std::move(model.levels);
      spec.referencePositions = model.positions[0];
      spec.finerReferences.assign(model.positions.begin() + 1, model.positions.end());
    }
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

    if (d.groundTruth) {
      L.truth.push_back(std::move(truthSurfaces[i]));
      L.truthCount.push_back(truthCounts[i]);
      L.truthLabels.emplace_back(labelMap.at(d.groundTruth->labelMap), d.groundTruth->label);
    } else {
      L.truth.push_back(nullptr);
      L.truthLabels.emplace_back(nullptr, 0);
      L.truthCount.push_back(0);
    }
    specs.push_back(std::move(spec));
  }
  L.clock.lap(L.model ? "structures" : "build_model");
  std::vector<const ReferenceSurface*> truths;
  for (const auto& t : L.truth) truths.push_back(t.get());
  if (std::any_of(truths.begin(), truths.end(), [](const ReferenceSurface* t) { return t != nullptr; }))
    L.sampled = std::make_unique<SampledError>(truths, kSampledSpacingMm);
  L.clock.lap("ground_truth");
  log("reading " + scene_.targetImage.string());
  L.target = L.image(registry_, scene_.targetImage);
  L.clock.lap("read_target");

  initialise(specs, log);
  L.clock.lap("initialisation");
  // A structure entirely outside the target image: where the image's field of view leaves it out
  // (a scan that does not cover the cerebellum), the others are still segmented and the model alone
  // places it, as it shapes the parts of structures past the field of view (outside_image_share in
  // the report). Every structure outside is a wrong image or a wrong placement: bad input.
  std::vector<size_t> outside;
  std::vector<char> whollyInside(specs.size(), 0);
  for (size_t i = 0; i < specs.size(); ++i) {
    size_t inside = 0;
    for (const Vec3& p : specs[i].initialPositions) inside += L.target->containsIndex(L.target->worldToIndex(p));
    if (inside == 0) outside.push_back(i);
    whollyInside[i] = inside == specs[i].initialPositions.size();
  }
  if (!outside.empty() && outside.size() == specs.size())
    sceneError(scene_, "/structures/" + std::to_string(outside.front()),
               "structure '" + specs[outside.front()].name + "' lies entirely outside the target image " +
                   scene_.targetImage.string() + (specs.size() > 1 ? ", as does every other structure" : ""));
  for (size_t i : outside)
    log("structure '" + specs[i].name + "' lies entirely outside the target image " + scene_.targetImage.string() +
         ": the model alone places it");
  // A ground truth without a voxel of its label: where the structure reaches past the field of view,
  // the label map (cut as the image is) can leave it out entirely, and then there is nothing to
  // score it against; the run goes on and the structure is not scored. Placed wholly inside the
  // image, the label's absence is a wrong label: bad input, as before.
  for (size_t i = 0; i < specs.size(); ++i) {
    if (!truthAbsent[i]) continue;
    const auto& truth = *scene_.structures[i].groundTruth;
    const std::string label = "label " + std::to_string(truth.label) + " is absent from ";
    if (whollyInside[i])
      throw InputError(truth.labelMap.string() + ": ground truth of '" + specs[i].name + "': " + label + "the label map");
    log("structure '" + specs[i].name + "' reaches past the target image's field of view, and its ground-truth " + label +
        truth.labelMap.string() + ": not scored");
  }
  for (auto& spec : specs) L.sim->addStructure(std::move(spec));

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
  L.sim->scene().setTrainingMap(L.trainingMap);
  if (!scene_.schedule.empty()) L.sim->setAffineRegularisation(float(scene_.schedule[0].affineRegularisation));
  for (size_t i = 0; i < scene_.structures.size(); ++i)
    for (const auto& p : scene_.structures[i].attractionPointsMm)
      L.sim->scene().attractionPoints()[i].push_back(Vec3(float(p[0]), float(p[1]), float(p[2])));
  for (size_t i = 0; i < scene_.structures.size(); ++i) {
    const StructureDesc& d = scene_.structures[i];
    for (const auto& p : d.includePointsMm)
      L.sim->scene().constraintPoints()[i].push_back({Vec3(float(p[0]), float(p[1]), float(p[2])), true});
    for (const auto& p : d.excludePointsMm)
      L.sim->scene().constraintPoints()[i].push_back({Vec3(float(p[0]), float(p[1]), float(p[2])), false});
  }
  if (const std::optional<fs::path> training = trainingImagePath()) {
    log("reading " + training->string());
    L.sim->scene().setTrainingImage(L.image(registry_, *training));
    L.clock.lap("read_training");
  }
  log("training and initialising the forces");
  L.sim->setStabilityGuard(scene_.stability);
  L.sim->initialize();
  L.clock.lap("prepare_forces");
  log("ready");
}

std::optional<fs::path> SceneRunner::trainingImagePath() const {
  // The scene's, else the model's atlas.
  const Loaded& L = *loaded_;
  return scene_.trainingImage ? scene_.trainingImage : L.model ? std::optional<fs::path>(L.model->atlasImage) : std::nullopt;
}

void SceneRunner::releaseTrainingImage() {
  Loaded& L = *loaded_;
  L.sim->scene().releaseTrainingImage();
  const std::optional<fs::path> training = trainingImagePath();
  if (training && *training != scene_.targetImage) L.images.erase(*training);
}

const InitialisationResult& SceneRunner::initialisation() const { return loaded_->init; }

void SceneRunner::sample(RunReport& report, double seconds, ExecutionBackend* backend, bool withError) {
  Loaded& L = *loaded_;
  MeshStore& store = L.sim->store();
  const auto x = store.positions();
  const auto prev = store.previousPositions();
  const auto f = store.forces();
  const auto t0 = Clock::now();
  std::vector<std::optional<SurfaceDistanceStats>> error(store.meshCount());
  std::vector<double> dice(store.meshCount(), std::nan(""));
  // The Dice on the host's threads beside the distances (which a device measures while they run).
  if (withError) L.sim->executor().invoke([&] { error = sampledError(backend); }, [&] { dice = timelineDice(); });
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
    if (error[i]) s.assdMm = error[i]->assd, s.hd95Mm = error[i]->hd95;
    s.dice = dice[i];
    report.timeline.push_back(s);
  }
  L.samplingSeconds += since(t0);
}

RunReport SceneRunner::run() {
  Loaded& L = *loaded_;
  Simulation& sim = *L.sim;
  RunReport report;
  report.threads = sim.executor().threads();
  report.device = cpuDescription(report.threads);
  report.initialisation = L.init;
  {
    const std::lock_guard lock(L.backgroundMutex);
    report.backgroundSeconds = L.backgroundSeconds;
  }
  std::unique_ptr<ExecutionBackend> backend = options_.backend ? options_.backend(sim) : nullptr;
  if (backend) {
    report.backend = backend->name();
    report.device = backend->device();
  }
  if (options_.backend) L.clock.lap("start_backend");
  // The start and the model, evaluated exactly. With a device running the steps, the host's threads
  // are free meanwhile, so the scoring runs beside the simulation (the surfaces are taken now).
  const bool initialised = scene_.initialise.method != InitialiseDesc::Method::None;
  const bool ownModel = initialised && sim.level() == 0;
  const bool modelScored = ownModel && !L.modelScores.empty();  // by initialise(), beside the registration
  std::vector<StructureResult> initial, model = modelScored ? L.modelScores : std::vector<StructureResult>{};
  for (Index i = 0; i < sim.structureCount(); ++i) {
    const auto x = sim.store().mesh(sim.store().positions(), i);
    initial.push_back(surfaceOf(i, std::vector<Vec3>(x.begin(), x.end())));
    if (!modelScored) model.push_back(ownModel ? surfaceOf(i, L.modelPositions[i]) : StructureResult{});
  }
  const bool scoredBeside = backend && L.reading == std::launch::async;
  const auto scoreStart = [this, &initial, &model, ownModel, modelScored, scoredBeside] {
    const auto t1 = Clock::now();
    // In the run's way, structures side by side as well (each one's sort and Dice are serial);
    // beside a device, one after another, so as not to crowd out the thread that drives it.
    loaded_->sim->executor().forEach(
        Index(initial.size()),
        [&](Index i) {
          score(i, initial[i], true);
          if (!ownModel) model[i] = initial[i];
          else if (!modelScored) score(i, model[i], true);
        },
        scoredBeside ? Index(initial.size()) : Index(1));
    return since(t1);
  };
  std::future<double> startScores = std::async(scoredBeside ? std::launch::async : std::launch::deferred, scoreStart);
  if (!scoredBeside) startScores.wait();
  L.clock.lap("evaluate_start");
  // A backend that fails mid-run (device memory, a lost device) hands over to the CPU, which goes on
  // from the last state the backend downloaded.
  auto onBackend = [&](const std::function<void(ExecutionBackend&)>& work) {
    if (!backend) return false;
    try {
      work(*backend);
      return true;
    } catch (const NumericalError& e) {
      // The scene's problem (a structure inside another), not the backend's: the run stops as it
      // would on the CPU, with the last good state.
      report.numericalFailure = e.what();
      if (options_.log) options_.log(std::string("numerical failure: ") + e.what());
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
  double simSeconds = 0.0;  // the steps' time alone: the timeline's clock
  // The stage covers the whole loop but its sampling (level changes, progress reports included).
  const double samplingBefore = L.samplingSeconds;
  // The timeline's first and last samples take the exact evaluation's scores of the same positions
  // (the start's and the end's, computed anyway), filled in below: the curve ends on the final
  // table's values, and two samples (a finest-level one the dearest) are not measured twice.
  sample(report, 0.0, backend.get(), false);
  bool lastSampleDeferred = false;
  for (int level = 0; level < levels && report.numericalFailure.empty(); ++level) {
    const LevelDesc& lv = scene_.schedule[level];
    levelSeconds_ = {};
    if (level > 0) {
      const auto t0 = Clock::now();
      enterNextLevel();
      onBackend([](ExecutionBackend& b) { b.levelChanged(); });
      levelSeconds_.enter = since(t0);
      simSeconds += levelSeconds_.enter;
    }
    // The finest level's forces are trained: nothing reads the training image again in this run,
    // and its memory is off the peak that the evaluation and the outputs reach (docs/benchmarks.md).
    if (level + 1 == levels) releaseTrainingImage();
    report.levelStartSeconds.push_back(simSeconds);
    // Steps run in chunks that end on the sample points; only samples bring state to the host.
    for (int it = 0; it < lv.iterations && report.numericalFailure.empty();) {
      const int chunk = std::min(scene_.sampleInterval - it % scene_.sampleInterval, lv.iterations - it);
      const auto t0 = Clock::now();
      const auto runChunk = [&] {
        if (onBackend([&](ExecutionBackend& b) { runGuarded(b, chunk, report); })) return;
        const auto stepsStart = Clock::now();
        try {
          sim.run(chunk);
          levelSeconds_.steps += since(stepsStart);
        } catch (const NumericalError& e) {
          levelSeconds_.steps += since(stepsStart);
          // The stability guard gave up and left the last good state: the run ends here and keeps it.
          report.numericalFailure = e.what();
          if (options_.log) options_.log(std::string("numerical failure: ") + e.what());
        }
      };
      if (sim.stabilityGuard().enabled) {
        holdChunkStart();
        runShapeGuarded(runChunk, chunk, report, [&] {
          if (backend) backend->restoreState();
        });
      } else {
        runChunk();
      }
      simSeconds += since(t0);
      it += chunk;
      done += chunk;
      lastSampleDeferred = (level + 1 == levels && it == lv.iterations) || !report.numericalFailure.empty();
      sample(report, simSeconds, backend.get(), !lastSampleDeferred);
      if (options_.progress) {
        RunProgress p{level, levels, it, lv.iterations, done, total, simSeconds};
        meanOfLastSample(report, sim.structureCount(), p);
        options_.progress(p);
      }
    }
    // The level's error is that of its last sample.
    for (const StabilityEvent& e : sim.stabilityEvents()) levelSeconds_.rollbacks += e.level == level && e.recovered;
    StageResult st{"level " + std::to_string(level), simSeconds - report.levelStartSeconds.back(), {}, levelSeconds_};
    for (Index i = 0; i < sim.structureCount(); ++i)
      st.assdMm.push_back(report.timeline[report.timeline.size() - sim.structureCount() + i].assdMm);
    report.stages.push_back(std::move(st));
  }
  report.simulationSeconds = simSeconds;
  const double loopSampling = L.samplingSeconds - samplingBefore;
  L.clock.split("simulation", "sample_error", loopSampling);
  const double startScoring = startScores.get();
  const size_t structures = size_t(sim.structureCount());
  for (size_t i = 0; i < structures; ++i)  // the first sample (the start's positions)
    report.timeline[i].assdMm = initial[i].assdFinalMm, report.timeline[i].hd95Mm = initial[i].hd95Mm,
    report.timeline[i].dice = initial[i].dice;
  if (scoredBeside) {
    L.clock.lap("evaluate_start_wait");
    report.backgroundSeconds.emplace_back("evaluate_start", startScoring);
  }
  std::vector<StageResult> firstStages;  // before the levels'
  auto stageOf = [&](std::string name, double seconds, const std::vector<StructureResult>& rs) {
    StageResult st{std::move(name), seconds, {}, std::nullopt};
    for (const auto& x : rs) st.assdMm.push_back(x.assdFinalMm);
    firstStages.push_back(std::move(st));
  };
  stageOf("model", 0.0, model);
  if (initialised) stageOf("initialisation", L.init.seconds, initial);
  report.stages.insert(report.stages.begin(), firstStages.begin(), firstStages.end());
  report.stability = sim.stabilityEvents();
  std::vector<StructureResult> end = evaluateEnd(backend.get());
  for (Index i = 0; i < sim.structureCount(); ++i) {
    StructureResult r = std::move(end[i]);
    r.assdInitialMm = initial[i].assdFinalMm;
    r.diceInitial = initial[i].dice;
    r.assdModelMm = model[i].assdFinalMm;
    r.diceModel = model[i].dice;
    r.seconds = simSeconds;
    report.structures.push_back(std::move(r));
  }
  if (lastSampleDeferred)  // the last sample and its level's error: the end's positions
    for (size_t i = 0; i < structures; ++i) {
      TimelineSample& s = report.timeline[report.timeline.size() - structures + i];
      s.assdMm = report.structures[i].assdFinalMm, s.hd95Mm = report.structures[i].hd95Mm;
      s.dice = report.structures[i].dice;
      report.stages.back().assdMm[i] = s.assdMm;
    }
  L.clock.lap("evaluate_end");
  if (sim.structureCount() > 1) {
    std::vector<const TriangleMesh*> start, end;
    for (Index i = 0; i < sim.structureCount(); ++i) {
      start.push_back(&initial[i].surface);
      end.push_back(&report.structures[i].surface);
    }
    std::map<std::pair<int, int>, OverlapResult> pairs;
    for (const PairOverlap& o : pairwiseOverlaps(start, kOverlapSpacingMm)) pairs[{o.a, o.b}] = {o.a, o.b, o.volumeMm3, 0.0};
    for (const PairOverlap& o : pairwiseOverlaps(end, kOverlapSpacingMm)) {
      auto& r = pairs[{o.a, o.b}];
      r.a = o.a, r.b = o.b, r.afterMm3 = o.volumeMm3;
    }
    for (const auto& [key, r] : pairs) report.overlaps.push_back(r);
    L.clock.lap("overlaps");
  }
  report.stageClock = L.clock;
  report.totalSeconds = L.clock.total();
  return report;
}

bool SceneRunner::enterNextLevel() {
  Simulation& sim = *loaded_->sim;
  const int next = sim.level() + 1;
  if (next >= sim.levelCount()) return false;
  // The level's values first: profile training and the like read them on entering the level.
  for (const auto& [name, values] : scene_.schedule[next].forces)
    applyParams(scene_, sim.forceParams(name), values, -1, "/schedule/" + std::to_string(next) + "/forces/" + name);
  sim.setAffineRegularisation(float(scene_.schedule[next].affineRegularisation));
  sim.setCoarseForceWeight(float(scene_.schedule[next].coarseForces));
  if (!sim.advanceLevel()) return false;
  if (sim.restoredTimeStep() > 0.0 && options_.log) {
    char text[96];
    std::snprintf(text, sizeof text, "stability guard: level %d starts again at time step %g", next, sim.restoredTimeStep());
    options_.log(text);
  }
  return true;
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
