#include "sinew/core/force.h"

namespace sinew {

void addNeighbourPullJacobian(const ForceContext& ctx, JacobianBlocks& jacobian) {
  forActiveVertices(ctx, [&](Index v, float alpha) {
    jacobian.self[v].diagonal().array() -= alpha;
    for (Mat3& b : jacobian.neighbour[v]) b.diagonal().array() += alpha / 3.0f;
  });
}

void addNormalPullJacobian(const ForceContext& ctx, JacobianBlocks& jacobian) {
  const auto normal = ctx.store.normals();
  forActiveVertices(ctx, [&](Index v, float alpha) { jacobian.self[v] -= alpha * normal[v] * normal[v].transpose(); });
}

void addFixedPointPullJacobian(const ForceContext& ctx, std::span<const float> stiffness, JacobianBlocks& jacobian) {
  if (stiffness.size() != size_t(ctx.store.vertexCount())) return;
  ctx.executor.forEach(ctx.store.vertexCount(), [&](Index v) {
    if (stiffness[v] > 0.0f) jacobian.self[v].diagonal().array() -= stiffness[v];
  });
}

}  // namespace sinew
