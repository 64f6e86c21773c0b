// The host side of collision detection (collision_bvh.h): the hierarchy of every structure, built
// once per level from the mesh store, refitted on the host for the CPU force; the CUDA backend
// uploads the same arrays and refits them on the device.
#pragma once

#include "sinew/core/collision_bvh.h"
#include "sinew/core/mesh_store.h"
#include "sinew/core/parameters.h"
#include "sinew/core/scene_data.h"
#include "sinew/core/surface_distance.h"  // asP3

#include <span>
#include <string>
#include <vector>

namespace sinew {

struct CollisionTree {
  std::vector<collision::Node> nodes;  // each structure's tree in pre-order (children after parents)
  std::vector<collision::Box> boxes;
  std::vector<collision::Tri> tris;    // three per vertex
  std::vector<int> order;              // vertices, leaf by leaf
  std::vector<int> roots;              // per structure
  std::vector<int> leaves;             // node index of every leaf
  std::vector<unsigned char> exempt;   // meshes x meshes, 1 where a pair is left out; empty: none
  std::vector<float> share;            // meshes x meshes, collision::shareOf; empty: every vertex takes all

  // Each structure's vertices split at the median along the widest axis down to leaves of at most
  // four; boxes from the store's current positions.
  static CollisionTree build(MeshStore& store);
  // Boxes from positions and cell centres: leaves in parallel, then the inner nodes from below.
  void refit(std::span<const Vec3> positions, std::span<const Vec3> centres, const Executor& executor);
  collision::BvhView view();
  // How two structures in contact share its correction, from the collision force's parameters
  // (`size_share` p, the weights in column 0): a vertex of structure i against j takes
  // min(1, 2 a_i^p / (a_i^p + a_j^p)), a the structures' surface areas now. The larger gives way
  // more, so each loses about the same fraction of its surface; alike pairs still both take all.
  // Against a structure that does not respond (weight 0) a vertex takes all. p = 0: no table.
  // The scene's shares by pair (`collision_shares`) replace these for their pairs, whatever p.
  void setShares(MeshStore& store, const SceneData& scene, const ParamTable& collisionParams);

  // A structure that lies inside another (or on it: two copies of one mesh), which no contact
  // response can separate: at least `fraction` of its vertices (an even sample of at most 512)
  // inside the other or within the margin of its surface. Unbounded searches: meant once per
  // level, not every step.
  struct Enclosure {
    Index inner = -1, outer = -1;
    Index inside = 0, sampled = 0;  // of the inner structure's vertices, an even sample
    std::string message(const SceneData& scene, float margin) const;
  };
  std::vector<Enclosure> findEnclosures(MeshStore& store, float margin, float fraction = 0.9f);
  // Throws NumericalError naming the first such pair, or with `ignore` (nested structures by design)
  // leaves every such pair out of the collisions.
  void handleEnclosures(MeshStore& store, const SceneData& scene, float margin, bool ignore);
};

// The collision force's parameters as the response reads them, on either backend: the settings
// of collision::contactResponse, and how many steps a full search covers (at least 1).
collision::ContactSettings contactSettingsOf(const ParamTable& collisionParams);
int fullSearchEveryOf(const ParamTable& collisionParams);
// How many of a level's first steps search in full besides (full_search_first, at least 0).
int fullSearchFirstOf(const ParamTable& collisionParams);

// Per vertex of the store, 1 where it lies inside another structure or within `margin` of its
// surface (pairs nested by design left out): the contact regions a view shows. Builds its own
// hierarchy and searches without bound, so it is meant on request, not every step. Allocates the
// store's cell centres when nothing required them yet.
std::vector<unsigned char> contactMask(MeshStore& store, const SceneData& scene, float margin);

}  // namespace sinew
