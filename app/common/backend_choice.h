// Which execution backend runs the steps: shared by sinew-run and the workstation so both choose,
// fall back and explain alike.
#pragma once

#include "sinew/core/execution_backend.h"
#include "sinew/core/simulation.h"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sinew {

// choice: "auto" (CUDA when a usable GPU exists), "cuda" or "cpu". Returns null for the CPU; every
// fallback is explained through notice (a missing device, a failed start, a build without CUDA).
std::unique_ptr<ExecutionBackend> makeBackend(const std::string& choice, Simulation& simulation,
                                              const std::function<void(const std::string&)>& notice);

// Probes the device and creates its context in the background (a few tenths of a second) so that
// this overlaps the scene's loading; the next makeBackend waits for it and uses its answer.
// Nothing for "cpu" or in a build without CUDA.
void startDeviceEarly(const std::string& choice);
// Waits for a start begun by startDeviceEarly that no makeBackend took (a run that failed before
// its backend, on bad input). Without it the wait fell to the start's static future, whose
// destructor runs after the CUDA runtime's exit handler (registered later, by the start itself):
// the runtime could be torn down beside a start still inside it. DeviceStartWait calls it when it
// leaves scope, before main returns.
void finishDeviceStart();
struct DeviceStartWait {
  DeviceStartWait() = default;
  DeviceStartWait(const DeviceStartWait&) = delete;
  DeviceStartWait& operator=(const DeviceStartWait&) = delete;
  ~DeviceStartWait() { finishDeviceStart(); }
};

// The GPUs the CUDA backend can use on this host, by CUDA index among the visible devices (none in
// a build without CUDA).
std::vector<int> usableGpus();

}  // namespace sinew
