#include "sinew/core/force.h"

#include <algorithm>

namespace sinew {

void PreviousPositionIntegrator::start(IntegratorContext& ctx) {
  const auto x = ctx.store.positions();
  auto prev = ctx.store.previousPositions();
  std::copy(x.begin(), x.end(), prev.begin());
}

void PreviousPositionIntegrator::timeStepScaled(IntegratorContext& ctx, float factor) {
  const auto x = ctx.store.positions();
  auto prev = ctx.store.previousPositions();
  ctx.executor.forEach(ctx.store.vertexCount(), [&](Index v) { prev[v] = x[v] - factor * (x[v] - prev[v]); }, 4096);
}

}  // namespace sinew
