// Which execution backend runs the steps: shared by sinew-run and the workstation so both choose,
// fall back and explain alike.
#pragma once

#include "sinew/core/execution_backend.h"
#include "sinew/core/simulation.h"

#include <functional>
#include <memory>
#include <string>

namespace sinew {

// choice: "auto" (CUDA when a usable GPU exists), "cuda" or "cpu". Returns null for the CPU; every
// fallback is explained through notice (a missing device, a failed start, a build without CUDA).
std::unique_ptr<ExecutionBackend> makeBackend(const std::string& choice, Simulation& simulation,
                                              const std::function<void(const std::string&)>& notice);

}  // namespace sinew
