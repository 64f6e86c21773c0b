#include "sinew/core/bspline_warp.h"

#include <algorithm>
#include <cmath>

namespace sinew {

namespace {
// The uniform cubic B-spline's four weights at fraction t in [0, 1) of the cell after the first
// support point, and their derivatives.
void cubicWeights(double t, double w[4], double dw[4]) {
  const double s = 1.0 - t;
  w[0] = s * s * s / 6.0;
  w[1] = (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0;
  w[2] = (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0;
  w[3] = t * t * t / 6.0;
  dw[0] = -s * s / 2.0;
  dw[1] = (3.0 * t * t - 4.0 * t) / 2.0;
  dw[2] = (-3.0 * t * t + 2.0 * t + 1.0) / 2.0;
  dw[3] = t * t / 2.0;
}
}  // namespace

bool BSplineWarp::valid() const {
  const size_t n = size_t(size[0]) * size_t(size[1]) * size_t(size[2]);
  if (size[0] < 4 || size[1] < 4 || size[2] < 4 || coefficients.size() != n) return false;
  if (!origin.allFinite() || !spacing.allFinite() || !(spacing.minCoeff() > 0.0) || !direction.allFinite() ||
      !(std::abs(direction.determinant()) > 1e-9))
    return false;
  for (const Eigen::Vector3d& c : coefficients)
    if (!c.allFinite()) return false;
  return true;
}

Eigen::Vector3d BSplineWarp::displacement(const Eigen::Vector3d& x, Eigen::Matrix3d* jacobian) const {
  if (jacobian) jacobian->setZero();
  if (empty()) return Eigen::Vector3d::Zero();
  // Index per world millimetre: diag(1/spacing) direction^-1.
  const Eigen::Matrix3d toIndex = spacing.cwiseInverse().asDiagonal() * direction.inverse();
  const Eigen::Vector3d u = toIndex * (x - origin);
  int first[3];
  double w[3][4], dw[3][4];
  bool clamped[3];
  for (int a = 0; a < 3; ++a) {
    if (std::isnan(u[a])) return Eigen::Vector3d::Zero();
    // Past the valid region, the displacement at its nearest point (the cell's end, t = 1, on the
    // far side: the same limit from inside).
    const double last = double(size[a]) - 2.0;
    clamped[a] = !(u[a] >= 1.0 && u[a] < last);
    const double v = std::clamp(u[a], 1.0, last);
    first[a] = std::min(int(std::floor(v - 1.0)), size[a] - 4);
    cubicWeights(v - 1.0 - double(first[a]), w[a], dw[a]);
  }
  Eigen::Vector3d d = Eigen::Vector3d::Zero();
  Eigen::Matrix3d dIndex = Eigen::Matrix3d::Zero();  // d's derivative with respect to the index
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j) {
      const size_t row = (size_t(first[2] + k) * size_t(size[1]) + size_t(first[1] + j)) * size_t(size[0]) + size_t(first[0]);
      for (int i = 0; i < 4; ++i) {
        const Eigen::Vector3d& c = coefficients[row + size_t(i)];
        d += (w[0][i] * w[1][j] * w[2][k]) * c;
        if (jacobian) {
          dIndex.col(0) += (dw[0][i] * w[1][j] * w[2][k]) * c;
          dIndex.col(1) += (w[0][i] * dw[1][j] * w[2][k]) * c;
          dIndex.col(2) += (w[0][i] * w[1][j] * dw[2][k]) * c;
        }
      }
    }
  if (jacobian) {
    for (int a = 0; a < 3; ++a)
      if (clamped[a]) dIndex.col(a).setZero();  // constant along a clamped axis
    *jacobian = dIndex * toIndex;
  }
  return d;
}

}  // namespace sinew
