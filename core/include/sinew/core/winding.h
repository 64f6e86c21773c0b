// Inside or outside a closed surface, for include / exclude points (the attraction_points force):
// the solid angle one cell of the paper-000 Fig. 1b tessellation (its fan of triangles: vertex,
// successor, cell centre) subtends at a point (Van Oosterom and Strackee); summed over a closed
// structure's cells it is 4 pi inside and 0 outside. And the push that follows from the side.
// Inline and SINEW_HD, so the CPU force and the CUDA kernel decide alike.
#pragma once

#include "sinew/core/collision_bvh.h"  // SINEW_HD, P3

namespace sinew {

SINEW_HD float triangleSolidAngle(collision::P3 a, collision::P3 b, collision::P3 c) {
  using namespace collision;
  const float la = sqrtf(dot3(a, a)), lb = sqrtf(dot3(b, b)), lc = sqrtf(dot3(c, c));
  return 2.0f * atan2f(dot3(a, cross3(b, c)), la * lb * lc + dot3(a, b) * lc + dot3(b, c) * la + dot3(c, a) * lb);
}

// x: positions, centres: cell centres, offsets / cellVertices: the cells as MeshStore keeps them.
SINEW_HD float cellSolidAngle(const collision::P3* x, const collision::P3* centres, const int* offsets,
                              const int* cellVertices, int cell, collision::P3 p) {
  using namespace collision;
  const P3 centre = sub(centres[cell], p);
  const int begin = offsets[cell], end = offsets[cell + 1];
  float sum = 0.0f;
  for (int i = begin; i < end; ++i) {
    const int next = i + 1 < end ? i + 1 : begin;
    sum += triangleSolidAngle(sub(x[cellVertices[i]], p), sub(x[cellVertices[next]], p), centre);
  }
  return sum;
}

// The push of P0 along its normal for a point that must be inside (include) or outside: the
// point's side (inside: winding number above one half) and its distance to P0. Positive: outward.
SINEW_HD float constraintShift(bool include, bool inside, float distance, float margin) {
  if (include) return inside ? fmaxf(margin - distance, 0.0f) : distance + margin;
  return inside ? -(distance + margin) : fminf(distance - margin, 0.0f);
}

}  // namespace sinew
