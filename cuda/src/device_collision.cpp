#include "device_collision.h"

#include <algorithm>

namespace sinew::cuda {

void DeviceCollision::build(MeshStore& store, const SceneData& scene, const ParamTable& params, bool withStiffness,
                            cudaStream_t stream) {
  CollisionTree tree = CollisionTree::build(store);
  tree.handleEnclosures(store, scene, params.getf(0, params.indexOf("margin_mm")),
                        params.getf(0, params.indexOf("ignore_enclosed")) > 0.5f);
  tree.setShares(store, scene, params);
  exempt_.upload(tree.exempt, stream);
  share_.upload(tree.share, stream);
  nodes_.upload(tree.nodes, stream);
  boxes_.upload(tree.boxes, stream);
  tris_.upload(tree.tris, stream);
  order_.upload(tree.order, stream);
  roots_.upload(tree.roots, stream);
  climb_ = store.vertexCount() >= kClimbFrom;
  if (climb_) {
    leaves_.upload(tree.leaves, stream);
    visits_.resize(tree.nodes.size());  // zero between refits: each node's second child resets it
    SINEW_CUDA(cudaMemsetAsync(visits_.get(), 0, visits_.bytes(), stream));
  } else {
    buildNodeLists(tree, stream);
    vertexBoxes_.resize(store.vertexCount());
  }
  stiffness_.resize(withStiffness ? size_t(store.vertexCount()) : 0);
  if (withStiffness) SINEW_CUDA(cudaMemsetAsync(stiffness_.get(), 0, stiffness_.bytes(), stream));
  depth_.upload(std::vector<float>(store.vertexCount(), collision::kUnknownDepth), stream);
  lastDepth_.resize(tree.share.empty() ? 0 : size_t(store.vertexCount()));  // copied from depth_ by each full search
  hint_.upload(std::vector<int>(store.vertexCount(), -1), stream);
  slack_.resize(store.vertexCount());  // no slack until the first step's (unbounded) search
  SINEW_CUDA(cudaMemsetAsync(slack_.get(), 0, slack_.bytes(), stream));
  moved_.resize(store.vertexCount());  // written by every step's refit before the response reads it
  const auto x = store.positions();
  last_.upload(reinterpret_cast<const float3*>(x.data()), x.size(), stream);
  hold_.resize(store.vertexCount());  // written by every response before the hold reads it
  contact_.resize(store.vertexCount());  // read only where contactShare_ says a full search wrote it
  contactShare_.upload(std::vector<float>(store.vertexCount(), -1.0f), stream);  // none until a full search writes it
  force_.resize(store.vertexCount());  // likewise, before launchCollisionAdd reads it
  reaction_.resize(0);
  prepareReaction(params, stream);
  motion_.resize(1);
  SINEW_CUDA(cudaMemsetAsync(motion_.get(), 0, motion_.bytes(), stream));
  meshes_ = int(tree.roots.size());
  steps_ = levelSteps_ = 0;
  SINEW_CUDA(cudaStreamSynchronize(stream));  // the host vectors go out of scope
}

// NodeLists: the nodes the refit computes from their vertices, by size.
void DeviceCollision::buildNodeLists(const CollisionTree& tree, cudaStream_t stream) {
  std::vector<int> threadNodes, warpNodes, blockNodes;
  for (int id = 0; id < int(tree.nodes.size()); ++id) {
    const int count = tree.nodes[id].count;
    (count <= kThreadNode ? threadNodes : count <= kWarpNode ? warpNodes : blockNodes).push_back(id);
  }
  threadNodes_.upload(threadNodes, stream);
  warpNodes_.upload(warpNodes, stream);
  blockNodes_.upload(blockNodes, stream);
}

void DeviceCollision::refit(const MeshView& m, cudaStream_t stream) const { launchCollisionRefit(m, view(), stream); }

collision::ContactSettings DeviceCollision::respond(const MeshView& m, ParamView p, const ParamTable& params,
                                                   cudaStream_t stream) const {
  const collision::ContactSettings settings = contactSettingsOf(params);
  launchCollisionRespond(m, p, view(), settings, fullSearchEveryOf(params), stream);
  return settings;
}

int DeviceCollision::schedule(const ParamTable& params) const {
  const int every = fullSearchEveryOf(params);
  return int(std::min<long>(levelSteps_, fullSearchFirstOf(params))) * every + int(steps_ % every);
}

bool DeviceCollision::searchesAt(int ahead, const ParamTable& params) const {
  return (steps_ + ahead) % fullSearchEveryOf(params) == 0 || levelSteps_ + ahead < fullSearchFirstOf(params);
}

ContactPlanes DeviceCollision::contactPlanes(ParamView p, const ParamTable& params) const {
  ContactPlanes planes;
  planes.params = p;
  planes.settings = contactSettingsOf(params);
  planes.contact = contact_.get();
  planes.share = contactShare_.get();
  planes.depth = depth_.get();
  planes.stiffness = stiffness_.get();
  planes.hold = planes.settings.hold >= 0.0f ? hold_.get() : nullptr;
  return planes;
}

bool DeviceCollision::prepareReaction(const ParamTable& params, cudaStream_t stream) {
  if (reaction_.size() || !(contactSettingsOf(params).reaction > 0.0f) || !moved_.size()) return false;
  reaction_.resize(kReactionStride * moved_.size());  // moved_: one per vertex; each step's add zeroes them
  SINEW_CUDA(cudaMemsetAsync(reaction_.get(), 0, reaction_.bytes(), stream));
  return true;
}

ReactionSums DeviceCollision::reactionSums(ParamView p, const ParamTable& params) const {
  const collision::ContactSettings settings = contactSettingsOf(params);
  if (!reaction_.size() || !(settings.reaction > 0.0f)) return {};
  return {p, settings, contact_.get(), contactShare_.get(), reaction_.get()};
}

CollisionDevice DeviceCollision::view() const {
  CollisionDevice c;
  c.nodes = nodes_.get();
  c.boxes = boxes_.get();
  c.tris = tris_.get();
  c.order = order_.get();
  c.roots = roots_.get();
  c.climb = climb_;
  c.leaves = leaves_.get();
  c.visits = visits_.get();
  c.leafCount = int(leaves_.size());
  c.vertexBoxes = vertexBoxes_.get();
  c.lists = {threadNodes_.get(), warpNodes_.get(), blockNodes_.get(), int(threadNodes_.size()), int(warpNodes_.size()),
             int(blockNodes_.size())};
  c.stiffness = stiffness_.get();
  c.depth = depth_.get();
  c.lastDepth = lastDepth_.size() ? lastDepth_.get() : nullptr;
  c.exempt = exempt_.get();
  c.share = share_.get();
  c.hint = hint_.get();
  c.slack = slack_.get();
  c.moved = moved_.get();
  c.last = last_.get();
  c.motion = motion_.get();
  c.hold = hold_.get();
  c.contact = contact_.get();
  c.contactShare = contactShare_.get();
  c.force = force_.get();
  c.reaction = reaction_.size() ? reaction_.get() : nullptr;
  c.meshes = meshes_;
  c.nodeCount = int(nodes_.size());
  return c;
}

std::size_t DeviceCollision::bytes() const {
  return nodes_.bytes() + boxes_.bytes() + tris_.bytes() + order_.bytes() + roots_.bytes() + leaves_.bytes() +
         visits_.bytes() + threadNodes_.bytes() + warpNodes_.bytes() + blockNodes_.bytes() + vertexBoxes_.bytes() +
         stiffness_.bytes() + depth_.bytes() + lastDepth_.bytes() + hint_.bytes() + exempt_.bytes() + share_.bytes() +
         slack_.bytes() + moved_.bytes() + last_.bytes() + motion_.bytes() + hold_.bytes() +
         contact_.bytes() + contactShare_.bytes() + force_.bytes() + reaction_.bytes();
}

}  // namespace sinew::cuda
