// Each structure's image fit from the first force of the scene that offers one (image_fit.h).
#include "sinew/core/image_fit.h"

#include "sinew/core/simulation.h"

#include <algorithm>
#include <cmath>

namespace sinew {

std::vector<StructureImageFit> imageFitOf(Simulation& sim) {
  MeshStore& store = sim.store();
  std::vector<StructureImageFit> out(store.meshCount());
  for (const std::string& name : sim.forceNames()) {
    auto* fit = dynamic_cast<ImageFit*>(&sim.force(name));
    ParamTable& params = sim.forceParams(name);
    if (!fit || !params.anyPositive(0)) continue;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<float> match(store.vertexCount(), nan), agreement(store.vertexCount(), nan);
    ForceContext ctx{store, params, sim.scene(), sim.executor()};
    fit->fitScores(ctx, match, agreement);
    for (Index i = 0; i < store.meshCount(); ++i) {
      const MeshRange& r = store.range(i);
      double m = 0.0, a = 0.0;
      Index n = 0;
      for (Index v = r.vertexBegin; v < r.vertexEnd; ++v)
        if (std::isfinite(match[v])) m += match[v], a += agreement[v], ++n;
      if (n == 0) continue;
      out[i].match = m / double(n);
      out[i].agreement = a / double(n);
      out[i].fit = std::min(1.0, out[i].match / std::sqrt(std::max(out[i].agreement, 0.01)));
    }
    break;  // the first force that offers one
  }
  return out;
}

}  // namespace sinew
