// The per-vertex force terms of the fused pass (force_kernels.cu), shared with the profile kernel,
// which takes them into its own pass when it also moves the vertices (profile_kernels.cu). Each is a
// line-for-line mirror of its CPU plugin (plugins/forces/*).
#pragma once

#include "device_math.cuh"

namespace sinew::cuda {

// The smoothing term from what it reads: v's position xv and normal, its neighbours' positions x,
// areas a and elevations e, and the structure's elevation_term weight (the one-pass step reads
// them from shared memory).
__device__ __forceinline__ float3 smoothingFrom(float3 xv, float3 normal, const float3 (&x)[3], const float (&a)[3],
                                                const float (&e)[3], float elevationTerm, float alpha) {
  const float total = a[0] + a[1] + a[2];
  const float3 centre = total > 0.0f ? (a[0] * x[0] + a[1] * x[1] + a[2] * x[2]) / total : (x[0] + x[1] + x[2]) / 3.0f;
  const float lift = elevationTerm * (e[0] + e[1] + e[2]) / 3.0f;
  return alpha * (centre + lift * normal - xv);
}

// Per-vertex force terms; each returns what its CPU plugin adds to forces[v] (alpha included).
// n: v's neighbours (m.neighbours[v]), loaded by the caller. kOwnNormal: v's normal from its
// neighbours, as the geometry pass computes it, instead of m.normal (the lean geometry).
template <bool kOwnNormal = false>
__device__ __forceinline__ float3 smoothingTerm(const MeshView& m, const ParamView& p, int kElevation, int v, int3 n,
                                                float alpha) {
  const int mesh = m.meshOf[v];
  const float a[3] = {m.area[n.x], m.area[n.y], m.area[n.z]};
  const float3 x[3] = {m.x[n.x], m.x[n.y], m.x[n.z]};
  const float e[3] = {m.elevation[n.x], m.elevation[n.y], m.elevation[n.z]};
  const float3 normal = kOwnNormal ? neighbourNormal(x[0], x[1], x[2]) : m.normal[v];
  return smoothingFrom(m.x[v], normal, x, a, e, param(p, mesh, kElevation), alpha);
}

// sinew::limitedPriorPull: the pull held to kPriorReach (4) times the neighbours' longest edge
// (16: kPriorReach squared; core's header is not included in device code).
__device__ __forceinline__ float3 limitedPriorPull(float3 pull, float3 p1, float3 p2, float3 p3) {
  const float longest2 = fmaxf(fmaxf(squaredNorm(p1 - p2), squaredNorm(p2 - p3)), squaredNorm(p3 - p1));
  const float limit2 = 16.0f * longest2;
  const float pull2 = squaredNorm(pull);
  return pull2 > limit2 ? sqrtf(limit2 / pull2) * pull : pull;
}

// The shape prior's term from v's position x, its neighbours' p1..p3 and its reference r.
__device__ __forceinline__ float3 shapePriorFrom(float3 x, float3 p1, float3 p2, float3 p3, float4 r, float alpha) {
  const Frame f = neighbourFrame(p1, p2, p3);
  const float eps3 = 1.0f - r.x - r.y;
  const float3 foot = r.x * p1 + r.y * p2 + eps3 * p3;
  float3 target = foot;
  if (f.twiceArea > 0.0f) {
    const float d2 = squaredNorm(foot - f.centre);
    target = foot + elevationFromSinCos(f.radius, d2, r.z, r.w, dot(x - p1, f.normal)) * f.normal;
  }
  return alpha * limitedPriorPull(target - x, p1, p2, p3);
}
__device__ __forceinline__ float3 shapePriorTerm(const MeshView& m, const float4* __restrict__ ref, int v, int3 n,
                                                 float alpha) {
  return shapePriorFrom(m.x[v], m.x[n.x], m.x[n.y], m.x[n.z], ref[v], alpha);
}

__device__ __forceinline__ float3 gradientTerm(const MeshView& m, const ParamView& p, int kEps, int kDepth, int kStep,
                                               const VolumeView& vol, const float3* __restrict__ grad, int v,
                                               float alpha) {
  const int mesh = m.meshOf[v];
  const float eps = param(p, mesh, kEps), step = param(p, mesh, kStep);
  const int reach = static_cast<int>(floorf(param(p, mesh, kDepth) / step));
  const float3 n = m.normal[v], x = m.x[v];
  float best = 3.402823466e+38f;
  int bestJ = 0;
  for (int j = -reach; j <= reach; ++j) {
    const float e = eps * dot(sampleVolume(vol, grad, x + (static_cast<float>(j) * step) * n), n);
    if (e < best || (e == best && abs(j) < abs(bestJ))) {
      best = e;
      bestJ = j;
    }
  }
  return (alpha * (static_cast<float>(bestJ) * step)) * n;
}

// The fused terms' sum at v, in the scene's order (the CPU's order of additions). kOwnNormal: as
// smoothingTerm's (no gradient term then). kWeightsFirst:
// every term's weight (and v's neighbours) is read before the first term, so that a term's loads do
// not wait for its weight (fusedForces: smoothing + shape prior 240.0 -> 233.4 us a step at 2.7 M
// vertices on an H100). The profile pass, at its register limit, spilled with it (42,496 vertices
// 20.3-20.4 -> 20.4-20.5 us) and reads each weight in turn (docs/benchmarks.md).
template <bool kWithGradient, bool kWeightsFirst, bool kOwnNormal = false>
__device__ __forceinline__ float3 fusedSum(const MeshView& m, const FusedTerms& t, int v) {
  static_assert(!(kWithGradient && kOwnNormal), "the gradient term reads m.normal");
  const int mesh = m.meshOf[v];
  const int3 early = kWeightsFirst ? m.neighbours[v] : make_int3(0, 0, 0);  // with the weights
  const auto add = [&](float3& f, const FusedTerm& term, float alpha) {
    const int3 n = kWeightsFirst ? early : m.neighbours[v];
    switch (term.kind) {
      case FusedTerm::Smoothing: f = f + smoothingTerm<kOwnNormal>(m, term.params, term.k0, v, n, alpha); break;
      case FusedTerm::ShapePrior: f = f + shapePriorTerm(m, t.reference, v, n, alpha); break;
      case FusedTerm::Gradient:
        if constexpr (kWithGradient)
          f = f + gradientTerm(m, term.params, term.k0, term.k1, term.k2, t.gradientVolume, t.gradient, v, alpha);
        break;
    }
  };
  float3 f = make_float3(0, 0, 0);
  if constexpr (kWeightsFirst) {
    constexpr int kMaxTerms = sizeof(t.terms) / sizeof(t.terms[0]);
    float weight[kMaxTerms];
#pragma unroll
    for (int i = 0; i < kMaxTerms; ++i) weight[i] = i < t.count ? param(t.terms[i].params, mesh, 0) : 0.0f;
#pragma unroll
    for (int i = 0; i < kMaxTerms; ++i)
      if (weight[i] > 0.0f) add(f, t.terms[i], weight[i]);
  } else {
    for (int i = 0; i < t.count; ++i) {
      const float alpha = param(t.terms[i].params, mesh, 0);
      if (alpha > 0.0f) add(f, t.terms[i], alpha);
    }
  }
  return f;
}

}  // namespace sinew::cuda
