// Maps from the model's (atlas) space to the target's: the global initialisation before the first
// level (paper 001 section 3: landmarks and a thin-plate spline; paper 000 section 5). An affine
// part, plus an optional thin-plate spline through landmark pairs, or a registration's B-spline
// (either way). World millimetres, LPS.
#pragma once

#include "sinew/core/bspline_warp.h"
#include "sinew/core/types.h"

#include <Eigen/Dense>

#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace sinew {

struct LandmarkPair {
  std::array<double, 3> model{};   // in the model's (atlas) space
  std::array<double, 3> target{};  // the same anatomical point in the target image
};

class SpatialMap {
public:
  SpatialMap() = default;  // the identity
  static SpatialMap affine(const Eigen::Matrix4d& modelToTarget);

  // Least-squares affine fit through the pairs. Throws InputError (fewer than 4 pairs, coincident
  // model or target points, coplanar points: the fit is not determined).
  static SpatialMap fitAffine(std::span<const LandmarkPair> pairs);
  // Thin-plate spline through the pairs (U(r) = r in 3D, interpolating exactly), with its affine
  // part; the same checks as fitAffine.
  static SpatialMap fitThinPlateSpline(std::span<const LandmarkPair> pairs);
  // x -> affine (x + warp's d(x)): a registration's B-spline, then its affine (the result's
  // targetToModel). Throws InputError when the warp is not valid().
  static SpatialMap warpThenAffine(const BSplineWarp& warp, const Eigen::Matrix4d& affine);
  // The inverse of an affine or warpThenAffine map (the latter: the inverse affine, then the warp
  // undone by Newton's method at each point, NaN where it does not converge); std::logic_error for
  // a thin-plate spline's.
  SpatialMap inverse() const;

  // The same map, evaluated inside the box [lo, hi] by trilinear interpolation of its values on a
  // grid of `spacingMm` (computed here, on every thread), exactly outside it. For a spline through
  // hundreds of pairs, whose exact evaluation costs a distance per pair at every point, or for a
  // B-spline's inverse, which costs a Newton solve.
  SpatialMap sampledOn(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double spacingMm) const;

  Eigen::Vector3d apply(const Eigen::Vector3d& modelPoint) const;
  Vec3 apply(const Vec3& modelPoint) const {
    const Eigen::Vector3d p = modelPoint.cast<double>();
    return apply(p).cast<float>();
  }
  void applyInPlace(std::span<Vec3> points) const;

  const Eigen::Matrix4d& affinePart() const { return affine_; }
  bool hasSpline() const { return !centres_.empty() || warp_; }
  // "identity", "affine", "thin-plate spline (N landmarks)", "B-spline (8x8x8 control points),
  // then affine", "inverse of ...", each with ", sampled every X mm" when sampled.
  std::string describe() const;

private:
  Eigen::Matrix4d affine_ = Eigen::Matrix4d::Identity();
  std::vector<Eigen::Vector3d> centres_;  // model landmarks
  std::vector<Eigen::Vector3d> weights_;  // spline weights, one per centre
  std::shared_ptr<const BSplineWarp> warp_;  // warpThenAffine: shared by the map and its inverse
  bool warpInverted_ = false;
  // sampledOn: the map's values on a grid (x fastest), empty when not sampled.
  Eigen::Vector3d gridOrigin_ = Eigen::Vector3d::Zero();
  double gridSpacing_ = 0.0;
  std::array<int, 3> gridSize_{};
  std::vector<Eigen::Vector3d> gridValues_;
  Eigen::Vector3d exact(const Eigen::Vector3d& p) const;
  std::string spacingText() const;
};

// Checks that landmark pairs can determine a map; throws InputError naming the problem (with the
// pair indices) otherwise. `where` prefixes the message (a file and JSON path).
void checkLandmarks(std::span<const LandmarkPair> pairs, const std::string& where);

}  // namespace sinew
