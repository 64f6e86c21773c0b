#include "backend_choice.h"

#ifdef SINEW_WITH_CUDA
#include "sinew/cuda/cuda_engine.h"
#endif

namespace sinew {

std::unique_ptr<ExecutionBackend> makeBackend(const std::string& choice, Simulation& sim,
                                              const std::function<void(const std::string&)>& notice) {
  if (choice == "cpu") return nullptr;
#ifdef SINEW_WITH_CUDA
  const cuda::DeviceStatus st = cuda::probeDevice();
  if (!st.usable) {
    notice("CUDA backend unavailable (" + st.reason + "); running on the CPU");
    return nullptr;
  }
  try {
    return std::make_unique<cuda::CudaEngine>(sim);
  } catch (const std::exception& e) {
    notice(std::string("CUDA backend failed (") + e.what() + "); running on the CPU");
    return nullptr;
  }
#else
  (void)sim;
  notice("this build has no CUDA backend; running on the CPU");
  return nullptr;
#endif
}

}  // namespace sinew
