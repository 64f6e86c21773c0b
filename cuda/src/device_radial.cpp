#include "device_radial.h"

#include <algorithm>

namespace sinew::cuda {

bool DeviceRadial::update(Simulation& sim, const ParamTable& params, const MeshView& view, bool jacobian,
                          cudaStream_t stream) {
  MeshStore& s = sim.store();
  const MedialOptions options{.spacingMm = params.getf(0, params.indexOf("spacing_mm")),
                              .neighbours = int(params.get(0, params.indexOf("neighbours")))};
  if (builtFor_ != s.vertexCount() || !(options == options_)) {
    medial_.assign(s.meshCount(), {});
    options_ = options;
    builtFor_ = s.vertexCount();
  }
  std::vector<int> fresh(s.meshCount(), 0);
  bool any = false;
  for (Index m = 0; m < s.meshCount(); ++m)
    if (params.getf(m, 0) > 0.0f && medial_[m].surfaceVertexCount() <= 0) {
      medial_[m] = buildMedialSurface(s.mesh(s.referencePositions(), m), s.mesh(s.referenceNormals(), m), options_,
                                      sim.executor());
      fresh[m] = 1;
      any = true;
    }
  if (any) upload(s, fresh, view, stream);
  if (jacobian && pull_.size() != std::size_t(view.vertices)) {
    pull_.resize(std::size_t(view.vertices));
    slack_.resize(std::size_t(view.vertices));
    direction_.resize(std::size_t(view.vertices));
    any = true;
  }
  return any;
}

void DeviceRadial::upload(const MeshStore& s, const std::vector<int>& fresh, const MeshView& view, cudaStream_t stream) {
  // The medial vertices kept from before, in the old layout (structures in order).
  std::vector<float3> kept(static_cast<std::size_t>(medialCount_));
  q_.download(kept.data(), kept.size(), stream);
  SINEW_CUDA(cudaStreamSynchronize(stream));
  std::vector<int> surfaceOffsets{0}, surfaceMedial, medialMesh, medialOffsets{0}, medialVertex;
  std::vector<float> surfaceWeight, radius(std::size_t(s.vertexCount()), 0.0f), medialWeight;
  std::vector<float3> q;
  std::size_t keptAt = 0;
  for (Index m = 0; m < s.meshCount(); ++m) {
    const MedialSurface& ms = medial_[m];
    const Index begin = s.range(m).vertexBegin, n = s.range(m).vertexCount();
    const int medialBegin = int(q.size());
    const bool built = ms.surfaceVertexCount() > 0;
    for (Index i = 0; i < n; ++i) {
      if (built) {
        for (Index k = ms.offsets[i]; k < ms.offsets[i + 1]; ++k) {
          surfaceMedial.push_back(medialBegin + int(ms.medial[k]));
          surfaceWeight.push_back(ms.weights[k]);
        }
        radius[begin + i] = ms.vertexRadius[i];
      }
      surfaceOffsets.push_back(int(surfaceMedial.size()));
    }
    if (!built) continue;
    const MedialVoters voters = votersOf(ms);  // in vertex order, as the CPU force's
    for (std::size_t j = 0; j < ms.vertices.size(); ++j) {
      for (Index k = voters.offsets[j]; k < voters.offsets[j + 1]; ++k) {
        medialVertex.push_back(int(begin + voters.vertex[k]));
        medialWeight.push_back(voters.weight[k]);
      }
      medialOffsets.push_back(int(medialVertex.size()));
      medialMesh.push_back(int(m));
      const Vec3& reference = ms.vertices[j];
      q.push_back(fresh[m] ? make_float3(reference.x(), reference.y(), reference.z()) : kept[keptAt++]);
    }
  }
  // Each medial vertex's voters in chunks of at most kRadialChunk (one, empty, where it has none).
  std::vector<int> chunkBegin, chunkRow, rowChunks{0};
  for (std::size_t j = 0; j + 1 < medialOffsets.size(); ++j) {
    int e = medialOffsets[j];
    do {
      chunkBegin.push_back(e);
      chunkRow.push_back(int(j));
      e = std::min(e + kRadialChunk, medialOffsets[j + 1]);
    } while (e < medialOffsets[j + 1]);
    rowChunks.push_back(int(chunkRow.size()));
  }
  chunkBegin.push_back(int(medialVertex.size()));
  chunkBegin_.upload(chunkBegin, stream);
  chunkRow_.upload(chunkRow, stream);
  rowChunks_.upload(rowChunks, stream);
  partial_.resize(chunkRow.size());
  arrivals_.upload(std::vector<unsigned>(q.size(), 0u), stream);
  surfaceOffsets_.upload(surfaceOffsets, stream);
  surfaceMedial_.upload(surfaceMedial, stream);
  surfaceWeight_.upload(surfaceWeight, stream);
  radius_.upload(radius, stream);
  medialMesh_.upload(medialMesh, stream);
  medialOffsets_.upload(medialOffsets, stream);
  medialVertex_.upload(medialVertex, stream);
  medialWeight_.upload(medialWeight, stream);
  q_.upload(q, stream);
  scratch_.resize(q.size());
  medialCount_ = int(q.size());
  // The fresh structures' medial vertices start from the votes of the surface as it is now.
  DeviceArray<int> freshOnDevice;
  freshOnDevice.upload(fresh, stream);
  launchGeometry(view, nullptr, stream);  // once, when the medial vertices are placed
  launchRadialVotes(view, device(), freshOnDevice.get(), q_.get(), stream);
  SINEW_CUDA(cudaGetLastError());
  SINEW_CUDA(cudaStreamSynchronize(stream));
}

void DeviceRadial::launch(const MeshView& view, ParamView p, int iterations, cudaStream_t stream) const {
  if (medialCount_ == 0) return;
  const bool jacobian = pull_.size() == std::size_t(view.vertices);
  const RadialDevice r = device();
  float3* from = q_.get();
  float3* to = scratch_.get();
  for (int it = 0; it < iterations; ++it) {
    launchRadialRelax(view, p, r, from, to, stream);
    std::swap(from, to);
  }
  // An odd count leaves the result in the scratch buffer: copied home, so that every replay of a
  // captured graph starts from q_.
  launchRadialApply(view, p, r, from, from == q_.get() ? nullptr : q_.get(), jacobian ? pull_.get() : nullptr, slack_.get(),
                    direction_.get(), stream);
}

void DeviceRadial::addTerms(ImplicitTerms& terms) const {
  if (medialCount_ == 0 || !pull_.size()) return;  // the force does not act, or explicit steps
  terms.radialPull = pull_.get();
  terms.radialSlack = slack_.get();
  terms.radialDirection = direction_.get();
}

RadialDevice DeviceRadial::device() const {
  RadialDevice r;
  r.surfaceOffsets = surfaceOffsets_.get();
  r.surfaceMedial = surfaceMedial_.get();
  r.surfaceWeight = surfaceWeight_.get();
  r.radius = radius_.get();
  r.medialMesh = medialMesh_.get();
  r.medialOffsets = medialOffsets_.get();
  r.medialVertex = medialVertex_.get();
  r.medialWeight = medialWeight_.get();
  r.chunkBegin = chunkBegin_.get();
  r.chunkRow = chunkRow_.get();
  r.rowChunks = rowChunks_.get();
  r.partial = partial_.get();
  r.arrivals = arrivals_.get();
  r.medialCount = medialCount_;
  r.chunkCount = int(chunkRow_.size());
  return r;
}

std::size_t DeviceRadial::bytes() const {
  return surfaceOffsets_.bytes() + surfaceMedial_.bytes() + surfaceWeight_.bytes() + radius_.bytes() + medialMesh_.bytes() +
         medialOffsets_.bytes() + medialVertex_.bytes() + medialWeight_.bytes() + chunkBegin_.bytes() + chunkRow_.bytes() +
         rowChunks_.bytes() + partial_.bytes() + arrivals_.bytes() + q_.bytes() + scratch_.bytes() + pull_.bytes() +
         slack_.bytes() + direction_.bytes();
}

}  // namespace sinew::cuda
