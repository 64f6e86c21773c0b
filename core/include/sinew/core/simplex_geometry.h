// Local geometry of a 2-simplex vertex from its three neighbours (Delingette 1999): normal,
// circumcircle, elevation and the simplex parameters (two metric parameters eps1, eps2 with
// eps3 = 1 - eps1 - eps2, and the simplex angle phi), all invariant under similarity except the
// elevation. Templated on the scalar so the engine runs it in float (as the GPU does) and tests
// can check the formulas in double; the CUDA kernels mirror it line for line.
#pragma once

#include "sinew/core/types.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace sinew {

template <class S>
struct SimplexParamsT {
  S eps1 = S(1) / S(3);
  S eps2 = S(1) / S(3);
  S phi = S(0);
  S eps3() const { return S(1) - eps1 - eps2; }
};
using SimplexParams = SimplexParamsT<float>;

// The neighbours' triangle: outward normal, circumcentre and circumradius.
template <class S>
struct NeighbourFrameT {
  using V = Eigen::Matrix<S, 3, 1>;
  V normal = V::Zero();
  V circumCentre = V::Zero();
  S circumRadius = S(0);
  S twiceArea = S(0);  // |(p2 - p1) x (p3 - p1)|; 0 when the neighbours are collinear
  bool valid() const { return twiceArea > S(0); }
};
using NeighbourFrame = NeighbourFrameT<float>;

template <class V>
NeighbourFrameT<typename V::Scalar> neighbourFrame(const V& p1, const V& p2, const V& p3) {
  using S = typename V::Scalar;
  NeighbourFrameT<S> f;
  const V a = p1 - p3, b = p2 - p3;
  const V axb = a.cross(b);
  const S axb2 = axb.squaredNorm();
  f.twiceArea = std::sqrt(axb2);
  if (!(f.twiceArea > S(1e-20))) {
    f.twiceArea = S(0);
    return f;
  }
  f.normal = axb / f.twiceArea;  // (p1-p3)x(p2-p3) == (p2-p1)x(p3-p1)
  f.circumCentre = p3 + (a.squaredNorm() * b - b.squaredNorm() * a).cross(axb) / (S(2) * axb2);
  f.circumRadius = (p1 - f.circumCentre).norm();
  return f;
}

// Signed distance from p to the neighbours' plane, positive along the outward normal.
template <class V>
typename V::Scalar elevation(const V& p, const V& p1, const NeighbourFrameT<typename V::Scalar>& f) {
  return (p - p1).dot(f.normal);
}

template <class V>
SimplexParamsT<typename V::Scalar> simplexParams(const V& p, const V& p1, const V& p2, const V& p3,
                                                 const NeighbourFrameT<typename V::Scalar>& f) {
  using S = typename V::Scalar;
  SimplexParamsT<S> s;
  if (!f.valid()) return s;
  const S L = elevation(p, p1, f);
  const V foot = p - L * f.normal;
  const S inv = S(1) / f.twiceArea;
  s.eps1 = (p2 - foot).cross(p3 - foot).dot(f.normal) * inv;
  s.eps2 = (p3 - foot).cross(p1 - foot).dot(f.normal) * inv;
  const S r = f.circumRadius;
  const S d2 = (foot - f.circumCentre).squaredNorm();
  // tan(phi) = 2 L r / (r^2 - d^2 - L^2): the angle of the sphere through p and its neighbours.
  s.phi = std::atan2(S(2) * L * r, r * r - d2 - L * L);
  return s;
}

// Reference parameters the shape prior can follow. Where the reference shape is folded at a
// vertex, its foot point lies far outside the neighbours' triangle (a barycentric coordinate beyond
// +-2; a healthy vertex keeps them within about [-1, 1]) or its angle is a spike (beyond 150
// degrees): the target then swings with any small change of the neighbours, and on new subjects
// such a vertex of Lingual_L ended 15 mm from its neighbours, its long triangles crossing the
// structure beside it (docs/accuracy.md). Such a vertex takes neutral parameters instead (its
// neighbours' centroid, flat): smoothing there, the reference everywhere else. 1 to 16 vertices
// in each atlas model of 10-12 regions measured (docs/stability.md).
template <class S>
bool isFoldedReference(const SimplexParamsT<S>& s) {
  constexpr S kMaxEps = S(2), kMaxPhi = S(2.618);  // 150 degrees
  return std::fabs(s.eps1) > kMaxEps || std::fabs(s.eps2) > kMaxEps || std::fabs(s.eps3()) > kMaxEps ||
         std::fabs(s.phi) > kMaxPhi;
}
template <class S>
SimplexParamsT<S> followableReference(const SimplexParamsT<S>& s) {
  return isFoldedReference(s) ? SimplexParamsT<S>{} : s;
}

// Elevation L(r, d, phi) of Delingette's equation, written with sin/cos so it has no branch:
// L = (r^2 - d^2) sin(phi) / (sqrt(r^2 cos^2(phi) + (r^2 - d^2) sin^2(phi)) + r cos(phi)).
// tan(phi) = 2 L r / (r^2 - d^2 - L^2) has two roots in L with product -(r^2 - d^2). When the foot
// point lies inside the circumcircle (r^2 - d^2 > 0) they have opposite signs and only the formula's
// root matches phi. Outside it both have the sign of phi and the angle cannot tell them apart; the
// root nearer `hint` (the vertex's current elevation) is taken, which keeps the shape prior
// continuous and makes the parameters an exact inverse for any configuration when hint is the
// original elevation.
template <class S>
S elevationFromSinCos(S r, S d2, S s, S c, S hint) {
  const S k = r * r - d2;
  const S root = std::sqrt(std::fmax(r * r * c * c + k * s * s, S(0)));
  const S den = root + r * c;
  S L = std::fabs(den) < S(1e-12) * (r + S(1e-30)) ? S(0) : k * s / den;
  if (k < S(0) && L != S(0)) {
    const S other = -k / L;
    if (std::fabs(other - hint) < std::fabs(L - hint)) L = other;
  }
  return L;
}

template <class S>
S elevationFromAngle(S r, S d2, S phi, S hint) {
  return elevationFromSinCos(r, d2, S(std::sin(phi)), S(std::cos(phi)), hint);
}

// The position the parameters give over the neighbours' current triangle; `hint` is the vertex's
// current elevation (see elevationFromAngle).
template <class V>
V positionFromParams(const V& p1, const V& p2, const V& p3, const NeighbourFrameT<typename V::Scalar>& f,
                     const SimplexParamsT<typename V::Scalar>& s, typename V::Scalar hint) {
  const V foot = s.eps1 * p1 + s.eps2 * p2 + s.eps3() * p3;
  if (!f.valid()) return foot;
  const typename V::Scalar d2 = (foot - f.circumCentre).squaredNorm();
  return foot + elevationFromAngle(f.circumRadius, d2, s.phi, hint) * f.normal;
}

// The shape prior's pull (target - x) held to kPriorReach times the longest edge of the
// neighbours' triangle. Where the reference is degenerate at a vertex (an angle near 180 degrees,
// whose elevation's denominator vanishes), its target lies arbitrarily far away: on new subjects
// with cortical labels a vertex of Cuneus_R was pulled 130-270 mm in one step, which the stability
// guard caught by halving the time step for the rest of the level (docs/stability.md). Such
// references are now neutralised (isFoldedReference); the limit still holds a vertex far from its
// target, or over a neighbours' triangle that has nearly collapsed. A healthy pull is a fraction
// of an edge, so the limit leaves it alone. The CUDA terms do the same (force_terms.cuh,
// limitedPriorPull).
constexpr float kPriorReach = 4.0f;
template <class V>
V limitedPriorPull(const V& pull, const V& p1, const V& p2, const V& p3) {
  using S = typename V::Scalar;
  const S longest2 = std::max({(p1 - p2).squaredNorm(), (p2 - p3).squaredNorm(), (p3 - p1).squaredNorm()});
  const S limit2 = S(kPriorReach * kPriorReach) * longest2;
  const S pull2 = pull.squaredNorm();
  return pull2 > limit2 ? V(pull * std::sqrt(limit2 / pull2)) : pull;
}

}  // namespace sinew
