#include "device_collision.h"

namespace sinew::cuda {

void DeviceCollision::build(MeshStore& store, const SceneData& scene, float margin, bool ignoreEnclosed,
                            bool withStiffness, cudaStream_t stream) {
  CollisionTree tree = CollisionTree::build(store);
  tree.handleEnclosures(store, scene, margin, ignoreEnclosed);
  exempt_.upload(tree.exempt, stream);
  nodes_.upload(tree.nodes, stream);
  boxes_.upload(tree.boxes, stream);
  tris_.upload(tree.tris, stream);
  order_.upload(tree.order, stream);
  roots_.upload(tree.roots, stream);
  leaves_.upload(tree.leaves, stream);
  visits_.resize(tree.nodes.size());
  stiffness_.resize(withStiffness ? size_t(store.vertexCount()) : 0);
  if (withStiffness) SINEW_CUDA(cudaMemsetAsync(stiffness_.get(), 0, stiffness_.bytes(), stream));
  depth_.upload(std::vector<float>(store.vertexCount(), collision::kUnknownDepth), stream);
  hint_.upload(std::vector<int>(store.vertexCount(), -1), stream);
  slack_.resize(store.vertexCount());  // no slack until the first step's (unbounded) search
  SINEW_CUDA(cudaMemsetAsync(slack_.get(), 0, slack_.bytes(), stream));
  moved_.resize(store.vertexCount());  // written by every step's refit before the response reads it
  const auto x = store.positions();
  last_.upload(reinterpret_cast<const float3*>(x.data()), x.size(), stream);
  motion_.resize(1);
  SINEW_CUDA(cudaMemsetAsync(motion_.get(), 0, motion_.bytes(), stream));
  counter_.resize(1);
  SINEW_CUDA(cudaMemsetAsync(counter_.get(), 0, counter_.bytes(), stream));
  meshes_ = int(tree.roots.size());
  SINEW_CUDA(cudaStreamSynchronize(stream));  // the host vectors go out of scope
}

CollisionDevice DeviceCollision::view() const {
  CollisionDevice c;
  c.nodes = nodes_.get();
  c.boxes = boxes_.get();
  c.tris = tris_.get();
  c.order = order_.get();
  c.roots = roots_.get();
  c.leaves = leaves_.get();
  c.visits = visits_.get();
  c.stiffness = stiffness_.get();
  c.depth = depth_.get();
  c.counter = counter_.get();
  c.exempt = exempt_.get();
  c.hint = hint_.get();
  c.slack = slack_.get();
  c.moved = moved_.get();
  c.last = last_.get();
  c.motion = motion_.get();
  c.meshes = meshes_;
  c.nodeCount = int(nodes_.size());
  c.leafCount = int(leaves_.size());
  return c;
}

std::size_t DeviceCollision::bytes() const {
  return nodes_.bytes() + boxes_.bytes() + tris_.bytes() + order_.bytes() + roots_.bytes() + leaves_.bytes() + visits_.bytes() +
         stiffness_.bytes() + depth_.bytes() + counter_.bytes() + hint_.bytes() + exempt_.bytes() + slack_.bytes() + moved_.bytes() + last_.bytes() + motion_.bytes();
}

}  // namespace sinew::cuda
