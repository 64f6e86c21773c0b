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
};

#if defined(__CUDACC__)
// Vertex i's force from its contact plane (respondTo's arithmetic, as the CPU's plugin), and its
// hold plane (none: side 3e38); writes its depth (where the force is on for its structure),
// stiffness and, where it has a contact plane, its hold plane (a vertex without one keeps the none
// and the depth 0 that the last full search wrote: most vertices, which read only their share, so
// that large scenes save the traffic). Reads m.x (the triangle's corners: nothing may move them in
// the same pass), m.prev[i], m.normal[i], m.mass[i] (with m.mass null, the mass from m.area[i],
// as the lean geometry's passes do) and m.cellCentre. `touching`: hasContactPlane(c, i), which a
// pass can read early, so that its round trip is not on the pass's last stretch.
__device__ inline bool hasContactPlane(const ContactPlanes& c, int i) { return c.share[i] >= 0.0f; }
__device__ inline float3 contactPlaneForce(const MeshView& m, const ContactPlanes& c, int i, bool touching,
                                           collision::HoldPlane& plane) {
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
  return make_float3(force.x, force.y, force.z);
}
#endif

}  // namespace sinew::cuda
