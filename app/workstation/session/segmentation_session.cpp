#include "segmentation_session.h"

#include "backend_choice.h"
#include "sinew/core/collision_tree.h"
#include "sinew/core/medial_axis.h"
#include "sinew/core/simplex_mesh.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

namespace sinew {

namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
constexpr const char* kAttraction = "attraction_points";

std::uint64_t nextSnapshotId() {
  static std::atomic<std::uint64_t> next{1};
  return next++;
}
}  // namespace

SegmentationSession::SegmentationSession(const Registry& registry) : registry_(registry) {}
SegmentationSession::~SegmentationSession() = default;

void SegmentationSession::open(const fs::path& sceneFile, const SessionOpenOptions& options) {
  open(readScene(sceneFile), options);
}

void SegmentationSession::open(SceneDesc scene, const SessionOpenOptions& options) {
  if (options.requirePlugin)
    for (const std::string& plugin : scene.plugins) options.requirePlugin(plugin);
  bool hasAttraction = false;
  for (const auto& f : scene.forces) hasAttraction |= f.first == kAttraction;
  if (!hasAttraction) scene.forces.emplace_back(kAttraction, std::vector<std::pair<std::string, double>>{});
  RunOptions run;
  run.threads = options.threads;
  run.log = options.log;
  auto runner = std::make_unique<SceneRunner>(registry_, std::move(scene), run);
  runner->load();  // throws before anything of the previous session is touched
  auto notice = options.log ? options.log : [](const std::string&) {};
  backend_.reset();
  backend_ = makeBackend(options.backend, runner->simulation(), notice);
  runner_ = std::move(runner);
  log_ = options.log;
  landmarks_.clear();
  hostCurrent_ = true;
  levelDone_ = 0;
  simSeconds_ = secondsPerStep_ = 0.0;
  timeline_.clear();
  undo_.clear();
  redo_.clear();
  lastEdit_.clear();
  sample();
  changed();
}

void SegmentationSession::close() {
  backend_.reset();  // before the simulation it mirrors
  runner_.reset();
  timeline_.clear();
  undo_.clear();
  redo_.clear();
  changed();
}

const SceneDesc& SegmentationSession::scene() const { return runner_->scene(); }
Simulation& SegmentationSession::simulation() { return runner_->simulation(); }
const Image3D& SegmentationSession::image() { return simulation().scene().targetImage(); }
Index SegmentationSession::structureCount() { return simulation().structureCount(); }
std::string SegmentationSession::backendName() const { return backend_ ? backend_->name() : "cpu"; }
std::string SegmentationSession::deviceName() const {
  return backend_ ? backend_->device() : cpuDescription(runner_->simulation().executor().threads());
}
int SegmentationSession::level() { return simulation().level(); }
int SegmentationSession::levelCount() { return simulation().levelCount(); }
int SegmentationSession::levelIterationsPlanned() const {
  return runner_->scene().schedule[runner_->simulation().level()].iterations;
}

int SegmentationSession::step(int iterations) {
  if (iterations <= 0) return 0;
  const auto t0 = Clock::now();
  // Both guards, on either backend, as in sinew-run: a violation is undone and the step halved; when
  // the guard gives up, the last good state stays and the reason is thrown.
  std::string stopped;
  bool done = false;
  // The shape is checked at every call: a rollback undoes this call's steps only, so a check that
  // skipped calls could find a shape gone wrong before them and never recover.
  if (backend_) {
    try {
      stopped = runner_->runGuardedChunk(backend_.get(), iterations);
      hostCurrent_ = true;  // the guard downloaded the chunk to check it
      done = true;
    } catch (const NumericalError&) {
      throw;  // the scene's problem (e.g. a structure inside another), not the backend's: keep it
    } catch (const std::runtime_error& e) {
      fallBackToCpu(e);  // the interrupted batch is lost
    }
  }
  if (!done) stopped = runner_->runGuardedChunk(nullptr, iterations);
  if (!stopped.empty()) {
    changed();
    throw NumericalError(stopped);
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  simSeconds_ += seconds;
  const double perStep = seconds / iterations;
  secondsPerStep_ = secondsPerStep_ == 0.0 ? perStep : 0.7 * secondsPerStep_ + 0.3 * perStep;
  levelDone_ += iterations;
  changed();
  return iterations;
}

int SegmentationSession::stepFor(double budgetSeconds, bool followSchedule) {
  int done = 0;
  const auto t0 = Clock::now();
  do {
    int n = secondsPerStep_ > 0.0 ? static_cast<int>((budgetSeconds - std::chrono::duration<double>(Clock::now() - t0).count()) /
                                                     secondsPerStep_)
                                  : 1;
    n = std::clamp(n, 1, 1000);
    if (followSchedule) n = std::min(n, levelIterationsPlanned() - levelDone_);
    if (n <= 0) break;
    done += step(n);
  } while (std::chrono::duration<double>(Clock::now() - t0).count() < budgetSeconds * 0.8);
  return done;
}

bool SegmentationSession::nextLevel() {
  syncHost();
  if (!runner_->enterNextLevel()) return false;
  if (backend_) {
    try {
      backend_->levelChanged();
    } catch (const std::runtime_error& e) {
      // The finer level may not fit on the device: the CPU goes on from the host's state.
      fallBackToCpu(e);
    }
  }
  levelDone_ = 0;
  undo_.clear();
  redo_.clear();
  lastEdit_.clear();
  changed();
  return true;
}

// Continues on the CPU from the last state the host has (device memory ran out, or the device was
// lost).
void SegmentationSession::fallBackToCpu(const std::runtime_error& e) {
  if (log_) log_(backend_->name() + " backend failed (" + e.what() + "); continuing on the CPU");
  backend_.reset();
  hostCurrent_ = true;
  changed();
}

void SegmentationSession::syncHost() {
  if (hostCurrent_) return;
  if (backend_) backend_->download();
  hostCurrent_ = true;
}

const SessionSample& SegmentationSession::sample() {
  syncHost();
  Simulation& sim = simulation();
  MeshStore& store = sim.store();
  SessionSample s;
  s.seconds = simSeconds_;
  s.iteration = sim.iteration();
  s.level = sim.level();
  const auto x = store.positions();
  const auto prev = store.previousPositions();
  double disp = 0.0;
  for (Index v = 0; v < store.vertexCount(); ++v) disp += (x[v] - prev[v]).norm();
  s.displacementMm = disp / std::max<Index>(store.vertexCount(), 1);
  double assd = 0.0;
  int withTruth = 0;
  auto errors = [&] {  // on the device with the CUDA backend
    try {
      return runner_->sampledError(backend_.get());
    } catch (const std::runtime_error& e) {
      if (!backend_) throw;
      fallBackToCpu(e);
      return runner_->sampledError(nullptr);
    }
  };
  for (const auto& e : errors())
    if (e) {
      assd += e->assd;
      ++withTruth;
    }
  s.assdMm = withTruth ? assd / withTruth : std::nan("");
  if (withTruth) {
    double dice = 0.0;
    for (double d : runner_->timelineDice())
      if (!std::isnan(d)) dice += d;
    s.dice = dice / withTruth;
  }
  timeline_.push_back(s);
  return timeline_.back();
}

bool SegmentationSession::hasGroundTruth() {
  for (Index i = 0; i < structureCount(); ++i)
    if (runner_->hasGroundTruth(i)) return true;
  return false;
}

// --- edits and history ---------------------------------------------------------------------------

std::size_t SessionSnapshot::bytes() const {
  std::size_t b = sizeof(SessionSnapshot) + label.size() + (positions.size() + previous.size()) * sizeof(Vec3);
  for (const auto& p : points) b += p.size() * sizeof(Vec3);
  for (const auto& p : constraints) b += p.size() * sizeof(ConstraintPoint);
  b += landmarks.size() * sizeof(PlacedLandmark);
  for (const auto& t : forceParams) b += t.decls().size() * (sizeof(ParamDecl) + sizeof(double) * t.rows());
  return b;
}

SegmentationSession::Snapshot SegmentationSession::capture(std::string label) {
  syncHost();
  Simulation& sim = simulation();
  Snapshot s;
  s.id = nextSnapshotId();
  s.label = std::move(label);
  s.level = sim.level();
  const auto x = sim.store().positions();
  const auto prev = sim.store().previousPositions();
  s.positions.assign(x.begin(), x.end());
  s.previous.assign(prev.begin(), prev.end());
  s.points = sim.scene().attractionPoints();
  s.constraints = sim.scene().constraintPoints();
  s.landmarks = landmarks_;
  for (const std::string& f : sim.forceNames()) s.forceParams.push_back(sim.forceParams(f));
  s.forceParams.push_back(sim.integratorParams());
  return s;
}

void SegmentationSession::restore(const Snapshot& s) {
  Simulation& sim = simulation();
  syncHost();
  auto x = sim.store().positionsForWrite();
  auto prev = sim.store().previousPositions();
  std::copy(s.positions.begin(), s.positions.end(), x.begin());
  std::copy(s.previous.begin(), s.previous.end(), prev.begin());
  sim.scene().attractionPoints() = s.points;
  sim.scene().constraintPoints() = s.constraints;
  landmarks_ = s.landmarks;
  const auto names = sim.forceNames();
  for (size_t f = 0; f < names.size(); ++f) sim.forceParams(names[f]) = s.forceParams[f];
  sim.integratorParams() = s.forceParams.back();
  if (backend_) backend_->reload();
  runner_->restartShapeGuard();
  lastEdit_.clear();
  changed();
}

void SegmentationSession::endEdit() { lastEdit_.clear(); }

void SegmentationSession::beginEdit(const std::string& label, bool continuing) {
  runner_->restartShapeGuard();  // what the user does is not a wrong shape
  if (continuing && !undo_.empty() && lastEdit_ == label) return;  // the drag goes on: one undo step
  undo_.push_back(std::make_shared<const Snapshot>(capture(label)));
  redo_.clear();
  lastEdit_ = label;
  trimHistory();
}

void SegmentationSession::trimHistory() {
  while (undo_.size() > 1 && historyBytes() > historyLimit_) undo_.pop_front();
}

void SegmentationSession::setHistoryLimit(std::size_t bytes) {
  historyLimit_ = bytes;
  trimHistory();
}

std::size_t SegmentationSession::historyBytes() const {
  std::size_t b = 0;
  for (const auto& s : undo_) b += s->bytes();
  for (const auto& s : redo_) b += s->bytes();
  return b;
}

bool SegmentationSession::undo() { return travel(undo_, redo_); }
bool SegmentationSession::redo() { return travel(redo_, undo_); }

// Restores the newest snapshot of `from`, keeping the current state on `to` under the same label.
bool SegmentationSession::travel(std::deque<SnapshotPtr>& from, std::deque<SnapshotPtr>& to) {
  if (from.empty()) return false;
  const SnapshotPtr target = std::move(from.back());
  from.pop_back();
  to.push_back(std::make_shared<const Snapshot>(capture(target->label)));
  restore(*target);
  return true;
}

SessionState SegmentationSession::state() {
  SessionState s;
  s.scene = currentScene();
  s.levelIterationsDone = levelDone_;
  s.iteration = simulation().iteration();
  s.simulationSeconds = simSeconds_;
  s.timeline = timeline_;
  s.current = std::make_shared<const Snapshot>(capture("current"));
  s.undo.assign(undo_.begin(), undo_.end());
  s.redo.assign(redo_.begin(), redo_.end());
  return s;
}

void SegmentationSession::restoreState(const SessionState& state, const SessionOpenOptions& options) {
  if (!state.current) throw InputError("the saved session holds no state");
  open(state.scene, options);
  while (level() < state.current->level && nextLevel()) {
  }
  // Each snapshot is checked against the opened scene and takes its parameter values into the
  // scene's own declarations (a saved file holds only the names), with a fresh id.
  Simulation& sim = simulation();
  const auto names = sim.forceNames();
  auto adopt = [&](const Snapshot& saved) {
    if (saved.level != level() || saved.positions.size() != std::size_t(sim.store().vertexCount()) ||
        saved.previous.size() != saved.positions.size() || saved.points.size() != std::size_t(structureCount()) ||
        saved.constraints.size() != saved.points.size() || saved.forceParams.size() != names.size() + 1)
      throw InputError("the saved state does not fit its scene (another model, or another level?)");
    for (const auto* list : {&saved.positions, &saved.previous})
      for (const Vec3& v : *list)
        if (!v.allFinite()) throw InputError("the saved state has a non-finite vertex position");
    Snapshot s = saved;
    s.id = nextSnapshotId();
    for (std::size_t f = 0; f <= names.size(); ++f) {
      const ParamTable& from = saved.forceParams[f];
      ParamTable to = f < names.size() ? sim.forceParams(names[f]) : sim.integratorParams();
      if (from.rows() != to.rows()) throw InputError("the saved parameters do not fit the scene's structures");
      for (int p = 0; p < int(from.decls().size()); ++p) {
        const int q = to.indexOf(from.decls()[p].name);
        for (Index r = 0; r < to.rows(); ++r)
          if (to.decls()[q].perStructure || r == 0) to.set(r, q, from.get(r, p));
      }
      s.forceParams[f] = std::move(to);
    }
    return std::make_shared<const Snapshot>(std::move(s));
  };
  const SnapshotPtr now = adopt(*state.current);
  std::deque<SnapshotPtr> undo, redo;
  for (const auto& s : state.undo) undo.push_back(adopt(*s));
  for (const auto& s : state.redo) redo.push_back(adopt(*s));
  sim.setIteration(state.iteration);
  restore(*now);
  undo_ = std::move(undo);
  redo_ = std::move(redo);
  levelDone_ = state.levelIterationsDone;
  simSeconds_ = state.simulationSeconds;
  timeline_ = state.timeline;
  changed();
}

const std::vector<Vec3>& SegmentationSession::attractionPoints(Index structure) {
  return simulation().scene().attractionPoints()[structure];
}

void SegmentationSession::addAttractionPoint(Index structure, const Vec3& point) {
  if (!point.allFinite()) throw InputError("an attraction point needs finite coordinates");
  beginEdit("Add attraction point", false);
  simulation().scene().attractionPoints()[structure].push_back(point);
  lastEdit_.clear();
  changed();
}

void SegmentationSession::moveAttractionPoint(Index structure, int index, const Vec3& point, bool continuing) {
  if (!point.allFinite()) throw InputError("an attraction point needs finite coordinates");
  auto& points = simulation().scene().attractionPoints()[structure];
  if (index < 0 || index >= static_cast<int>(points.size())) throw InputError("no such attraction point");
  beginEdit("Move attraction point " + std::to_string(structure) + "/" + std::to_string(index), continuing);
  points[index] = point;
  changed();
}

void SegmentationSession::removeAttractionPoint(Index structure, int index) {
  auto& points = simulation().scene().attractionPoints()[structure];
  if (index < 0 || index >= static_cast<int>(points.size())) throw InputError("no such attraction point");
  beginEdit("Delete attraction point", false);
  points.erase(points.begin() + index);
  lastEdit_.clear();
  changed();
}

bool SegmentationSession::due(std::size_t size, std::uint64_t revision, std::chrono::steady_clock::time_point at,
                              std::chrono::steady_clock::time_point now, double minIntervalSeconds) {
  return size != std::size_t(simulation().store().vertexCount()) ||
         (revision != revision_ && std::chrono::duration<double>(now - at).count() >= minIntervalSeconds);
}

const std::vector<unsigned char>& SegmentationSession::contactMask(double minIntervalSeconds) {
  const auto now = std::chrono::steady_clock::now();
  if (!due(contactMask_.size(), contactRevision_, contactTime_, now, minIntervalSeconds)) return contactMask_;
  syncHost();
  Simulation& sim = simulation();
  const std::vector<std::string> forces = sim.forceNames();
  const bool collisions = std::find(forces.begin(), forces.end(), "collision") != forces.end();
  const float margin = collisions ? float(parameter("collision", 0, "margin_mm")) : 0.25f;
  contactMask_ = sinew::contactMask(sim.store(), sim.scene(), margin);
  contactRevision_ = revision_;
  contactTime_ = now;
  return contactMask_;
}

const std::vector<float>& SegmentationSession::vertexImageFit(double minIntervalSeconds) {
  const auto now = std::chrono::steady_clock::now();
  if (!due(vertexFit_.size(), vertexFitRevision_, vertexFitTime_, now, std::max(minIntervalSeconds, 20.0 * vertexFitSeconds_)))
    return vertexFit_;
  syncHost();
  vertexFit_ = sinew::vertexImageFit(simulation());
  vertexFitRevision_ = revision_;
  vertexFitTime_ = now;
  vertexFitSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - now).count();
  return vertexFit_;
}

const std::vector<float>& SegmentationSession::medialRadius(double minIntervalSeconds, bool wait) {
  static const std::vector<float> none;
  const auto finish = [&] {
    medialRadius_ = medialJob_.get();
    medialRevision_ = medialJobRevision_;
    medialTime_ = medialJobTime_;
  };
  if (medialJob_.valid() && medialJob_.wait_for(std::chrono::seconds(0)) == std::future_status::ready) finish();
  const auto now = std::chrono::steady_clock::now();
  if (!medialJob_.valid() && due(medialRadius_.size(), medialRevision_, medialTime_, now, minIntervalSeconds)) {
    // The surfaces are copied here; the job touches nothing of the session's.
    syncHost();
    MeshStore& store = simulation().store();
    std::vector<TriangleMesh> surfaces;
    for (Index m = 0; m < store.meshCount(); ++m) {
      const auto x = store.mesh(store.positions(), m);
      surfaces.push_back(tessellate(store.topologyOf(m), {x.begin(), x.end()}));
    }
    std::vector<Index> counts;
    for (Index m = 0; m < store.meshCount(); ++m) counts.push_back(store.range(m).vertexCount());
    medialJobRevision_ = revision_;
    medialJobTime_ = now;
    medialJob_ = std::async(std::launch::async, [surfaces = std::move(surfaces), counts = std::move(counts)] {
      const Executor executor;
      std::vector<float> out;
      for (std::size_t m = 0; m < surfaces.size(); ++m) {
        // The tessellation's points are the structure's vertices, then its cell centres.
        const std::vector<float> radii = medialRadii(surfaces[m], executor);
        out.insert(out.end(), radii.begin(), radii.begin() + counts[m]);
      }
      return out;
    });
  }
  if (wait && medialJob_.valid()) finish();
  return medialRadius_.size() == std::size_t(simulation().store().vertexCount()) ? medialRadius_ : none;
}

const std::vector<ConstraintPoint>& SegmentationSession::constraintPoints(Index structure) {
  return simulation().scene().constraintPoints()[structure];
}

void SegmentationSession::addConstraintPoint(Index structure, const ConstraintPoint& point) {
  if (!point.at.allFinite()) throw InputError("an include / exclude point needs finite coordinates");
  beginEdit(point.include ? "Add include point" : "Add exclude point", false);
  simulation().scene().constraintPoints()[structure].push_back(point);
  lastEdit_.clear();
  changed();
}

void SegmentationSession::moveConstraintPoint(Index structure, int index, const Vec3& point, bool continuing) {
  if (!point.allFinite()) throw InputError("an include / exclude point needs finite coordinates");
  auto& points = simulation().scene().constraintPoints()[structure];
  if (index < 0 || index >= static_cast<int>(points.size())) throw InputError("no such include / exclude point");
  beginEdit("Move include / exclude point " + std::to_string(structure) + "/" + std::to_string(index), continuing);
  points[index].at = point;
  changed();
}

void SegmentationSession::removeConstraintPoint(Index structure, int index) {
  auto& points = simulation().scene().constraintPoints()[structure];
  if (index < 0 || index >= static_cast<int>(points.size())) throw InputError("no such include / exclude point");
  beginEdit(points[index].include ? "Delete include point" : "Delete exclude point", false);
  points.erase(points.begin() + index);
  lastEdit_.clear();
  changed();
}

void SegmentationSession::addLandmark(const Vec3& from, const Vec3& to) {
  if (!from.allFinite() || !to.allFinite()) throw InputError("a landmark needs finite coordinates");
  beginEdit("Add landmark", false);
  landmarks_.push_back({from, to});
  lastEdit_.clear();
  changed();
}

void SegmentationSession::moveLandmark(int index, const Vec3& to, bool continuing) {
  if (!to.allFinite()) throw InputError("a landmark needs finite coordinates");
  if (index < 0 || index >= static_cast<int>(landmarks_.size())) throw InputError("no such landmark");
  beginEdit("Move landmark " + std::to_string(index), continuing);
  landmarks_[index].to = to;
  changed();
}

void SegmentationSession::removeLandmark(int index) {
  if (index < 0 || index >= static_cast<int>(landmarks_.size())) throw InputError("no such landmark");
  beginEdit("Delete landmark", false);
  landmarks_.erase(landmarks_.begin() + index);
  lastEdit_.clear();
  changed();
}

void SegmentationSession::initialiseFromLandmarks(const SessionOpenOptions& options) {
  // The model points: where the model has them now, taken back through the current initialisation
  // (the map the profiles are trained through), so the new map replaces the old one.
  const SceneData& data = simulation().scene();
  std::vector<LandmarkPair> pairs;
  for (const auto& l : landmarks_) {
    const Vec3 model = data.toTraining(l.from);
    pairs.push_back({{model.x(), model.y(), model.z()}, {l.to.x(), l.to.y(), l.to.z()}});
  }
  checkLandmarks(pairs, "landmarks");
  SceneDesc scene = currentScene();
  scene.initialise = InitialiseDesc{};
  scene.initialise.method = InitialiseDesc::Method::Landmarks;
  scene.initialise.landmarks = std::move(pairs);
  open(std::move(scene), options);
}

ParamTable& SegmentationSession::params(const std::string& owner) {
  Simulation& sim = simulation();
  return owner == sim.integratorName() ? sim.integratorParams() : sim.forceParams(owner);
}

void SegmentationSession::setParameter(const std::string& force, Index structure, const std::string& param,
                                       double value, bool continuing) {
  ParamTable& table = params(force);
  const int p = table.indexOf(param);
  const ParamDecl& decl = table.decls()[p];
  if (!(value >= decl.min && value <= decl.max))
    throw InputError(force + "." + param + " = " + std::to_string(value) + " is outside [" + std::to_string(decl.min) +
                     ", " + std::to_string(decl.max) + "]");
  beginEdit("Set " + force + "." + param + (structure >= 0 ? " of " + scene().structures[structure].name : ""),
            continuing);
  if (structure < 0 || !decl.perStructure) table.setAll(param, value);
  else table.set(structure, p, value);
  changed();
}

double SegmentationSession::parameter(const std::string& force, Index structure, const std::string& param) {
  ParamTable& table = params(force);
  return table.get(std::max<Index>(structure, 0), table.indexOf(param));
}

// --- outputs -------------------------------------------------------------------------------------

SceneDesc SegmentationSession::currentScene() {
  SceneDesc s = scene();
  Simulation& sim = simulation();
  // Shared values go to /forces; a structure's own value only where it differs from structure 0's.
  for (auto& [force, values] : s.forces) {
    const ParamTable& t = sim.forceParams(force);
    values.clear();
    for (size_t p = 0; p < t.decls().size(); ++p) values.emplace_back(t.decls()[p].name, t.get(0, int(p)));
  }
  for (size_t i = 0; i < s.structures.size(); ++i) {
    StructureDesc& d = s.structures[i];
    d.forces.clear();
    for (const auto& [force, shared] : s.forces) {
      const ParamTable& t = sim.forceParams(force);
      std::vector<std::pair<std::string, double>> own;
      for (size_t p = 0; p < t.decls().size(); ++p)
        if (t.decls()[p].perStructure && t.get(Index(i), int(p)) != t.get(0, int(p)))
          own.emplace_back(t.decls()[p].name, t.get(Index(i), int(p)));
      if (!own.empty()) d.forces.emplace_back(force, std::move(own));
    }
    d.attractionPointsMm.clear();
    for (const Vec3& p : sim.scene().attractionPoints()[i]) d.attractionPointsMm.push_back({p.x(), p.y(), p.z()});
    d.includePointsMm.clear();
    d.excludePointsMm.clear();
    for (const ConstraintPoint& c : sim.scene().constraintPoints()[i])
      (c.include ? d.includePointsMm : d.excludePointsMm).push_back({c.at.x(), c.at.y(), c.at.z()});
  }
  s.integratorParams.clear();
  const ParamTable& integ = sim.integratorParams();
  for (size_t p = 0; p < integ.decls().size(); ++p) s.integratorParams.emplace_back(integ.decls()[p].name, integ.get(0, int(p)));
  // The schedule is kept as it was: a rerun enters its levels with their values again, which win
  // over the values above for the parameters the schedule names (docs/workstation.md).
  return s;
}

void SegmentationSession::saveScene(const fs::path& file) { writeScene(currentScene(), file); }

const std::vector<StructureImageFit>& SegmentationSession::scoreImageFit() {
  syncHost();
  fits_ = imageFitOf(simulation());
  fitRevision_ = revision_;
  return fits_;
}

std::vector<StructureResult> SegmentationSession::finalSurfaces() {
  syncHost();
  MeshStore& store = simulation().store();
  std::vector<StructureResult> out;
  for (Index i = 0; i < structureCount(); ++i) {
    StructureResult r;
    r.name = scene().structures[i].name;
    r.label = scene().structures[i].label;
    const auto x = store.mesh(store.positions(), i);
    r.surface = tessellate(store.topologyOf(i), std::vector<Vec3>(x.begin(), x.end()));
    for (const Vec3& p : r.surface.points)
      if (!p.allFinite()) throw NumericalError("structure '" + r.name + "' has a non-finite vertex; nothing was written");
    out.push_back(std::move(r));
  }
  return out;
}

std::vector<fs::path> SegmentationSession::saveMeshes(const fs::path& dir, const std::string& ext) {
  std::vector<fs::path> written;
  for (const auto& r : finalSurfaces()) {
    const fs::path file = dir / (r.name + ext);
    registry_.meshIOFor(file).write(file, r.surface);
    written.push_back(file);
  }
  return written;
}

void SegmentationSession::exportLabelMap(const fs::path& file) {
  RunReport report;
  report.structures = finalSurfaces();
  registry_.imageIOFor(file).writeLabels(file, runner_->labelMap(report));
}

}  // namespace sinew
