// The radial force on the device (plugins/forces/radial is the CPU force it mirrors;
// docs/medial.md): each active structure's medial surface, built on the host from its reference
// shape as the CPU force builds it, laid out for the kernels of radial_kernels.cu, and the medial
// vertices Q_j, which live on the device from step to step. Host C++ only.
#pragma once

#include "cuda_check.h"
#include "kernels.h"
#include "sinew/core/medial_axis.h"
#include "sinew/core/simulation.h"

namespace sinew::cuda {

class DeviceRadial {
public:
  // Before a capture: builds the medial surface of every structure whose weight is now positive and
  // that has none yet (all of them again at a new level, or when spacing_mm or neighbours changed),
  // and starts their medial vertices where the surface's votes put them (positions and normals of
  // now, as the CPU force's first evaluation). `view` must be the engine's bound store; `jacobian`:
  // implicit Euler will want the force's Jacobian terms. True when the device arrays changed
  // (captured graphs are stale).
  bool update(Simulation& sim, const ParamTable& params, const MeshView& view, bool jacobian, cudaStream_t stream);
  // Relaxes the medial vertices `iterations` times and adds the force (alpha from p), writing the
  // per-vertex Jacobian terms too when update() was asked for them.
  void launch(const MeshView& view, ParamView p, int iterations, cudaStream_t stream) const;
  // The Jacobian terms of the last launch for implicit Euler's solve.
  void addTerms(ImplicitTerms& terms) const;
  std::size_t bytes() const;

private:
  void upload(const MeshStore& store, const std::vector<int>& fresh, const MeshView& view, cudaStream_t stream);
  RadialDevice device() const;

  std::vector<MedialSurface> medial_;  // per structure; empty surface: not built
  MedialOptions options_;
  Index builtFor_ = -1;  // the store's vertex count when built (a level change resets)
  // Surface side, per global vertex: its medial vertices (global) and weights, and r_i.
  DeviceArray<int> surfaceOffsets_, surfaceMedial_;
  DeviceArray<float> surfaceWeight_, radius_;
  // Medial side, per global medial vertex: its structure, its surface vertices (global) and weights.
  DeviceArray<int> medialMesh_, medialOffsets_, medialVertex_;
  DeviceArray<float> medialWeight_;
  // The relaxation's chunks (kernels.h: RadialDevice) and its scratch.
  DeviceArray<int> chunkBegin_, chunkRow_, rowChunks_;
  DeviceArray<float4> partial_;
  DeviceArray<unsigned> arrivals_;
  DeviceArray<float3> q_, scratch_;  // Q_j now, and the relaxation's other buffer
  DeviceArray<float> pull_, slack_;   // implicit Euler: per vertex (ImplicitTerms)
  DeviceArray<float3> direction_;
  int medialCount_ = 0;
};

}  // namespace sinew::cuda
