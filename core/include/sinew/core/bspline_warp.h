// A cubic B-spline displacement on a regular grid of control points: what a registration's
// B-spline stage found (RegistrationResult::deformation), evaluated in core without the plugin's
// library. The layout is ITK's BSplineTransform's: a point's continuous index in the control grid is
// u = diag(1/spacing) direction^-1 (x - origin), and its displacement is
//   d(x) = sum over the 4x4x4 control points around u of B(u0 - i) B(u1 - j) B(u2 - k) c_ijk
// (B the cubic B-spline), zero where that support leaves the grid (ITK's valid region: index in
// [1, size - 2) on every axis). World millimetres, LPS.
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
  // d(x); with `jacobian`, also d's derivative with respect to x (zero where d is).
  Eigen::Vector3d displacement(const Eigen::Vector3d& x, Eigen::Matrix3d* jacobian = nullptr) const;
  // True when the size, spacing and direction make a grid and every coefficient is finite.
  bool valid() const;
};

}  // namespace sinew
