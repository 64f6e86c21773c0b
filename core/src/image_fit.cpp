// Each structure's image fit from the first force of the scene that offers one (image_fit.h).
#include "sinew/core/image_fit.h"

#include "sinew/core/simulation.h"

#include <algorithm>
#include <cmath>

namespace sinew {

namespace {

// Every vertex's match and agreement from the first force that offers them and is weighted above
// 0 somewhere (NaN where it scores none); false where no force does.
bool scoreVertices(Simulation& sim, std::vector<float>& match, std::vector<float>& agreement) {
  MeshStore& store = sim.store();
  for (const std::string& name : sim.forceNames()) {
    auto* fit = dynamic_cast<ImageFit*>(&sim.force(name));
    ParamTable& params = sim.forceParams(name);
    if (!fit || !params.anyPositive(0)) continue;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    match.assign(store.vertexCount(), nan);
    agreement.assign(store.vertexCount(), nan);
    ForceContext ctx{store, params, sim.scene(), sim.executor()};
    fit->fitScores(ctx, match, agreement);
    return true;
  }
  return false;
}

// The means of a structure's scored vertices; fit = min(1, match / sqrt(agreement)).
StructureImageFit structureFit(const MeshRange& r, const std::vector<float>& match, const std::vector<float>& agreement) {
  StructureImageFit out;
  double m = 0.0, a = 0.0;
  Index n = 0;
  for (Index v = r.vertexBegin; v < r.vertexEnd; ++v)
    if (std::isfinite(match[v])) m += match[v], a += agreement[v], ++n;
  if (n == 0) return out;
  out.match = m / double(n);
  out.agreement = a / double(n);
  out.fit = std::min(1.0, out.match / std::sqrt(std::max(out.agreement, 0.01)));
  return out;
}

}  // namespace

std::vector<StructureImageFit> imageFitOf(Simulation& sim) { return imageFitScores(sim, 0).structures; }

std::vector<float> vertexImageFit(Simulation& sim, int passes) { return imageFitScores(sim, passes).vertices; }

ImageFitScores imageFitScores(Simulation& sim, int passes) {
  MeshStore& store = sim.store();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  ImageFitScores out{std::vector<StructureImageFit>(store.meshCount()), std::vector<float>(store.vertexCount(), nan)};
  std::vector<float> match, agreement;
  if (!scoreVertices(sim, match, agreement)) return out;
  for (Index i = 0; i < store.meshCount(); ++i) out.structures[i] = structureFit(store.range(i), match, agreement);
  // The match smoothed over the surface: each pass takes every vertex to the mean of itself and its
  // three neighbours (unscored ones left out; neighbours never cross structures).
  const auto neighbours = store.neighbours();
  std::vector<float> next(match.size());
  for (int pass = 0; pass < passes; ++pass) {
    sim.executor().forEach(store.vertexCount(), [&](Index v) {
      float sum = 0.0f;
      int count = 0;
      if (std::isfinite(match[v])) sum += match[v], ++count;
      for (Index n : neighbours[v])
        if (std::isfinite(match[n])) sum += match[n], ++count;
      next[v] = count > 0 ? sum / float(count) : nan;
    });
    match.swap(next);
  }
  // Over the square root of the structure's agreement, as the structure's fit is.
  for (Index i = 0; i < store.meshCount(); ++i) {
    const StructureImageFit& whole = out.structures[i];
    if (!std::isfinite(whole.fit)) continue;
    const double noise = 1.0 / std::sqrt(std::max(whole.agreement, 0.01));
    const MeshRange& r = store.range(i);
    for (Index v = r.vertexBegin; v < r.vertexEnd; ++v)
      if (std::isfinite(match[v])) out.vertices[v] = float(std::min(1.0, match[v] * noise));
  }
  return out;
}

}  // namespace sinew
