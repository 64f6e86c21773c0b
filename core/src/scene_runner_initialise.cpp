// SceneRunner's "initialise" stage: the registration (started early, beside the loading, when
// files are read in the background), a transform file or landmarks, and the map applied to every
// structure's reference shapes and initial positions.
#include "scene_runner_loaded.h"

namespace sinew {

namespace fs = std::filesystem;

// The registration of the "initialise" stage, started as soon as its images are named: in the
// background when files are read so (Loaded::registration), else deferred to initialise(). A scene
// whose registration cannot run (no atlas image, no registration plugin) fails here, when load()
// starts it, before any structure is made.
void SceneRunner::Loaded::startRegistration(const Registry& registry, const SceneDesc& scene,
                                            const std::function<void(const std::string&)>& log, std::launch policy) {
  const InitialiseDesc& d = scene.initialise;
  if (d.method != InitialiseDesc::Method::Registration || registration.result.valid()) return;
  const std::optional<fs::path> moving = d.movingImage ? d.movingImage
                                         : model       ? std::optional<fs::path>(model->atlasImage)
                                                         : scene.trainingImage;
  if (!moving)
    sceneError(scene, "/initialise/registration",
               "registration needs the model's atlas image: name a \"model\", a training image or \"moving_image\"");
  const ImageIODescriptor* io = nullptr;
  try {
    io = &registry.imageRegistration();
  } catch (const InputError& e) {
    sceneError(scene, "/initialise/registration", e.what());
  }
  if (policy == std::launch::async && reading != std::launch::async) return;  // one thread: in initialise()
  log("registering " + moving->filename().string() + " to the target (" +
      (d.bsplineCells > 0 ? "rigid, affine, then B-spline" : d.affine ? "rigid, then affine" : "rigid") +
      (policy == std::launch::async ? "), beside the loading" : ")"));
  Pending<Image3D> target = startImage(registry, scene.targetImage), atlas = startImage(registry, *moving);
  RegistrationOptions o;
  o.affine = d.affine;
  o.bsplineCells = d.bsplineCells;
  o.levels = d.levels;
  o.iterations = d.iterations;
  o.samplesPerLevel = d.samples;
  o.log = [&lines = registration.log](const std::string& line) { lines.push_back(line); };
  o.cancelled = [&cancel = registration.cancel] { return cancel.load(); };
  registration.beside = policy == std::launch::async;
  registration.result = std::async(policy, [io, target, atlas, o, file = scene.file, &seconds = registration.seconds] {
    const std::shared_ptr<Image3D> fixed = target.get(), moving = atlas.get();  // their errors name their files
    const auto t0 = Clock::now();
    try {
      RegistrationResult r = io->registerImages(*fixed, *moving, o);
      seconds = since(t0);
      return r;
    } catch (const InputError& e) {
      throw InputError(file.string() + ": /initialise: " + e.what());
    }
  });
}

namespace {
// A registration's B-spline maps are sampled on grids over the structures' shapes grown by a
// margin: in the model for the map (every 2 mm; each value there is a Newton solve), in the target
// for the training map (every 3 mm: it only places the atlas image's samples), whose points reach
// out along the reference normals by the profiles' length and search.
constexpr double kMapGridMm = 2.0, kTrainingGridMm = 3.0, kMapBoxMarginMm = 5.0, kTrainingBoxMarginMm = 25.0;

std::pair<Eigen::Vector3d, Eigen::Vector3d> boxOf(const std::vector<StructureSpec>& specs, double marginMm) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  const auto extend = [&](std::span<const Vec3> points) {
    for (const Vec3& p : points) {
      lo = lo.cwiseMin(p.cast<double>());
      hi = hi.cwiseMax(p.cast<double>());
    }
  };
  for (const StructureSpec& s : specs) {
    extend(s.referencePositions);
    for (const auto& level : s.finerReferences) extend(level);
    extend(s.initialPositions);
  }
  return {lo.array() - marginMm, hi.array() + marginMm};
}
}  // namespace

// The map of the "initialise" stage, applied to every structure's reference shapes (all levels) and
// initial positions: the model moves into the target as a whole. Initial meshes given as files
// are in the target already and stay.
void SceneRunner::initialise(std::vector<StructureSpec>& specs, const std::function<void(const std::string&)>& log) {
  Loaded& L = *loaded_;
  const InitialiseDesc& d = scene_.initialise;
  if (d.method == InitialiseDesc::Method::None) return;
  for (const auto& s : specs) L.modelPositions.push_back(s.initialPositions);
  InitialisationResult& r = L.init;
  SpatialMap map, inverse;
  bool sampleInverseAfterMapping = false;
  const auto t0 = Clock::now();
  switch (d.method) {
    case InitialiseDesc::Method::None: break;
    case InitialiseDesc::Method::Registration: {
      L.startRegistration(registry_, scene_, log, std::launch::deferred);  // unless started: one thread
      L.clock.lap("initialisation");  // its own stage, not counted twice
      // The model's placement does not depend on the registration, which runs on one thread: its
      // exact evaluation fills the others here instead of waiting, not after it (run()).
      if (L.registration.beside && L.sampled) {  // the sampled error exists when some structure has a truth
        for (size_t i = 0; i < specs.size(); ++i) {
          StructureResult m;
          m.surface = tessellate(specs[i].levels.levels[0], L.modelPositions[i]);
          L.modelScores.push_back(std::move(m));
        }
        L.sim->executor().forEach(Index(specs.size()), [&](Index i) { score(i, L.modelScores[size_t(i)], true); }, 1);
        L.clock.lap("evaluate_model");
      }
      const RegistrationResult reg = L.registration.result.get();
      for (const std::string& line : L.registration.log)
        if (options_.log) options_.log(line);
      if (L.registration.beside) {
        const std::lock_guard lock(L.backgroundMutex);
        L.backgroundSeconds.emplace_back("registration", L.registration.seconds);
      }
      L.clock.lap("registration");
      r.method = std::string("registration (") + (!reg.deformation.empty() ? "affine, then B-spline" : d.affine ? "affine" : "rigid") + ")";
      r.registration = reg.stages;
      r.transform = reg;
      break;
    }
    case InitialiseDesc::Method::Transform:
      try {
        r.transform = registry_.imageRegistration().readTransform(d.transform);
      } catch (const InputError& e) {
        sceneError(scene_, "/initialise/transform", e.what());
      }
      r.method = "transform " + d.transform.string() + (r.transform.deformation.empty() ? "" : " (affine, then B-spline)");
      break;
    case InitialiseDesc::Method::Landmarks:
      try {
        // The spline's inverse has no closed form: the spline through the swapped pairs stands in
        // for it (exact at the landmarks), to train on the atlas image.
        std::vector<LandmarkPair> swapped;
        for (const auto& p : d.landmarks) swapped.push_back({p.target, p.model});
        map = d.thinPlateSpline ? SpatialMap::fitThinPlateSpline(d.landmarks) : SpatialMap::fitAffine(d.landmarks);
        inverse = d.thinPlateSpline ? SpatialMap::fitThinPlateSpline(swapped)
                                    : SpatialMap::affine(map.affinePart().inverse());
      } catch (const InputError& e) {
        sceneError(scene_, "/initialise/landmarks", e.what());
      }
      r.method = "landmarks: " + map.describe();
      r.hasAffine = !map.hasSpline();
      r.transform.targetToModel = map.affinePart().inverse();
      break;
  }
  if (d.method == InitialiseDesc::Method::Registration || d.method == InitialiseDesc::Method::Transform) {
    r.hasAffine = true;
    const RegistrationTransform& t = r.transform;
    map = SpatialMap::affine(t.targetToModel.inverse());
    inverse = SpatialMap::affine(t.targetToModel);
    if (!t.deformation.empty()) {
      // The B-spline then the affine takes the target to the model; the model is placed by its
      // inverse. Each is evaluated from its own values on a grid over where it is used
      // (SpatialMap::sampledOn).
      try {
        inverse = SpatialMap::warpThenAffine(t.deformation, t.targetToModel);
      } catch (const InputError& e) {
        sceneError(scene_, d.method == InitialiseDesc::Method::Transform ? "/initialise/transform" : "/initialise/registration",
                   e.what());
      }
      map = inverse.inverse();
      const auto [lo, hi] = boxOf(specs, kMapBoxMarginMm);
      map = map.sampledOn(lo, hi, kMapGridMm);
      sampleInverseAfterMapping = true;
    }
  }
  for (size_t i = 0; i < specs.size(); ++i) {
    StructureSpec& s = specs[i];
    map.applyInPlace(s.referencePositions);
    for (auto& level : s.finerReferences) map.applyInPlace(level);
    if (!scene_.structures[i].initial.mesh) map.applyInPlace(s.initialPositions);
    for (const Vec3& p : s.initialPositions)
      if (!p.allFinite())
        sceneError(scene_, "/initialise", "the initialisation maps structure '" + s.name + "' to non-finite positions");
  }
  if (sampleInverseAfterMapping) {  // over the mapped shapes and their profiles' reach, in the target
    const auto [lo, hi] = boxOf(specs, kTrainingBoxMarginMm);
    inverse = inverse.sampledOn(lo, hi, kTrainingGridMm);
  }
  L.trainingMap = inverse;
  r.seconds = since(t0);
  log("initialisation: " + r.method);
}

}  // namespace sinew
