// The mesh store: every mesh of a scene in one structure of arrays (one array per attribute, all
// meshes concatenated, per-mesh ranges). Topology indices are global, so a kernel needs no per-mesh
// offsets. Only attributes somebody required are allocated; derived geometry is recomputed on
// request when the positions changed since it was last computed, and is never handed out stale.
// The CUDA backend mirrors these arrays one to one.
#pragma once

#include "sinew/core/executor.h"
#include "sinew/core/level_of_detail.h"
#include "sinew/core/simplex_geometry.h"
#include "sinew/core/simplex_mesh.h"

#include <array>
#include <map>
#include <span>
#include <string>
#include <vector>

namespace sinew {

enum class Attribute : int {
  // State, written by integrators and users.
  Position,
  PreviousPosition,
  Force,
  ReferencePosition,  // the reference shape, same topology (shape prior, profile training)
  // Derived from Position.
  Normal,
  Elevation,
  SimplexParams,
  CellCentre,  // per cell
  Area,        // per vertex: sum of the paper-000 Fig. 1b triangles at the vertex
  Mass,        // area x the mesh's density, at least the mesh's mass floor
  // Derived from ReferencePosition.
  ReferenceNormal,
  ReferenceParams,
  Count
};
const char* attributeName(Attribute a);

// What memory is for; lets tests and reports show that a scene allocated only what it needs.
enum class MemoryCategory { Topology, State, Geometry, ImageDerived, Count };

struct MeshRange {
  Index vertexBegin = 0, vertexEnd = 0, cellBegin = 0, cellEnd = 0;
  Index vertexCount() const { return vertexEnd - vertexBegin; }
};

class MeshStore {
public:
  MeshStore() = default;
  explicit MeshStore(std::span<const SimplexTopology* const> topologies);

  Index meshCount() const { return static_cast<Index>(ranges_.size()); }
  Index vertexCount() const { return static_cast<Index>(neighbours_.size()); }
  Index cellCount() const { return static_cast<Index>(cellOffsets_.size()) - 1; }
  const MeshRange& range(Index mesh) const { return ranges_[mesh]; }
  std::span<const Index> meshOfVertex() const { return meshOfVertex_; }
  std::span<const std::array<Index, 3>> neighbours() const { return neighbours_; }
  std::span<const std::array<Index, 3>> vertexCells() const { return vertexCells_; }
  std::span<const Index> cellOffsets() const { return cellOffsets_; }
  std::span<const Index> cellVertices() const { return cellVertices_; }
  // One mesh's topology with local indices (for export and tessellation).
  SimplexTopology topologyOf(Index mesh) const;

  // Allocation on demand. Requiring a derived attribute requires what it is computed from.
  void require(Attribute a);
  bool has(Attribute a) const { return allocated_[static_cast<int>(a)]; }

  // State. The *ForWrite accessors mark what is derived from them stale.
  std::span<const Vec3> positions() const { return vec3(Attribute::Position); }
  std::span<Vec3> positionsForWrite();
  std::span<const Vec3> referencePositions() const { return vec3(Attribute::ReferencePosition); }
  std::span<Vec3> referencePositionsForWrite();
  std::span<Vec3> previousPositions() { return vec3(Attribute::PreviousPosition); }
  std::span<Vec3> forces() { return vec3(Attribute::Force); }
  std::span<const Vec3> mesh(std::span<const Vec3> all, Index m) const {
    return all.subspan(ranges_[m].vertexBegin, ranges_[m].vertexCount());
  }

  // Derived geometry, brought up to date on request.
  std::span<const Vec3> normals();
  std::span<const float> elevations();
  std::span<const SimplexParams> simplexParams();
  std::span<const Vec3> cellCentres();
  std::span<const float> areas();
  std::span<const float> masses();
  std::span<const Vec3> referenceNormals();
  std::span<const SimplexParams> referenceParams();
  // Recomputes every allocated derived attribute that is stale.
  void refresh();

  void setDensity(Index mesh, float density);
  float density(Index mesh) const { return density_[mesh]; }
  // The least mass of the mesh's vertices (Simulation::applyDensities): mass = max(area x density,
  // floor). 0 (the default) leaves area x density.
  void setMassFloor(Index mesh, float mass);
  float massFloor(Index mesh) const { return massFloor_[mesh]; }

  // Named per-vertex float channels for forces (e.g. trained profiles): width floats per vertex.
  std::span<float> requireChannel(const std::string& name, Index width, MemoryCategory category);
  std::span<float> channel(const std::string& name);
  Index channelWidth(const std::string& name) const;

  std::size_t bytes(MemoryCategory c) const;

  void setExecutor(const Executor* executor) { executor_ = executor; }
  const Executor& executor() const;

  // A store for the next level of detail: same required attributes and densities, with positions,
  // previous positions, forces and the reference shape carried by the prolongations.
  MeshStore refined(std::span<const SimplexTopology* const> fineTopologies,
                    std::span<const Prolongation* const> prolongations) const;

private:
  struct Channel {
    Index width = 0;
    MemoryCategory category = MemoryCategory::ImageDerived;
    std::vector<float> values;
  };

  std::span<const Vec3> vec3(Attribute a) const;
  std::span<Vec3> vec3(Attribute a);
  void requireVec3(Attribute a, Index count);
  void ensureFresh(Attribute a);
  void refreshCurrent();
  void refreshReference();
  bool currentStale() const { return currentComputedAt_ != positionsVersion_; }
  bool referenceStale() const { return referenceComputedAt_ != referenceVersion_; }

  std::vector<MeshRange> ranges_;
  std::vector<Index> meshOfVertex_;
  std::vector<std::array<Index, 3>> neighbours_, vertexCells_;
  std::vector<Index> cellOffsets_{0}, cellVertices_;
  std::vector<float> density_, massFloor_;

  std::array<bool, static_cast<int>(Attribute::Count)> allocated_{};
  std::array<std::vector<Vec3>, static_cast<int>(Attribute::Count)> vec3_;
  std::vector<float> elevations_, areas_, masses_;
  std::vector<SimplexParams> params_, referenceParams_;
  std::map<std::string, Channel> channels_;

  std::uint64_t positionsVersion_ = 1, currentComputedAt_ = 0;
  std::uint64_t referenceVersion_ = 1, referenceComputedAt_ = 0;
  const Executor* executor_ = nullptr;
};

}  // namespace sinew
