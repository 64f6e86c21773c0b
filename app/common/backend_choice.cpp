#include "backend_choice.h"

#ifdef SINEW_WITH_CUDA
#include "sinew/cuda/cuda_engine.h"
#endif

#include <future>

namespace sinew {

#ifdef SINEW_WITH_CUDA
namespace {
std::future<cuda::DeviceStatus> early;  // startDeviceEarly's, taken by the next makeBackend
}
#endif

void startDeviceEarly(const std::string& choice) {
#ifdef SINEW_WITH_CUDA
  if (choice != "cpu" && !early.valid()) early = std::async(std::launch::async, cuda::startDevice);
#else
  (void)choice;
#endif
}

void finishDeviceStart() {
#ifdef SINEW_WITH_CUDA
  if (early.valid()) early.wait();
#endif
}

std::unique_ptr<ExecutionBackend> makeBackend(const std::string& choice, Simulation& sim,
                                              const std::function<void(const std::string&)>& notice) {
  if (choice == "cpu") return nullptr;
#ifdef SINEW_WITH_CUDA
  const cuda::DeviceStatus st = early.valid() ? early.get() : cuda::probeDevice();
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

std::vector<int> usableGpus() {
#ifdef SINEW_WITH_CUDA
  return cuda::usableDevices();
#else
  return {};
#endif
}

}  // namespace sinew
