#include "device_forces.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace sinew::cuda {

bool builtInForceKind(const std::string& name, ForceKind& kind) {
  static const std::map<std::string, ForceKind> kinds = {{"smoothing", ForceKind::Smoothing},
                                                         {"shape_prior", ForceKind::ShapePrior},
                                                         {"gradient", ForceKind::Gradient},
                                                         {"intensity_profile", ForceKind::Profile},
                                                         {"attraction_points", ForceKind::Attraction},
                                                         {"collision", ForceKind::Collision},
                                                         {"contacts", ForceKind::Contacts},
                                                         {"radial", ForceKind::Radial}};
  const auto it = kinds.find(name);
  if (it == kinds.end()) return false;
  kind = it->second;
  return true;
}

int maxProfileReach(const ParamTable& t) {
  const int kDepth = t.indexOf("search_depth");
  const float spacing = t.getf(0, t.indexOf("spacing"));
  int reach = 0;
  for (Index r = 0; r < t.rows(); ++r) reach = std::max(reach, static_cast<int>(std::floor(t.getf(r, kDepth) / spacing)));
  return reach;
}

FusedTerms fusedPrefix(const std::vector<ForceSlot>& forces, Simulation& sim, bool regularise, size_t& next) {
  FusedTerms fused;
  for (next = 0; next < forces.size() && fused.count < 4; ++next) {
    const ForceSlot& f = forces[next];
    const ParamTable& t = sim.forceParams(f.name);
    const bool fusable = f.kind == ForceKind::Smoothing || f.kind == ForceKind::ShapePrior ||
                         (f.kind == ForceKind::Gradient && !regularise);
    if (!fusable) break;
    if (!t.anyPositive(0)) continue;
    FusedTerm term{};
    term.params = ParamView{f.params.get(), f.count};
    if (f.kind == ForceKind::Smoothing) {
      term.kind = FusedTerm::Smoothing;
      term.k0 = t.indexOf("elevation_term");
    } else if (f.kind == ForceKind::ShapePrior) {
      term.kind = FusedTerm::ShapePrior;
    } else {
      term.kind = FusedTerm::Gradient;
      term.k0 = t.indexOf("epsilon");
      term.k1 = t.indexOf("search_depth");
      term.k2 = t.indexOf("sample_spacing");
    }
    fused.terms[fused.count++] = term;
  }
  return fused;
}

bool activeAfter(const std::vector<ForceSlot>& forces, Simulation& sim, size_t i) {
  for (size_t k = i + 1; k < forces.size(); ++k)
    if (sim.forceParams(forces[k].name).anyPositive(0)) return true;
  return false;
}

bool onlyActiveAfter(const std::vector<ForceSlot>& forces, Simulation& sim, size_t i, const ForceSlot* slot) {
  bool found = false;
  for (size_t k = i + 1; k < forces.size(); ++k)
    if (sim.forceParams(forces[k].name).anyPositive(0)) {
      if (&forces[k] != slot) return false;
      found = true;
    }
  return found;
}

bool anyPluginActive(const std::vector<ForceSlot>& forces, Simulation& sim) {
  return std::any_of(forces.begin(), forces.end(), [&](const ForceSlot& f) {
    return f.kind == ForceKind::Plugin && sim.forceParams(f.name).anyPositive(0);
  });
}

std::vector<float> graphSignature(const std::vector<ForceSlot>& forces, Simulation& sim) {
  std::vector<float> signature;
  for (const ForceSlot& f : forces) {
    const ParamTable& t = sim.forceParams(f.name);
    signature.push_back(t.anyPositive(0) ? 1.0f : 0.0f);
    for (size_t p = 0; p < t.decls().size(); ++p)
      if (!t.decls()[p].perStructure) signature.push_back(t.getf(0, static_cast<int>(p)));
    if (f.kind == ForceKind::Profile) signature.push_back(static_cast<float>(maxProfileReach(t)));  // picks the kernel
  }
  for (size_t p = 0; p < sim.integratorParams().decls().size(); ++p)
    signature.push_back(sim.integratorParams().getf(0, static_cast<int>(p)));
  signature.push_back(sim.affineRegularisation());
  signature.push_back(sim.coarseForceWeight());
  return signature;
}

}  // namespace sinew::cuda
