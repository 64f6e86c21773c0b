// A cubic B-spline displacement on a regular grid of control points: what a registration's
// B-spline stage found (RegistrationResult::deformation), evaluated in core without the plugin's
// library. The layout is ITK's BSplineTransform's: a point's continuous index in the control grid is
// u = diag(1/spacing) direction^-1 (x - origin), and its displacement is
//   d(x) = sum over the 4x4x4 control points around u of B(u0 - i) B(u1 - j) B(u2 - k) c_ijk
// (B the cubic B-spline) inside ITK's valid region (index in [1, size - 2) on every axis: the
// registration's target image). Past it, unlike ITK (which gives zero there), the displacement at
// the region's nearest point: the map stays continuous, so a structure that reaches past the
// target's field of view is not torn at its edge, and its inverse exists everywhere (Newton's
// method found none across ITK's jump; docs/accuracy.md, "Subjects on other grids, cut and
// turned"). World millimetres, LPS.
#pragma once

#include <Eigen/Dense>

#include <array>
#include <vector>

namespace sinew {

struct BSplineWarp {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();   // the control point of index (0, 0, 0)
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();  // between control points, per grid axis
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();  // grid axes as columns
  std::array<int, 3> size{};                          // control points per axis (cells + 3)
  std::vector<Eigen::Vector3d> coefficients;          // one per control point, x fastest

  bool empty() const { return coefficients.empty(); }
  // d(x); with `jacobian`, also d's derivative with respect to x (along a clamped axis, zero).
  Eigen::Vector3d displacement(const Eigen::Vector3d& x, Eigen::Matrix3d* jacobian = nullptr) const;
  // True when the size, spacing and direction make a grid and every coefficient is finite.
  bool valid() const;
};

}  // namespace sinew
