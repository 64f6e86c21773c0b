// The scene's forces as the device step sees them: each force's kind (a built-in force with kernels
// here, or a plugin's DeviceForce), its parameters in device memory, and the questions the step
// asks of the list (the fused prefix, which forces follow which with a positive weight). Host C++
// only.
#pragma once

#include "cuda_check.h"
#include "kernels.h"
#include "sinew/core/simulation.h"

#include <string>
#include <vector>

namespace sinew::cuda {

enum class ForceKind { Smoothing, ShapePrior, Gradient, Profile, Attraction, Collision, Contacts, Radial, Plugin };

struct ForceSlot {
  std::string name;
  ForceKind kind;
  DeviceArray<float> params;
  int count = 0;
  DeviceForce* device = nullptr;  // ForceKind::Plugin
};

// A built-in force's kind by its name; false for any other name (a plugin's).
bool builtInForceKind(const std::string& name, ForceKind& kind);

// The profile force's largest reach in samples (the kernel's floor(search_depth / spacing), in float).
int maxProfileReach(const ParamTable& t);

// The leading forces that run fused in one kernel (at most 4 of smoothing, the shape prior and,
// unless the affine regularisation is on, the gradient, those with a positive weight), without
// the per-vertex arrays (the caller's). next: the index of the first force not taken.
FusedTerms fusedPrefix(const std::vector<ForceSlot>& forces, Simulation& sim, bool regularise, size_t& next);

// Whether any force after forces[i] has a positive weight somewhere.
bool activeAfter(const std::vector<ForceSlot>& forces, Simulation& sim, size_t i);
// Whether `slot` is the only force after forces[i] with a positive weight.
bool onlyActiveAfter(const std::vector<ForceSlot>& forces, Simulation& sim, size_t i, const ForceSlot* slot);
bool anyPluginActive(const std::vector<ForceSlot>& forces, Simulation& sim);

// Per-structure values are read from device memory, but which kernels run (a force weighted 0
// everywhere is skipped) and the values passed by value are baked into a captured step: it is
// captured again when this, those values, changed.
std::vector<float> graphSignature(const std::vector<ForceSlot>& forces, Simulation& sim);

}  // namespace sinew::cuda
