// A plugin force whose device path fails to launch (tst_cuda_parity): the engine must stop with an
// error naming the force, not run on without it.
#include "sinew/core/registry.h"
#include "sinew/cuda/device_force.h"

namespace sinew {
cudaError_t launchWithTooManyThreads(const cuda::MeshView& mesh, cudaStream_t stream);

namespace {
class BadLaunchForce final : public Force, public cuda::DeviceForce {
public:
  Requirements requirements() const override { return {}; }
  void accumulate(ForceContext&, std::span<Vec3>) override {}
  cuda::DeviceForce* deviceForce() override { return this; }
  cudaError_t enqueue(const cuda::DeviceForceContext& ctx) override { return launchWithTooManyThreads(ctx.mesh, ctx.stream); }
};
}  // namespace

void registerTestBadLaunch(Registry& r) {
  r.addForce({"test_bad_launch", "a device path that cannot launch", {}, [] { return std::make_unique<BadLaunchForce>(); }});
}
}  // namespace sinew
