// The collision hierarchies in device memory (core/collision_tree.h built on the host once per
// level, refitted on the device every step). Allocated only while the collision force is active
// in a scene of two or more structures. Host C++ only.
#pragma once

#include "contact_planes.h"
#include "cuda_check.h"
#include "kernels.h"
#include "sinew/core/collision_tree.h"

namespace sinew::cuda {

class DeviceCollision {
public:
  // withStiffness: keep each vertex's contact pull (implicit Euler's Jacobian).
  // A structure lying inside another stops the run or leaves the pair out (CollisionTree::handleEnclosures).
  // params: the collision force's (margin_mm, ignore_enclosed, size_share and the weights).
  void build(MeshStore& store, const SceneData& scene, const ParamTable& params, bool withStiffness,
             cudaStream_t stream);
  void clear() { *this = DeviceCollision{}; }
  bool built() const { return meshes_ > 0; }
  CollisionDevice view() const;
  const float* stiffness() const { return stiffness_.get(); }
  // launchCollisionRefit and launchCollisionRespond with the force's settings from its parameters
  // `params` (p: their device copy); respond returns those settings (their hold negative: no hold,
  // so no launchCollisionHold; holdStep for the hold's limit). refitsBeforeGeometry: the refit
  // computes the cells' centres it needs.
  bool refitsBeforeGeometry() const { return !climb_; }
  void refit(const MeshView& m, cudaStream_t stream) const;
  collision::ContactSettings respond(const MeshView& m, ParamView p, const ParamTable& params, cudaStream_t stream) const;
  // The full searches' schedule, kept on the host: the steps enqueued at this level (advance), and
  // whether the step `ahead` steps after them searches in full (the level's first does, and its
  // first full_search_first). Between full searches the engine enqueues the contact planes instead
  // of refit and respond (launchCollisionPlanes, or in the profile's passes), with these (hold
  // null: no hold).
  void advance(int steps) { steps_ += steps, levelSteps_ += steps; }
  // After a guard's rollback: the next step searches in full (CollisionForce::restored).
  void restart() { steps_ = 0; }
  // What decides which of a batch's steps search in full (StepGraphs' variant): the place between
  // full searches, and while a level's first steps search, how many have gone.
  int schedule(const ParamTable& params) const;
  bool searchesAt(int ahead, const ParamTable& params) const;
  ContactPlanes contactPlanes(ParamView p, const ParamTable& params) const;
  // The reaction's sums (ReactionSums), allocated once the force's `reaction` is positive:
  // returns true where it allocated them now (a captured step must be captured again).
  // reactionSums: with p (the device copy of `params`); sums null where the step does not react
  // (none allocated, or the gain 0).
  bool prepareReaction(const ParamTable& params, cudaStream_t stream);
  ReactionSums reactionSums(ParamView p, const ParamTable& params) const;
  std::size_t bytes() const;

private:
  void buildNodeLists(const CollisionTree& tree, cudaStream_t stream);

  DeviceArray<collision::Node> nodes_;
  DeviceArray<collision::Box> boxes_;
  DeviceArray<collision::Tri> tris_;
  DeviceArray<collision::Box> vertexBoxes_;
  DeviceArray<int> order_, roots_, leaves_, visits_, threadNodes_, warpNodes_, blockNodes_, hint_;
  DeviceArray<float> stiffness_, depth_, lastDepth_, slack_, moved_, contactShare_;
  DeviceArray<float3> last_, force_;
  DeviceArray<unsigned long long> reaction_;  // CollisionDevice::reaction: kReactionStride per vertex, or none
  DeviceArray<collision::HoldPlane> hold_;  // CollisionDevice::hold
  DeviceArray<collision::ContactPlane> contact_;  // CollisionDevice::contact
  DeviceArray<unsigned> motion_;
  DeviceArray<unsigned char> exempt_;
  DeviceArray<float> share_;
  int meshes_ = 0;
  bool climb_ = false;
  long steps_ = 0;       // the steps enqueued since the level began or a rollback
  long levelSteps_ = 0;  // the steps enqueued since the level began
};

}  // namespace sinew::cuda
