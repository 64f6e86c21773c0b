#include "sinew/core/mesh_store.h"

#include <algorithm>
#include <stdexcept>

namespace sinew {

namespace {
constexpr int idx(Attribute a) { return static_cast<int>(a); }

float triangleArea(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5f * (b - a).cross(c - a).norm();
}
}  // namespace

const char* attributeName(Attribute a) {
  static const char* names[] = {"position",  "previous_position", "force",
                                "reference_position", "normal", "elevation",
                                "simplex_params", "cell_centre", "area",
                                "mass", "reference_normal", "reference_params"};
  return names[idx(a)];
}

MeshStore::MeshStore(std::span<const SimplexTopology* const> topologies) {
  size_t vertices = 0, cells = 0, corners = 0;
  for (const SimplexTopology* t : topologies)
    vertices += t->vertexCount(), cells += t->cellCount(), corners += t->cellVertices.size();
  meshOfVertex_.reserve(vertices);
  neighbours_.reserve(vertices);
  vertexCells_.reserve(vertices);
  cellOffsets_.reserve(cells + 1);
  cellVertices_.reserve(corners);
  Index vBase = 0, cBase = 0;
  for (const SimplexTopology* t : topologies) {
    MeshRange r{vBase, vBase + t->vertexCount(), cBase, cBase + t->cellCount()};
    const Index mesh = static_cast<Index>(ranges_.size());
    ranges_.push_back(r);
    density_.push_back(1.0f);
    massFloor_.push_back(0.0f);
    for (Index v = 0; v < t->vertexCount(); ++v) {
      meshOfVertex_.push_back(mesh);
      auto n = t->neighbours[v];
      auto c = t->vertexCells[v];
      for (int k = 0; k < 3; ++k) {
        n[k] += vBase;
        c[k] += cBase;
      }
      neighbours_.push_back(n);
      vertexCells_.push_back(c);
    }
    for (Index c = 0; c < t->cellCount(); ++c) {
      for (Index i = t->cellOffsets[c]; i < t->cellOffsets[c + 1]; ++i)
        cellVertices_.push_back(t->cellVertices[i] + vBase);
      cellOffsets_.push_back(static_cast<Index>(cellVertices_.size()));
    }
    vBase = r.vertexEnd;
    cBase = r.cellEnd;
  }
  require(Attribute::Position);
}

SimplexTopology MeshStore::topologyOf(Index mesh) const {
  const MeshRange& r = ranges_[mesh];
  SimplexTopology t;
  for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) {
    auto n = neighbours_[v];
    auto c = vertexCells_[v];
    for (int k = 0; k < 3; ++k) {
      n[k] -= r.vertexBegin;
      c[k] -= r.cellBegin;
    }
    t.neighbours.push_back(n);
    t.vertexCells.push_back(c);
  }
  t.cellOffsets.push_back(0);
  for (Index c = r.cellBegin; c < r.cellEnd; ++c) {
    for (Index i = cellOffsets_[c]; i < cellOffsets_[c + 1]; ++i)
      t.cellVertices.push_back(cellVertices_[i] - r.vertexBegin);
    t.cellOffsets.push_back(static_cast<Index>(t.cellVertices.size()));
  }
  return t;
}

void MeshStore::requireVec3(Attribute a, Index count) {
  if (vec3_[idx(a)].size() != static_cast<size_t>(count)) vec3_[idx(a)].assign(count, Vec3::Zero());
}

void MeshStore::require(Attribute a) {
  if (has(a)) return;
  const Index n = vertexCount();
  switch (a) {
    case Attribute::Position:
    case Attribute::PreviousPosition:
    case Attribute::Force:
    case Attribute::ReferencePosition:
    case Attribute::Normal:
    case Attribute::ReferenceNormal:
      if (a == Attribute::ReferenceNormal) require(Attribute::ReferencePosition);
      requireVec3(a, n);
      break;
    case Attribute::CellCentre:
      requireVec3(a, cellCount());
      break;
    case Attribute::Elevation:
      elevations_.assign(n, 0.0f);
      break;
    case Attribute::SimplexParams:
      params_.assign(n, SimplexParams{});
      break;
    case Attribute::Area:
      require(Attribute::CellCentre);
      areas_.assign(n, 0.0f);
      break;
    case Attribute::Mass:
      require(Attribute::Area);
      masses_.assign(n, 0.0f);
      break;
    case Attribute::ReferenceParams:
      require(Attribute::ReferencePosition);
      referenceParams_.assign(n, SimplexParams{});
      break;
    case Attribute::Count:
      throw std::logic_error("MeshStore::require: invalid attribute");
  }
  allocated_[idx(a)] = true;
  // A newly allocated derived attribute must be computed before it is read.
  currentComputedAt_ = 0;
  referenceComputedAt_ = 0;
}

std::span<const Vec3> MeshStore::vec3(Attribute a) const {
  if (!has(a)) throw std::logic_error(std::string("attribute not required: ") + attributeName(a));
  return vec3_[idx(a)];
}

std::span<Vec3> MeshStore::vec3(Attribute a) {
  if (!has(a)) throw std::logic_error(std::string("attribute not required: ") + attributeName(a));
  return vec3_[idx(a)];
}

std::span<Vec3> MeshStore::positionsForWrite() {
  ++positionsVersion_;
  return vec3(Attribute::Position);
}

std::span<Vec3> MeshStore::referencePositionsForWrite() {
  ++referenceVersion_;
  return vec3(Attribute::ReferencePosition);
}

void MeshStore::setDensity(Index mesh, float density) {
  density_[mesh] = density;
  ++positionsVersion_;  // masses depend on it
}

void MeshStore::setMassFloor(Index mesh, float mass) {
  massFloor_[mesh] = mass;
  ++positionsVersion_;
}

const Executor& MeshStore::executor() const { return executor_ ? *executor_ : serialExecutor(); }

void MeshStore::refresh() {
  if (currentStale()) refreshCurrent();
  if (referenceStale()) refreshReference();
}

void MeshStore::refreshCurrent() {
  const std::vector<Vec3>& x = vec3_[idx(Attribute::Position)];
  const Executor& ex = executor();
  if (has(Attribute::CellCentre)) {
    std::vector<Vec3>& centres = vec3_[idx(Attribute::CellCentre)];
    ex.forEach(cellCount(), [&](Index c) {
      Vec3 sum = Vec3::Zero();
      for (Index i = cellOffsets_[c]; i < cellOffsets_[c + 1]; ++i) sum += x[cellVertices_[i]];
      centres[c] = sum / static_cast<float>(cellOffsets_[c + 1] - cellOffsets_[c]);
    });
  }
  Vec3* normal = has(Attribute::Normal) ? vec3_[idx(Attribute::Normal)].data() : nullptr;
  float* elev = has(Attribute::Elevation) ? elevations_.data() : nullptr;
  SimplexParams* par = has(Attribute::SimplexParams) ? params_.data() : nullptr;
  float* area = has(Attribute::Area) ? areas_.data() : nullptr;
  float* mass = has(Attribute::Mass) ? masses_.data() : nullptr;
  const Vec3* centre = has(Attribute::CellCentre) ? vec3_[idx(Attribute::CellCentre)].data() : nullptr;
  if (normal || elev || par || area) {
    ex.forEach(vertexCount(), [&](Index v) {
      const auto& n = neighbours_[v];
      const Vec3 &p = x[v], &p1 = x[n[0]], &p2 = x[n[1]], &p3 = x[n[2]];
      if (normal || elev || par) {
        const NeighbourFrame f = neighbourFrame(p1, p2, p3);
        if (normal) normal[v] = f.normal;
        if (elev) elev[v] = elevation(p, p1, f);
        if (par) par[v] = sinew::simplexParams(p, p1, p2, p3, f);
      }
      if (area) {
        const auto& c = vertexCells_[v];
        float a = 0.0f;
        for (int j = 0; j < 3; ++j)
          a += triangleArea(p, x[n[j]], centre[c[j]]) + triangleArea(p, x[n[j]], centre[c[(j + 1) % 3]]);
        area[v] = a;
        if (mass) mass[v] = std::max(a * density_[meshOfVertex_[v]], massFloor_[meshOfVertex_[v]]);
      }
    });
  }
  currentComputedAt_ = positionsVersion_;
}

void MeshStore::refreshReference() {
  if (has(Attribute::ReferenceNormal) || has(Attribute::ReferenceParams)) {
    const std::vector<Vec3>& x = vec3_[idx(Attribute::ReferencePosition)];
    Vec3* normal = has(Attribute::ReferenceNormal) ? vec3_[idx(Attribute::ReferenceNormal)].data() : nullptr;
    SimplexParams* par = has(Attribute::ReferenceParams) ? referenceParams_.data() : nullptr;
    executor().forEach(vertexCount(), [&](Index v) {
      const auto& n = neighbours_[v];
      const NeighbourFrame f = neighbourFrame(x[n[0]], x[n[1]], x[n[2]]);
      if (normal) normal[v] = f.normal;
      if (par) par[v] = followableReference(sinew::simplexParams(x[v], x[n[0]], x[n[1]], x[n[2]], f));
    });
  }
  referenceComputedAt_ = referenceVersion_;
}

void MeshStore::ensureFresh(Attribute a) {
  if (!has(a)) throw std::logic_error(std::string("attribute not required: ") + attributeName(a));
  if (a == Attribute::ReferenceNormal || a == Attribute::ReferenceParams) {
    if (referenceStale()) refreshReference();
  } else if (currentStale()) {
    refreshCurrent();
  }
}

std::span<const Vec3> MeshStore::normals() {
  ensureFresh(Attribute::Normal);
  return vec3_[idx(Attribute::Normal)];
}
std::span<const float> MeshStore::elevations() {
  ensureFresh(Attribute::Elevation);
  return elevations_;
}
std::span<const SimplexParams> MeshStore::simplexParams() {
  ensureFresh(Attribute::SimplexParams);
  return params_;
}
std::span<const Vec3> MeshStore::cellCentres() {
  ensureFresh(Attribute::CellCentre);
  return vec3_[idx(Attribute::CellCentre)];
}
std::span<const float> MeshStore::areas() {
  ensureFresh(Attribute::Area);
  return areas_;
}
std::span<const float> MeshStore::masses() {
  ensureFresh(Attribute::Mass);
  return masses_;
}
std::span<const Vec3> MeshStore::referenceNormals() {
  ensureFresh(Attribute::ReferenceNormal);
  return vec3_[idx(Attribute::ReferenceNormal)];
}
std::span<const SimplexParams> MeshStore::referenceParams() {
  ensureFresh(Attribute::ReferenceParams);
  return referenceParams_;
}

std::span<float> MeshStore::requireChannel(const std::string& name, Index width, MemoryCategory category) {
  Channel& c = channels_[name];
  if (c.width != width || c.values.size() != static_cast<size_t>(width) * vertexCount()) {
    c.width = width;
    c.values.assign(static_cast<size_t>(width) * vertexCount(), 0.0f);
  }
  c.category = category;
  return c.values;
}

std::span<float> MeshStore::channel(const std::string& name) {
  auto it = channels_.find(name);
  if (it == channels_.end()) throw std::logic_error("channel not required: " + name);
  return it->second.values;
}

Index MeshStore::channelWidth(const std::string& name) const {
  auto it = channels_.find(name);
  return it == channels_.end() ? 0 : it->second.width;
}

std::size_t MeshStore::bytes(MemoryCategory c) const {
  std::size_t total = 0;
  auto vecBytes = [](const auto& v) { return v.size() * sizeof(v[0]); };
  switch (c) {
    case MemoryCategory::Topology:
      total = vecBytes(ranges_) + vecBytes(meshOfVertex_) + vecBytes(neighbours_) +
              vecBytes(vertexCells_) + vecBytes(cellOffsets_) + vecBytes(cellVertices_) + vecBytes(density_) + vecBytes(massFloor_);
      break;
    case MemoryCategory::State:
      for (Attribute a : {Attribute::Position, Attribute::PreviousPosition, Attribute::Force,
                          Attribute::ReferencePosition})
        total += vecBytes(vec3_[idx(a)]);
      break;
    case MemoryCategory::Geometry:
      for (Attribute a : {Attribute::Normal, Attribute::CellCentre, Attribute::ReferenceNormal})
        total += vecBytes(vec3_[idx(a)]);
      total += vecBytes(elevations_) + vecBytes(areas_) + vecBytes(masses_) + vecBytes(params_) +
               vecBytes(referenceParams_);
      break;
    default:
      break;
  }
  for (const auto& [name, ch] : channels_)
    if (ch.category == c) total += vecBytes(ch.values);
  return total;
}

MeshStore MeshStore::refined(std::span<const SimplexTopology* const> fineTopologies,
                             std::span<const Prolongation* const> prolongations) const {
  MeshStore fine(fineTopologies);
  fine.executor_ = executor_;
  fine.density_ = density_;
  fine.massFloor_ = massFloor_;
  for (int a = 0; a < idx(Attribute::Count); ++a)
    if (allocated_[a]) fine.require(static_cast<Attribute>(a));
  for (Attribute a : {Attribute::Position, Attribute::PreviousPosition, Attribute::Force,
                      Attribute::ReferencePosition}) {
    if (!has(a)) continue;
    for (Index m = 0; m < meshCount(); ++m) {
      const MeshRange& rc = ranges_[m];
      const MeshRange& rf = fine.ranges_[m];
      prolongations[m]->apply(std::span<const Vec3>(vec3_[idx(a)]).subspan(rc.vertexBegin, rc.vertexCount()),
                              std::span<Vec3>(fine.vec3_[idx(a)]).subspan(rf.vertexBegin, rf.vertexCount()), executor());
    }
  }
  return fine;
}

}  // namespace sinew
