// Attachments (paper 001 section 2.2): topological constraints between structures, applied by the
// simulation around each integration step (docs/attachments.md).
//   - surface: a structure's vertices near another structure's surface follow that surface
//     (barycentric coordinates on its tessellation; mass modification, M^-1 = 0: their own forces
//     are ignored);
//   - merge: vertex pairs of two structures move together (forces and masses summed, and the pair
//     put back at its offset about its centre of mass after each step);
//   - fixed: a structure's vertices inside a sphere do not move (M^-1 = 0).
// Built at the start of every level from the positions then (after the initialisation at level 0).
#pragma once

#include "sinew/core/executor.h"
#include "sinew/core/mesh_store.h"

#include <string>
#include <vector>

namespace sinew {

// The level's constraints as plain arrays, for a backend that applies them on its device in the
// order shareForces() and project() do. Attached vertex k is at sum_i weight[i] x[source[i]] +
// offset[k] over i in [attachedOffsets[k], attachedOffsets[k + 1]).
struct AttachmentArrays {
  std::vector<int> mergedA, mergedB;
  std::vector<Vec3> mergedOffset;
  std::vector<int> fixedVertex;
  std::vector<Vec3> fixedAt;
  std::vector<int> attachedVertex, attachedOffsets{0}, attachedSource;
  std::vector<float> attachedWeight;
  std::vector<Vec3> attachedOffset;
  // Some attached vertex follows another attached vertex: they must be placed one after the other.
  bool attachedInOrder = false;
  bool empty() const { return mergedA.empty() && fixedVertex.empty() && attachedVertex.empty(); }
};

struct AttachmentSpec {
  enum class Kind { Surface, Merge, Fixed };
  Kind kind = Kind::Surface;
  Index structure = -1;
  Index other = -1;          // surface, merge: the other structure
  float distanceMm = 1.0f;   // surface, merge: vertices this close (at the level's start) are attached
  Vec3 centre = Vec3::Zero();  // fixed: the sphere, world mm
  float radiusMm = 0.0f;
};

class Attachments {
public:
  Attachments() = default;
  explicit Attachments(std::vector<AttachmentSpec> specs) : specs_(std::move(specs)) {}
  bool empty() const { return specs_.empty(); }
  const std::vector<AttachmentSpec>& specs() const { return specs_; }

  // At the start of each level: which vertices are attached, to what, with their offsets.
  void build(MeshStore& store, const Executor& executor);
  // Before the integrator: merged pairs share their summed force in proportion to their masses
  // (one acceleration; the shares are kept for project()), attached and fixed vertices get none.
  void shareForces(MeshStore& store);
  // After the integrator: fixed vertices back where they were, merged pairs at their offset about
  // their centre of mass, attached ones onto their surface (previous positions too, so that they
  // keep one velocity).
  void project(MeshStore& store) const;

  AttachmentArrays arrays() const;

  // Throws InputError naming the attachment when a spec does not fit the store (structure indices,
  // distances, radii).
  void validate(const MeshStore& store) const;

  // Counts at this level, for reports and tests.
  Index attachedCount() const { return Index(attached_.size()); }
  Index mergedCount() const { return Index(merged_.size()); }
  std::vector<std::pair<Index, Index>> mergedPairs() const {
    std::vector<std::pair<Index, Index>> out;
    for (const Merged& p : merged_) out.emplace_back(p.a, p.b);
    return out;
  }
  Index fixedCount() const { return Index(fixed_.size()); }

private:
  struct Attached {
    Index vertex = -1;
    std::vector<std::pair<Index, float>> weights;  // the other structure's vertices
    Vec3 offset = Vec3::Zero();
  };
  struct Fixed {
    Index vertex = -1;
    Vec3 at = Vec3::Zero();
  };
  std::vector<AttachmentSpec> specs_;
  std::vector<Attached> attached_;
  struct Merged {
    Index a = -1, b = -1;
    Vec3 offset = Vec3::Zero();  // x_b - x_a at the level's start, kept
    float shareA = 0.5f;         // a's share of the pair's mass, at the last shareForces()
  };
  std::vector<Merged> merged_;
  std::vector<Fixed> fixed_;
};

}  // namespace sinew
