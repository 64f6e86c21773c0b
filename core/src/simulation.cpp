#include "sinew/core/simulation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>

namespace sinew {

struct Simulation::ForceSlot {
  std::string name;
  std::unique_ptr<Force> force;
  ParamTable params;
  long evaluations = 0;
};

Simulation::Simulation(const Registry& registry, int threads) : registry_(registry), executor_(threads) {}
Simulation::~Simulation() = default;

Index Simulation::addStructure(StructureSpec spec) {
  if (initialized_) throw std::logic_error("addStructure after initialize");
  if (!forces_.empty() || integrator_) throw std::logic_error("add structures before forces");
  if (spec.levels.levelCount() == 0) throw InputError("structure '" + spec.name + "' has no mesh");
  const Index n = spec.levels.levels[0].vertexCount();
  if (static_cast<Index>(spec.initialPositions.size()) != n)
    throw InputError("structure '" + spec.name + "': initial positions do not match its mesh");
  if (!spec.referencePositions.empty() && static_cast<Index>(spec.referencePositions.size()) != n)
    throw InputError("structure '" + spec.name + "': reference shape does not match its mesh topology");
  structures_.push_back(std::move(spec));
  scene_.attractionPoints().resize(structures_.size());
  scene_.constraintPoints().resize(structures_.size());
  scene_.addStructureName(structures_.back().name);
  return static_cast<Index>(structures_.size()) - 1;
}

ParamTable& Simulation::addForce(std::string_view name) {
  const ForceDescriptor& d = registry_.force(name);
  for (const auto& s : forces_)
    if (s.get()->name == name) throw InputError("force '" + std::string(name) + "' added twice");
  auto s = std::make_unique<ForceSlot>();
  s->name = d.name;
  s->force = d.create();
  s->params = ParamTable(d.params, structureCount());
  forces_.push_back(std::move(s));
  return forces_.back()->params;
}

ParamTable& Simulation::setIntegrator(std::string_view name) {
  const IntegratorDescriptor& d = registry_.integrator(name);
  integrator_ = d.create();
  integratorName_ = d.name;
  integratorParams_ = ParamTable(d.params, 1);
  unhalvedTimeStep_ = guardTimeStep_ = restoredTimeStep_ = 0.0;
  return integratorParams_;
}

Simulation::ForceSlot& Simulation::slot(std::string_view name) {
  for (auto& s : forces_)
    if (s->name == name) return *s;
  throw InputError("force '" + std::string(name) + "' is not part of the scene");
}

const Simulation::ForceSlot& Simulation::slot(std::string_view name) const {
  return const_cast<Simulation*>(this)->slot(name);
}

ParamTable& Simulation::forceParams(std::string_view name) { return slot(name).params; }
Force& Simulation::force(std::string_view name) { return *slot(name).force; }

std::vector<std::string> Simulation::forceNames() const {
  std::vector<std::string> names;
  for (const auto& s : forces_) names.push_back(s->name);
  return names;
}
long Simulation::evaluations(std::string_view name) const { return slot(name).evaluations; }

int Simulation::levelCount() const {
  int n = 1 << 30;
  for (const auto& s : structures_) n = std::min(n, s.levels.levelCount());
  return structures_.empty() ? 0 : n;
}

void Simulation::initialize() {
  if (!integrator_) throw InputError("the scene names no integrator");
  unhalvedTimeStep_ = guardTimeStep_ = restoredTimeStep_ = 0.0;
  if (structures_.empty()) throw InputError("the scene has no structure");
  std::vector<const SimplexTopology*> topologies;
  for (const auto& s : structures_) topologies.push_back(&s.levels.levels[0]);
  store_ = MeshStore(topologies);
  store_.setExecutor(&executor_);

  store_.require(Attribute::Force);
  if (!attachments_.empty()) {
    attachments_.validate(store_);
    store_.require(Attribute::Mass);  // merged pairs share their force by mass
  }
  for (Attribute a : integrator_->requirements().attributes) store_.require(a);
  for (size_t f = 0; f < forces_.size(); ++f) {
    const Requirements req = forces_[f]->force->requirements();
    for (Attribute a : req.attributes) store_.require(a);
    if (!req.referenceShape) continue;
    store_.require(Attribute::ReferencePosition);
    for (Index m = 0; m < structureCount(); ++m)
      if (structures_[m].referencePositions.empty() && forces_[f]->params.get(m, 0) > 0.0)
        throw InputError("structure '" + structures_[m].name + "' has no reference shape, which force '" +
                         forces_[f]->name + "' needs");
  }

  auto x = store_.positionsForWrite();
  const bool withReference = store_.has(Attribute::ReferencePosition);
  std::span<Vec3> ref = withReference ? store_.referencePositionsForWrite() : std::span<Vec3>{};
  for (Index m = 0; m < structureCount(); ++m) {
    const MeshRange& r = store_.range(m);
    std::copy(structures_[m].initialPositions.begin(), structures_[m].initialPositions.end(),
              x.begin() + r.vertexBegin);
    if (!withReference) continue;
    // A structure without a reference (force inactive there) keeps its initial shape as one.
    const auto& src = structures_[m].referencePositions.empty() ? structures_[m].initialPositions
                                                                : structures_[m].referencePositions;
    std::copy(src.begin(), src.end(), ref.begin() + r.vertexBegin);
  }
  level_ = 0;
  iteration_ = 0;
  applyDensities();
  IntegratorContext ictx{store_, integratorParams_, executor_};
  integrator_->start(ictx);
  prepareForces();
  if (!attachments_.empty()) attachments_.build(store_, executor_);
  initialized_ = true;
}

void Simulation::applyDensities() {
  if (!store_.has(Attribute::Area)) return;
  // Density 0 means "auto": the mean vertex mass of the structure is 1 at every level, so one time
  // step suits every level (a level has 4x the vertices, each with about 1/4 of the area).
  // The mass floor keeps the vertices beside the smallest cells from being so light that the shape
  // and smoothing pulls, which do not scale with area, take them past the explicit step's limit:
  // without it a few dozen of them trembled by 1-1.6 mm every step on the demo (docs/stability.md).
  for (Index m = 0; m < structureCount(); ++m) {
    const auto areas = store_.areas();
    const MeshRange& r = store_.range(m);
    const double total = std::accumulate(areas.begin() + r.vertexBegin, areas.begin() + r.vertexEnd, 0.0);
    const float density = structures_[m].density > 0.0f ? structures_[m].density
                          : total > 0.0                  ? static_cast<float>(r.vertexCount() / total)
                                                         : 1.0f;
    store_.setDensity(m, density);
    const double meanMass = r.vertexCount() > 0 ? density * total / r.vertexCount() : 0.0;
    store_.setMassFloor(m, static_cast<float>(structures_[m].massFloor * meanMass));
  }
}

void Simulation::prepareForces() {
  for (auto& s : forces_) {
    ForceContext ctx{store_, s->params, scene_, executor_};
    s->force->prepare(ctx);
  }
}

void Simulation::computeForces() {
  store_.refresh();
  auto f = store_.forces();
  executor_.forEach(store_.vertexCount(), [&](Index v) { f[v] = Vec3::Zero(); }, 4096);
  const bool regularise = affineShare_ > 0.0f;
  if (regularise) {
    imageForces_.resize(store_.vertexCount());
    executor_.forEach(store_.vertexCount(), [&](Index v) { imageForces_[v] = Vec3::Zero(); }, 4096);
  }
  for (auto& s : forces_) {
    if (!s->params.anyPositive(0)) continue;
    ForceContext ctx{store_, s->params, scene_, executor_};
    const bool image = regularise && s->force->requirements().imageForce;
    s->force->accumulate(ctx, image ? std::span<Vec3>(imageForces_) : f);
    ++s->evaluations;
  }
  if (regularise) regulariseImageForces(f);
  if (coarseWeight_ > 0.0f && level_ > 0) addCoarseForces(f);
  if (!integrator_->requirements().jacobian) return;
  jacobian_.reset(store_.vertexCount());
  for (auto& s : forces_) {
    if (!s->params.anyPositive(0)) continue;
    ForceContext ctx{store_, s->params, scene_, executor_};
    s->force->addJacobian(ctx, jacobian_);
  }
}

void Simulation::setAffineRegularisation(float share) {
  if (!(share >= 0.0f && share <= 1.0f)) throw InputError("affine regularisation must be in [0, 1]");
  affineShare_ = share;
  if (share == 0.0f) std::vector<Vec3>().swap(imageForces_);
}

void Simulation::setCoarseForceWeight(float weight) {
  if (!(weight >= 0.0f && weight <= 1.0f)) throw InputError("the coarse-force weight must be in [0, 1]");
  coarseWeight_ = weight;
  if (weight == 0.0f) coarse_.clear();
}

std::vector<Vec3> Simulation::referenceAt(Index m, int level) const {
  const StructureSpec& s = structures_[m];
  const std::vector<Vec3>& base = s.referencePositions.empty() ? s.initialPositions : s.referencePositions;
  // The finest level at or below `level` that has its own reference, carried up from there.
  for (int l = level; l > 0; --l)
    if (static_cast<int>(s.finerReferences.size()) >= l && !s.finerReferences[l - 1].empty())
      return s.levels.carry(s.finerReferences[l - 1], l, level);
  return s.levels.carry(base, 0, level);
}

MeshStore& Simulation::coarseStore(int level) {
  if (level < 0 || level >= level_) throw std::logic_error("coarseStore: not a coarser level");
  if (static_cast<int>(coarse_.size()) != level_) {
    // Built on the first request of a level: one store per coarser level, with only what the shape
    // forces need.
    coarse_.clear();
    for (int l = 0; l < level_; ++l) {
      std::vector<const SimplexTopology*> topologies;
      for (const auto& s : structures_) topologies.push_back(&s.levels.levels[l]);
      auto store = std::make_unique<MeshStore>(topologies);
      store->setExecutor(&executor_);
      store->require(Attribute::Force);
      for (const auto& slot : forces_)
        if (slot->force->requirements().shapeForce)
          for (Attribute a : slot->force->requirements().attributes) store->require(a);
      store->require(Attribute::ReferencePosition);
      auto ref = store->referencePositionsForWrite();
      for (Index m = 0; m < structureCount(); ++m) {
        const auto r = referenceAt(m, l);
        std::copy(r.begin(), r.end(), ref.begin() + store->range(m).vertexBegin);
      }
      coarse_.push_back(std::move(store));
    }
  }
  return *coarse_[level];
}

void Simulation::addCoarseForces(std::span<Vec3> forces) {
  const auto x = store_.positions();
  for (int l = 0; l < level_; ++l) {
    MeshStore& cs = coarseStore(l);
    const Index stride = Index(1) << (2 * (level_ - l));  // coarse vertex t is fine vertex 4^(L-l) t
    auto cx = cs.positionsForWrite();
    for (Index m = 0; m < structureCount(); ++m) {
      const MeshRange &rc = cs.range(m), &rf = store_.range(m);
      for (Index t = 0; t < rc.vertexCount(); ++t) cx[rc.vertexBegin + t] = x[rf.vertexBegin + t * stride];
    }
    cs.refresh();
    auto cf = cs.forces();
    std::fill(cf.begin(), cf.end(), Vec3::Zero());
    for (auto& slot : forces_) {
      if (!slot->params.anyPositive(0) || !slot->force->requirements().shapeForce) continue;
      ForceContext ctx{cs, slot->params, scene_, executor_};
      slot->force->accumulate(ctx, cf);
    }
    executor_.forEach(structureCount(), [&](Index m) {
      const MeshRange &rc = cs.range(m), &rf = store_.range(m);
      const auto fine = structures_[m].levels.carry(std::span<const Vec3>(cf).subspan(rc.vertexBegin, rc.vertexCount()), l, level_);
      for (Index i = 0; i < rf.vertexCount(); ++i) forces[rf.vertexBegin + i] += coarseWeight_ * fine[i];
    });
  }
}

void Simulation::regulariseImageForces(std::span<Vec3> forces) {
  const auto x = store_.positions();
  const float share = affineShare_;
  // One structure per task, its sums in a fixed order: deterministic for any thread count. The
  // normal equations in homogeneous coordinates, in double (as the CUDA backend does).
  executor_.forEach(structureCount(), [&](Index m) {
    const MeshRange& r = store_.range(m);
    Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
    Eigen::Matrix<double, 4, 3> rhs = Eigen::Matrix<double, 4, 3>::Zero();
    for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) {
      const Eigen::Vector4d h = x[v].cast<double>().homogeneous();
      normal.noalias() += h * h.transpose();
      rhs.noalias() += h * imageForces_[v].cast<double>().transpose();
    }
    const Eigen::Matrix<double, 4, 3> fit = normal.partialPivLu().solve(rhs);
    const bool usable = fit.allFinite();
    for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) {
      const Vec3 affine = usable ? Vec3((fit.transpose() * x[v].cast<double>().homogeneous()).cast<float>()) : imageForces_[v];
      forces[v] += share * affine + (1.0f - share) * imageForces_[v];
    }
  });
}

std::string Simulation::checkStep(std::span<const Vec3> before, int steps) {
  const auto x = store_.positions();
  // The worst vertex: non-finite first, then the longest move (ties to the lower index).
  struct Worst {
    float score = -1.0f;  // +inf for a non-finite position
    Index v = -1;
    static Worst pick(Worst a, Worst b) { return (b.score > a.score || (b.score == a.score && b.v < a.v)) ? b : a; }
  };
  const Worst w = executor_.reduce(
      Index{0}, store_.vertexCount(), Worst{},
      [&](Index b, Index e, Worst acc) {
        for (Index v = b; v < e; ++v) {
          const float d = x[v].allFinite() ? (x[v] - before[v]).norm() : std::numeric_limits<float>::infinity();
          acc = Worst::pick(acc, {d, v});
        }
        return acc;
      },
      Worst::pick);
  if (w.v < 0 || w.score <= guard_.maxStepMm) return {};
  const Index m = store_.meshOfVertex()[w.v];
  const std::string where = "structure '" + structures_[m].name + "', vertex " + std::to_string(w.v - store_.range(m).vertexBegin);
  if (!x[w.v].allFinite()) return "non-finite position (" + where + ")";
  char moved[96];
  if (steps > 1)
    std::snprintf(moved, sizeof moved, "moved %.3g mm in %d steps (limit %.3g, one step's, for the chunk)", double(w.score),
                  steps, guard_.maxStepMm);
  else std::snprintf(moved, sizeof moved, "moved %.3g mm in one step (limit %.3g)", double(w.score), guard_.maxStepMm);
  return std::string(moved) + " (" + where + ")";
}

void Simulation::step() {
  if (!initialized_) throw std::logic_error("Simulation::step before initialize");
  IntegratorContext ictx{store_, integratorParams_, executor_, &jacobian_};
  // Forces, the attachments' share of them, the integrator, then the attachments' positions.
  const auto advance = [&] {
    computeForces();
    if (!attachments_.empty()) attachments_.shareForces(store_);
    integrator_->step(ictx);
    for (auto& slot : forces_)
      if (slot->params.anyPositive(0)) {
        ForceContext ctx{store_, slot->params, scene_, executor_};
        slot->force->constrain(ctx);
      }
    if (!attachments_.empty()) attachments_.project(store_);
  };
  if (!guard_.enabled) {
    advance();
    ++iteration_;
    return;
  }
  const auto x = store_.positions();
  goodPositions_.assign(x.begin(), x.end());
  goodPrevious_.clear();
  if (store_.has(Attribute::PreviousPosition)) {
    const auto prev = store_.previousPositions();
    goodPrevious_.assign(prev.begin(), prev.end());
  }
  for (int attempt = 0;; ++attempt) {
    advance();
    const std::string problem = checkStep(goodPositions_);
    if (problem.empty()) break;
    recover(goodPositions_, goodPrevious_, problem, attempt);
  }
  ++iteration_;
}

void Simulation::restoreState(std::span<const Vec3> positions, std::span<const Vec3> previous) {
  auto x = store_.positionsForWrite();
  std::copy(positions.begin(), positions.end(), x.begin());
  if (!previous.empty()) std::copy(previous.begin(), previous.end(), store_.previousPositions().begin());
  for (auto& s : forces_) {
    ForceContext ctx{store_, s->params, scene_, executor_};
    s->force->restored(ctx);
  }
}

void Simulation::recover(std::span<const Vec3> goodPositions, std::vector<Vec3>& goodPrevious,
                         const std::string& problem, int attempt) {
  restoreState(goodPositions, goodPrevious);
  int kStep = -1;
  for (int i = 0; i < static_cast<int>(integratorParams_.decls().size()); ++i)
    if (integratorParams_.decls()[i].name == "time_step") kStep = i;
  StabilityEvent e{iteration_, level_, problem, kStep >= 0 ? integratorParams_.get(0, kStep) : 0.0, false};
  const double halved = e.timeStep / 2.0;
  if (kStep < 0 || attempt >= guard_.maxRetries || halved < integratorParams_.decls()[kStep].min) {
    events_.push_back(e);
    std::string why;
    if (kStep < 0) why = "the integrator has no time_step to reduce";
    else if (attempt >= guard_.maxRetries) why = "still unstable after " + std::to_string(attempt) + " halvings of the time step";
    else {
      char text[128];
      std::snprintf(text, sizeof text, "the time step (%g) cannot be halved below the integrator's minimum (%g)", e.timeStep,
                    integratorParams_.decls()[kStep].min);
      why = text;
    }
    throw NumericalError(problem + " at iteration " + std::to_string(iteration_) + "; " + why +
                         "; the state is the last good one");
  }
  if (unhalvedTimeStep_ == 0.0 || e.timeStep != guardTimeStep_) unhalvedTimeStep_ = e.timeStep;
  guardTimeStep_ = halved;
  integratorParams_.set(0, kStep, halved);
  IntegratorContext ictx{store_, integratorParams_, executor_, &jacobian_};
  integrator_->timeStepScaled(ictx, 0.5f);
  // The good state now carries the halved step's previous positions: a further retry halves from
  // here, so the velocity stays that of the good state however many retries follow.
  if (!goodPrevious.empty()) {
    const auto prev = store_.previousPositions();
    goodPrevious.assign(prev.begin(), prev.end());
  }
  e.timeStep = halved;
  e.recovered = true;
  events_.push_back(e);
}

void Simulation::run(int iterations) {
  for (int i = 0; i < iterations; ++i) step();
}

bool Simulation::advanceLevel() {
  if (level_ + 1 >= levelCount()) return false;
  std::vector<const SimplexTopology*> topologies;
  std::vector<const Prolongation*> prolongations;
  for (const auto& s : structures_) {
    topologies.push_back(&s.levels.levels[level_ + 1]);
    prolongations.push_back(&s.levels.prolongations[level_]);
  }
  store_ = store_.refined(topologies, prolongations);
  ++level_;
  if (store_.has(Attribute::ReferencePosition)) {
    std::span<Vec3> ref;
    for (Index m = 0; m < structureCount(); ++m) {
      const auto& finer = structures_[m].finerReferences;
      if (static_cast<int>(finer.size()) < level_ || finer[level_ - 1].empty()) continue;
      if (ref.empty()) ref = store_.referencePositionsForWrite();
      std::copy(finer[level_ - 1].begin(), finer[level_ - 1].end(), ref.begin() + store_.range(m).vertexBegin);
    }
  }
  applyDensities();
  prepareForces();
  if (!attachments_.empty()) attachments_.build(store_, executor_);
  // A rollback's halved step held for the rest of its level; each new level, a new mesh, doubles it
  // back once, up to the step before the first halving, so that a single spike (a light vertex's
  // jump) does not slow every later level (demo seed 9 on the device lost 0.07 mm of mean ASSD that
  // way, docs/stability.md) and a step too long for the scene costs at most one rollback a level.
  // The step-to-step motion is carried over as it is (both backends prolong the previous positions
  // themselves), so the velocity drops by the factor. A step set by hand since is left alone.
  restoredTimeStep_ = 0.0;
  if (unhalvedTimeStep_ > 0.0) {
    const int k = integratorParams_.indexOf("time_step");
    const double now = integratorParams_.get(0, k);
    if (now == guardTimeStep_ && now < unhalvedTimeStep_) {
      restoredTimeStep_ = std::min(unhalvedTimeStep_, 2.0 * now);
      integratorParams_.set(0, k, restoredTimeStep_);
      guardTimeStep_ = restoredTimeStep_;
    } else {
      unhalvedTimeStep_ = 0.0;
    }
  }
  return true;
}

}  // namespace sinew
