// SceneRunner's scoring against the ground truths: the exact evaluation (the start, the end, the
// workstation's), the timeline's sampled error, the label map of a result.
#include "scene_runner_loaded.h"
#include "sinew/core/image_fit.h"
#include "sinew/core/shape_guard.h"
#include "sinew/core/voxelize.h"

namespace sinew {

StructureResult SceneRunner::evaluate(Index i, bool final) {
  MeshStore& store = loaded_->sim->store();
  const auto x = store.mesh(store.positions(), i);
  StructureResult r = surfaceOf(i, std::vector<Vec3>(x.begin(), x.end()));
  score(i, r, final);
  return r;
}

StructureResult SceneRunner::surfaceOf(Index i, const std::vector<Vec3>& positions) const {
  const MeshStore& store = loaded_->sim->store();
  StructureResult r;
  r.name = scene_.structures[i].name;
  r.label = scene_.structures[i].label;
  r.vertices = store.range(i).vertexCount();
  const SceneData& data = loaded_->sim->scene();
  if (data.hasTargetImage() && !positions.empty())
    r.outsideImageShare = double(pointsOutside(positions, data.targetImage().geometry())) / double(positions.size());
  r.surface = tessellate(store.topologyOf(i), positions);
  return r;
}

std::vector<StructureResult> SceneRunner::evaluateEnd(ExecutionBackend* backend) {
  Loaded& L = *loaded_;
  MeshStore& store = L.sim->store();
  const Index n = store.meshCount();
  std::vector<StructureResult> out;
  for (Index i = 0; i < n; ++i) {
    const auto x = store.mesh(store.positions(), i);
    out.push_back(surfaceOf(i, std::vector<Vec3>(x.begin(), x.end())));
  }
  setImageFit(out);
  if (backend && L.sampled) {
    // The host's samples and hierarchies, the device's searches: the truths' hierarchy is the
    // sampled error's (the same trees as the exact evaluation's), the final surfaces' built here.
    std::vector<std::vector<SurfaceSample>> meshSamples(n);
    std::vector<TriangleBvh> surfaceTrees(n);
    L.sim->executor().forEach(
        n,
        [&](Index i) {
          if (!L.truth[i]) return;
          meshSamples[i] = sampleSurface(out[i].surface, L.truth[i]->spacing());
          surfaceTrees[i] = TriangleBvh::build(out[i].surface);
        },
        1);
    TriangleBvh surfaces;
    std::vector<collision::P3> toTruthPoints, fromTruthPoints;
    std::vector<int> toTruthRoots, fromTruthRoots;
    for (Index i = 0; i < n; ++i) {
      if (!L.truth[i]) continue;
      const int root = surfaces.append(surfaceTrees[i]);
      for (const SurfaceSample& s : meshSamples[i]) toTruthPoints.push_back(asP3(s.point)), toTruthRoots.push_back(L.sampled->truthRoots()[i]);
      for (const SurfaceSample& s : L.truth[i]->samples()) fromTruthPoints.push_back(asP3(s.point)), fromTruthRoots.push_back(root);
    }
    std::vector<float> toTruth(toTruthPoints.size()), fromTruth(fromTruthPoints.size());
    bool onDevice = false;
    try {
      onDevice = backend->closestDistances(L.sampled->truth(), toTruthPoints, toTruthRoots, toTruth) &&
                 backend->closestDistances(surfaces, fromTruthPoints, fromTruthRoots, fromTruth);
    } catch (const std::runtime_error& e) {  // the device failed: the host computes them
      if (options_.log) options_.log(std::string("the final evaluation on the device failed (") + e.what() + "); on the host");
    }
    if (onDevice) {
      std::vector<std::size_t> toFirst(n + 1, 0), fromFirst(n + 1, 0);
      for (Index i = 0; i < n; ++i) {
        toFirst[i + 1] = toFirst[i] + meshSamples[i].size();
        fromFirst[i + 1] = fromFirst[i] + (L.truth[i] ? L.truth[i]->samples().size() : 0);
      }
      L.sim->executor().forEach(
          n,
          [&](Index i) {
            if (!L.truth[i]) return;
            std::vector<WeightedDistance> all;
            for (std::size_t k = toFirst[i]; k < toFirst[i + 1]; ++k) all.push_back({toTruth[k], meshSamples[i][k - toFirst[i]].area});
            for (std::size_t k = fromFirst[i]; k < fromFirst[i + 1]; ++k)
              all.push_back({fromTruth[k], L.truth[i]->samples()[k - fromFirst[i]].area});
            setScores(i, out[i], ReferenceSurface::summarise(std::move(all), meshSamples[i].size()), true);
          },
          1);
      return out;
    }
  }
  L.sim->executor().forEach(n, [&](Index i) { score(i, out[i], true); }, 1);  // structures side by side too
  return out;
}

void SceneRunner::setImageFit(std::vector<StructureResult>& out) {
  const MeshStore& store = loaded_->sim->store();
  const ImageFitScores fits = imageFitScores(*loaded_->sim);
  for (size_t i = 0; i < out.size(); ++i) {
    const StructureImageFit& f = fits.structures[i];
    out[i].imageFit = f.fit, out[i].profileMatch = f.match, out[i].selfAgreement = f.agreement;
    // Per point of the written surface (the vertices, then the cell centres: tessellate): a
    // vertex's own fit, a cell centre's the mean of its vertices'.
    const MeshRange& r = store.range(Index(i));
    const SimplexTopology& t = store.topologyOf(Index(i));
    std::vector<float> perPoint(fits.vertices.begin() + r.vertexBegin, fits.vertices.begin() + r.vertexEnd);
    for (Index c = 0; c < t.cellCount(); ++c) {
      double sum = 0.0;
      for (Index k = t.cellOffsets[c]; k < t.cellOffsets[c + 1]; ++k) sum += perPoint[t.cellVertices[k]];
      perPoint.push_back(float(sum / double(t.cellOffsets[c + 1] - t.cellOffsets[c])));
    }
    if (!std::all_of(perPoint.begin(), perPoint.end(), [](float v) { return std::isfinite(v); })) continue;
    if (perPoint.size() != out[i].surface.points.size()) throw std::logic_error("setImageFit: the surface is not the store's tessellation");
    std::erase_if(out[i].surface.pointData, [](const PointArray& a) { return a.name == "image_fit"; });
    out[i].surface.pointData.push_back({"image_fit", std::move(perPoint)});
  }
}

void SceneRunner::score(Index i, StructureResult& r, bool final) const {
  const Loaded& L = *loaded_;
  if (L.truth[i]) setScores(i, r, L.truth[i]->compare(r.surface, L.sim->executor()), final);
}

void SceneRunner::setScores(Index i, StructureResult& r, const SurfaceDistanceStats& distances, bool final) const {
  const Loaded& L = *loaded_;
  r.assdFinalMm = distances.assd;
  r.hd95Mm = distances.hd95;
  if (final) r.dice = diceOfMesh(r.surface, *L.truthLabels[i].first, L.truthLabels[i].second, L.truthCount[i]);
}

std::vector<std::optional<SurfaceDistanceStats>> SceneRunner::sampledError(ExecutionBackend* backend) {
  Loaded& L = *loaded_;
  std::vector<std::optional<SurfaceDistanceStats>> error(L.sim->structureCount());
  if (!L.sampled) return error;
  try {
    if (backend && backend->measureError(*L.sampled, error)) return error;
  } catch (const std::runtime_error& e) {  // the device failed: the host has the same state
    if (options_.log) options_.log(std::string("error sampling on the device failed (") + e.what() + "); sampling on the host");
  }
  return L.sampled->measure(L.sim->store());
}

std::vector<double> SceneRunner::timelineDice() {
  Loaded& L = *loaded_;
  MeshStore& store = L.sim->store();
  std::vector<double> dice(store.meshCount(), std::nan(""));
  const auto x = store.positions();
  // Structures side by side; each one's rasterisation visits only the rows its surface crosses.
  L.sim->executor().forEach(
      store.meshCount(),
      [&](Index i) {
        if (!L.truth[i]) return;
        const auto local = store.mesh(x, i);
        dice[i] = diceOfMesh(tessellate(store.topologyOf(i), std::vector<Vec3>(local.begin(), local.end())),
                             *L.truthLabels[i].first, L.truthLabels[i].second, L.truthCount[i]);
      },
      1);
  return dice;
}

bool SceneRunner::hasGroundTruth(Index structure) const { return loaded_->truth[structure] != nullptr; }

LabelVolume SceneRunner::labelMap(const RunReport& report) const {
  LabelVolume out(loaded_->target->geometry(), 0);
  for (const StructureResult& s : report.structures)  // in order: a later structure's voxels win
    forEachInsideRun(s.surface, out.geometry(), [&](std::size_t first, std::size_t count) {
      std::fill_n(out.voxels().begin() + std::ptrdiff_t(first), count, s.label);
    });
  return out;
}

void addThickness(RunReport& report, const Executor& executor) {
  for (StructureResult& s : report.structures) {
    std::vector<float> radii = medialRadii(s.surface, executor);
    s.medialRadius = summariseRadii(radii);
    std::erase_if(s.surface.pointData, [](const PointArray& a) { return a.name == "medial_radius_mm"; });
    s.surface.pointData.push_back({"medial_radius_mm", std::move(radii)});
  }
}

}  // namespace sinew
