// float3 arithmetic written in the same operation order as the Eigen expressions of the CPU
// kernels (no fused multiply-add: the library is compiled with --fmad=false), so both backends
// round identically.
#pragma once

#include "kernels.h"

namespace sinew::cuda {

__device__ __forceinline__ float3 operator+(float3 a, float3 b) { return make_float3(a.x + b.x, a.y + b.y, a.z + b.z); }
__device__ __forceinline__ float3 operator-(float3 a, float3 b) { return make_float3(a.x - b.x, a.y - b.y, a.z - b.z); }
__device__ __forceinline__ float3 operator*(float s, float3 a) { return make_float3(s * a.x, s * a.y, s * a.z); }
__device__ __forceinline__ float3 operator/(float3 a, float s) { return make_float3(a.x / s, a.y / s, a.z / s); }
// Eigen reduces a 3-vector as x0 + (x1 + x2) (its unroller halves the range).
__device__ __forceinline__ float sum3(float a, float b, float c) { return a + (b + c); }
__device__ __forceinline__ float dot(float3 a, float3 b) { return sum3(a.x * b.x, a.y * b.y, a.z * b.z); }
__device__ __forceinline__ float squaredNorm(float3 a) { return sum3(a.x * a.x, a.y * a.y, a.z * a.z); }
__device__ __forceinline__ float norm(float3 a) { return sqrtf(squaredNorm(a)); }
__device__ __forceinline__ float3 cross(float3 a, float3 b) {
  return make_float3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

// sinew::neighbourFrame
struct Frame {
  float3 normal, centre;
  float radius, twiceArea;
};
__device__ __forceinline__ Frame neighbourFrame(float3 p1, float3 p2, float3 p3) {
  Frame f{make_float3(0, 0, 0), make_float3(0, 0, 0), 0.0f, 0.0f};
  const float3 a = p1 - p3, b = p2 - p3;
  const float3 axb = cross(a, b);
  const float axb2 = squaredNorm(axb);
  f.twiceArea = sqrtf(axb2);
  if (!(f.twiceArea > 1e-20f)) {
    f.twiceArea = 0.0f;
    return f;
  }
  f.normal = axb / f.twiceArea;
  f.centre = p3 + cross(squaredNorm(a) * b - squaredNorm(b) * a, axb) / (2.0f * axb2);
  f.radius = norm(p1 - f.centre);
  return f;
}
// neighbourFrame(p1, p2, p3).normal alone.
__device__ __forceinline__ float3 neighbourNormal(float3 p1, float3 p2, float3 p3) {
  const float3 axb = cross(p1 - p3, p2 - p3);
  const float twiceArea = sqrtf(squaredNorm(axb));
  return twiceArea > 1e-20f ? axb / twiceArea : make_float3(0, 0, 0);
}

// sinew::elevationFromSinCos
__device__ __forceinline__ float elevationFromSinCos(float r, float d2, float s, float c, float hint) {
  const float k = r * r - d2;
  const float root = sqrtf(fmaxf(r * r * c * c + k * s * s, 0.0f));
  const float den = root + r * c;
  float L = fabsf(den) < 1e-12f * (r + 1e-30f) ? 0.0f : k * s / den;
  if (k < 0.0f && L != 0.0f) {
    const float other = -k / L;
    if (fabsf(other - hint) < fabsf(L - hint)) L = other;
  }
  return L;
}

__device__ __forceinline__ float param(const ParamView& p, int mesh, int k) { return p.values[mesh * p.count + k]; }

// Damped Verlet (plugins/integrators/damped_verlet): the position after `current` under force f,
// x + keep (x - prev) + dt^2 / m f. keep: 1 - damping.
__device__ __forceinline__ float3 verletStep(float3 current, float3 previous, float3 f, float dt, float keep, float mass) {
  return current + keep * (current - previous) + (dt * dt / mass) * f;
}
// Vertex v's move: x as above, prev = the old x.
__device__ __forceinline__ void verletMove(const MeshView& m, int v, float3 f, float dt, float keep) {
  const float3 current = m.x[v];
  m.x[v] = verletStep(current, m.prev[v], f, dt, keep, m.mass[v]);
  m.prev[v] = current;
}
// The same move with the new position written over prev[v] and x left as it was, for a pass in
// which other vertices' forces still read x; the caller swaps x and prev after it.
// mass: v's mass, when the caller has it (m.mass[v] otherwise).
__device__ __forceinline__ void verletMoveAside(const MeshView& m, int v, float3 f, float dt, float keep, float mass) {
  const float3 current = m.x[v];
  m.prev[v] = verletStep(current, m.prev[v], f, dt, keep, mass);
}
__device__ __forceinline__ void verletMoveAside(const MeshView& m, int v, float3 f, float dt, float keep) {
  verletMoveAside(m, v, f, dt, keep, m.mass[v]);
}
// A vertex of structure `mesh` and this area: its mass as MeshStore computes it (the area times the
// structure's density, at least its floor).
__device__ __forceinline__ float massFromArea(const MeshView& m, int mesh, float area) {
  const float mass = area * m.density[mesh];
  return m.massFloor && m.massFloor[mesh] > mass ? m.massFloor[mesh] : mass;  // as std::max on the host
}

// sinew::Volume<T>::sample with T = float or float3: border voxels extend outside.
__device__ __forceinline__ float lerp(float a, float b, float t) { return a + (b - a) * t; }
__device__ __forceinline__ float3 lerp(float3 a, float3 b, float t) { return a + t * (b - a); }

// The voxel cell around world point p: corner indices i0, i1 and fractions f per axis.
struct VolumeCell {
  int i0[3], i1[3];
  float f[3];
};
__device__ __forceinline__ VolumeCell cellAt(const VolumeView& v, float3 p) {
  const float3 q = p - v.origin;
  const float idx[3] = {sum3(v.m[0] * q.x, v.m[1] * q.y, v.m[2] * q.z), sum3(v.m[3] * q.x, v.m[4] * q.y, v.m[5] * q.z),
                        sum3(v.m[6] * q.x, v.m[7] * q.y, v.m[8] * q.z)};
  const int size[3] = {v.sx, v.sy, v.sz};
  VolumeCell c;
#pragma unroll
  for (int a = 0; a < 3; ++a) {
    const float x = fminf(fmaxf(idx[a], 0.0f), static_cast<float>(size[a] - 1));
    c.i0[a] = min(static_cast<int>(x), max(size[a] - 2, 0));
    c.f[a] = x - static_cast<float>(c.i0[a]);
    c.i1[a] = min(c.i0[a] + 1, size[a] - 1);
  }
  return c;
}

template <class T>
__device__ __forceinline__ T sampleVolume(const VolumeView& v, const T* __restrict__ data, float3 p) {
  const VolumeCell c = cellAt(v, p);
  const int *i0 = c.i0, *i1 = c.i1;
  const float* f = c.f;
  auto at = [&](int i, int j, int k) { return data[(static_cast<size_t>(k) * v.sy + j) * v.sx + i]; };
  const T c00 = lerp(at(i0[0], i0[1], i0[2]), at(i1[0], i0[1], i0[2]), f[0]);
  const T c10 = lerp(at(i0[0], i1[1], i0[2]), at(i1[0], i1[1], i0[2]), f[0]);
  const T c01 = lerp(at(i0[0], i0[1], i1[2]), at(i1[0], i0[1], i1[2]), f[0]);
  const T c11 = lerp(at(i0[0], i1[1], i1[2]), at(i1[0], i1[1], i1[2]), f[0]);
  return lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2]);
}

}  // namespace sinew::cuda
