// Deforming contacts (paper 001 section 2.2: "once generic collisions and proximities have been
// detected, they are subsequently used as a reference (springs) to smoothly enforce the relative
// position between models"). Found once per level on the reference shapes: each vertex of a
// declared pair's structure is linked to the nearest vertex of its partner(s) within the distance,
// with the reference offset between them; the force `contacts` (CPU) and the CUDA engine pull the
// vertex toward partner + offset.
#pragma once

#include "sinew/core/mesh_store.h"

#include <array>
#include <span>
#include <vector>

namespace sinew {

struct ContactLinks {
  std::vector<Index> partner;  // per vertex: the linked vertex of another structure, or -1
  std::vector<Vec3> offset;    // per vertex: reference position minus the partner's
  Index linked = 0;            // vertices with a partner
};

// The store's reference positions must be allocated (Attribute::ReferencePosition). A vertex near
// several partners is linked to the nearest one.
ContactLinks findContactLinks(const MeshStore& store, std::span<const std::array<Index, 2>> pairs, float distanceMm);

}  // namespace sinew
