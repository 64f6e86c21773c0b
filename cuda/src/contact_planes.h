// The collision force between full searches (collision::contactResponse's branch for them): each
// vertex meets the plane of its deepest contact at the last full search, through that contact's
// point on the other surface as it is now. As a per-vertex force that two kernels share: the
// collision's own planes kernel (collision_kernels.cu) and the profile's passes, which add it after
// the profile's term where the collision is the step's last force (launchProfileAfterTerms,
// launchProfileFirst).
// Host C++ fills the struct (DeviceCollision::contactPlanes); the device function is CUDA only.
#pragma once

#include "kernels.h"
#include "sinew/core/collision_bvh.h"
#if defined(__CUDACC__)
#include "device_math.cuh"  // massFromArea
#endif

namespace sinew::cuda {

struct ContactPlanes {
  ParamView params;  // the collision force's (its weight: column 0)
  collision::ContactSettings settings;
  const collision::ContactPlane* contact = nullptr;  // per vertex, from the last full search; valid where share >= 0
  const float* share = nullptr;  // per vertex, contact's share alone (< 0: none), read first
  float* depth = nullptr;                 // written: the plane's penetration (the next full search's radius)
  float* stiffness = nullptr;             // written where not null: the pull (implicit Euler's Jacobian)
  collision::HoldPlane* hold = nullptr;   // written where not null: the plane the hold moves the vertex out of
  // The profile's pass holds the vertices itself (settings.hold >= 0, hold null): every vertex's
  // previous position after the hold goes here, a third position buffer, since the pass may not
  // write x, which other vertices read (launchProfileAfterTerms).
  float3* heldPrevious = nullptr;
  // The reaction's sums (ReactionSums), taken by every vertex with its force; null: none here.
  unsigned long long* reaction = nullptr;
};

// The collision's reaction (collision::reactionPush; CollisionForce::addReaction on the CPU): each
// vertex with a contact plane pushes that contact's triangle, its pushes times part times weight
// summed per vertex in fixed point, 2^-32 of a unit: integer sums do not depend on the order the
// atomics land in, so a run repeats itself (float atomics would not). Far below a float's rounding
// of the forces; the range, 2^31, far above them. Each vertex has kReactionStride words: its three
// sums and a flag that says it was pushed, which a pass reads alone, early (one register), so that
// only the few pushed vertices load their sums. Whoever adds a vertex's force takes its sums (times
// its mass) and sets them and the flag back to 0 (takeReaction).
struct ReactionSums {
  ParamView params;  // the collision force's (its weights: column 0)
  collision::ContactSettings settings;
  const collision::ContactPlane* contact = nullptr;  // per vertex (valid where share >= 0)
  const float* share = nullptr;                      // per vertex, the contact's share (< 0: none)
  unsigned long long* sums = nullptr;                // kReactionStride per vertex
};
constexpr int kReactionStride = 4;

#if defined(__CUDACC__)
// The reaction's sums (ReactionSums): one added in fixed point, with the vertex's flag, and taken.
constexpr double kReactionScale = 4294967296.0;
__device__ inline void addReactionTo(unsigned long long* sums, int u, float x, float y, float z) {
  unsigned long long* s = sums + kReactionStride * u;
  atomicAdd(s, static_cast<unsigned long long>(__double2ll_rn(static_cast<double>(x) * kReactionScale)));
  atomicAdd(s + 1, static_cast<unsigned long long>(__double2ll_rn(static_cast<double>(y) * kReactionScale)));
  atomicAdd(s + 2, static_cast<unsigned long long>(__double2ll_rn(static_cast<double>(z) * kReactionScale)));
  s[3] = 1;  // pushed (any order of these stores: all write 1)
}
// Vertex i's flag (its low word), loaded ahead of the take.
__device__ inline unsigned reactionPushed(const unsigned long long* sums, int i) {
  return reinterpret_cast<const unsigned*>(sums + kReactionStride * i + 3)[0];
}
// Vertex i's sums s0..s2 as a force (times its mass, as the CPU's), set back to 0 with its flag for
// the next step.
__device__ inline float3 takeSums(const MeshView& m, unsigned long long* sums, int i, unsigned long long s0,
                                  unsigned long long s1, unsigned long long s2) {
  const unsigned long long sum[3] = {s0, s1, s2};
  float f[3];
  for (int k = 0; k < 3; ++k)
    f[k] = static_cast<float>(static_cast<double>(static_cast<long long>(sum[k])) / kReactionScale);
  reinterpret_cast<ulonglong2*>(sums + kReactionStride * i)[0] = make_ulonglong2(0, 0);
  reinterpret_cast<ulonglong2*>(sums + kReactionStride * i)[1] = make_ulonglong2(0, 0);
  const float mass = m.mass ? m.mass[i] : massFromArea(m, m.meshOf[i], m.area[i]);
  return make_float3(f[0] * mass, f[1] * mass, f[2] * mass);
}
// Vertex i's reaction where its flag (reactionPushed, loaded before) says it was pushed; 0 (no
// loads) where not: most vertices are pushed by nothing.
__device__ inline float3 takeReaction(const MeshView& m, unsigned long long* sums, int i, unsigned pushed) {
  if (!pushed) return make_float3(0.0f, 0.0f, 0.0f);
  const unsigned long long* s = sums + kReactionStride * i;
  return takeSums(m, sums, i, s[0], s[1], s[2]);
}
// The same with the flag and the sums loaded at once (a vertex's 32 bytes, two 16-byte loads).
__device__ inline float3 takeReaction(const MeshView& m, unsigned long long* sums, int i) {
  const ulonglong2* s = reinterpret_cast<const ulonglong2*>(sums + kReactionStride * i);
  const ulonglong2 a = s[0], b = s[1];
  return b.y ? takeSums(m, sums, i, a.x, a.y, b.x) : make_float3(0.0f, 0.0f, 0.0f);
}

// Vertex i's force from its contact plane (respondTo's arithmetic, as the CPU's plugin), and its
// hold plane (none: side 3e38); writes its depth (where the force is on for its structure),
// stiffness and, where it has a contact plane, its hold plane (a vertex without one keeps the none
// and the depth 0 that the last full search wrote: most vertices, which read only their share, so
// that large scenes save the traffic). Reads m.x (the triangle's corners: nothing may move them in
// the same pass), m.prev[i], m.normal[i], m.mass[i] (with m.mass null, the mass from m.area[i],
// as the lean geometry's passes do) and m.cellCentre. `touching`: hasContactPlane(c, i), which a
// pass can read early, so that its round trip is not on the pass's last stretch. With c.reaction,
// the vertex's reaction is added too where `pushed` (reactionPushed, read early as well) says so,
// touching or not.
__device__ inline bool hasContactPlane(const ContactPlanes& c, int i) { return c.share[i] >= 0.0f; }
__device__ inline float3 contactPlaneForce(const MeshView& m, const ContactPlanes& c, int i, bool touching,
                                           collision::HoldPlane& plane, unsigned pushed) {
  const float weight = c.params.values[m.meshOf[i] * c.params.count];
  collision::P3 force{0, 0, 0};
  float k = 0.0f;
  plane = collision::HoldPlane{};
  if (weight > 0.0f && touching) {  // (its weight may have changed since the plane was found: then no hold)
    const collision::ContactPlane contact = c.contact[i];
    const float mass = m.mass ? m.mass[i] : massFromArea(m, m.meshOf[i], m.area[i]);
    const auto* x = reinterpret_cast<const collision::P3*>(m.x);
    const collision::P3 point = x[i];
    float deepest = 0.0f;
    k = collision::respondTo(collision::contactHit(contact, point, x, reinterpret_cast<const collision::P3*>(m.cellCentre)),
                             point, reinterpret_cast<const collision::P3*>(m.prev)[i],
                             reinterpret_cast<const collision::P3*>(m.normal)[i], weight * mass, c.settings, deepest, force,
                             &plane, contact.share);  // (a local: written out only with a hold)
    c.depth[i] = deepest;
  }
  if (c.stiffness) c.stiffness[i] = k;
  if (c.hold && touching) c.hold[i] = plane;
  const float3 f = make_float3(force.x, force.y, force.z);
  return c.reaction ? f + takeReaction(m, c.reaction, i, pushed) : f;
}
#endif

}  // namespace sinew::cuda
