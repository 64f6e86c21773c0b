#include "sinew/core/spatial_map.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace sinew {

namespace {
Eigen::Vector3d vec(const std::array<double, 3>& a) { return {a[0], a[1], a[2]}; }

// How far the points are from lying on one plane, relative to their spread: the smallest singular
// value of the centred point set over the largest.
double flatness(const std::vector<Eigen::Vector3d>& p) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& x : p) c += x;
  c /= double(p.size());
  Eigen::MatrixXd m(p.size(), 3);
  for (size_t i = 0; i < p.size(); ++i) m.row(i) = (p[i] - c).transpose();
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::MatrixXd>(m).singularValues();
  return s[0] > 0.0 ? s[2] / s[0] : 0.0;
}

void checkSide(const std::vector<Eigen::Vector3d>& p, const char* side, const std::string& where) {
  for (size_t i = 0; i < p.size(); ++i) {
    if (!p[i].allFinite()) throw InputError(where + ": landmark " + std::to_string(i) + ": non-finite " + side + " point");
    for (size_t j = 0; j < i; ++j)
      if ((p[i] - p[j]).norm() < 1e-3)
        throw InputError(where + ": landmarks " + std::to_string(j) + " and " + std::to_string(i) + " have the same " +
                         side + " point; every landmark must be distinct");
  }
  // 1e-3 of the spread: a plane of landmarks leaves the direction across it undetermined.
  if (flatness(p) < 1e-3)
    throw InputError(where + ": the " + std::string(side) +
                     " landmarks are coplanar (or collinear); place at least one off their plane");
}
}  // namespace

void checkLandmarks(std::span<const LandmarkPair> pairs, const std::string& where) {
  if (pairs.size() < 4)
    throw InputError(where + ": " + std::to_string(pairs.size()) +
                     " landmark pairs; at least 4 non-coplanar pairs are needed");
  std::vector<Eigen::Vector3d> model, target;
  for (const auto& p : pairs) {
    model.push_back(vec(p.model));
    target.push_back(vec(p.target));
  }
  checkSide(model, "model", where);
  checkSide(target, "target", where);
}

SpatialMap SpatialMap::affine(const Eigen::Matrix4d& modelToTarget) {
  SpatialMap m;
  m.affine_ = modelToTarget;
  return m;
}

SpatialMap SpatialMap::fitAffine(std::span<const LandmarkPair> pairs) {
  checkLandmarks(pairs, "landmarks");
  const Index n = Index(pairs.size());
  Eigen::MatrixXd a(n, 4), b(n, 3);
  for (Index i = 0; i < n; ++i) {
    a.row(i) << pairs[i].model[0], pairs[i].model[1], pairs[i].model[2], 1.0;
    b.row(i) << pairs[i].target[0], pairs[i].target[1], pairs[i].target[2];
  }
  const Eigen::MatrixXd x = a.colPivHouseholderQr().solve(b);  // 4x3
  SpatialMap m;
  m.affine_.topRows<3>() = x.transpose();
  return m;
}

constexpr Index kFullPivotingUpTo = 64;

SpatialMap SpatialMap::fitThinPlateSpline(std::span<const LandmarkPair> pairs) {
  checkLandmarks(pairs, "landmarks");
  const Index n = Index(pairs.size());
  // [K P; P^T 0] [w; a] = [y; 0], K_ij = |c_i - c_j| (the 3D biharmonic kernel).
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(n + 4, n + 4);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(n + 4, 3);
  for (Index i = 0; i < n; ++i) {
    const Eigen::Vector3d ci = vec(pairs[i].model);
    for (Index j = 0; j < n; ++j) L(i, j) = (ci - vec(pairs[j].model)).norm();
    L.block<1, 4>(i, n) << ci.x(), ci.y(), ci.z(), 1.0;
    rhs.row(i) = vec(pairs[i].target).transpose();
  }
  L.block(n, 0, 4, n) = L.block(0, n, n, 4).transpose();
  // Full pivoting for the few pairs a user places; partial pivoting for hundreds of pairs: with 729
  // pairs (an earlier registration's grid) two fits and the mapping took 0.12 s instead of 0.38 on
  // the 2-core machine.
  const Eigen::MatrixXd x = n <= kFullPivotingUpTo ? Eigen::MatrixXd(L.fullPivLu().solve(rhs))
                                                   : Eigen::MatrixXd(L.partialPivLu().solve(rhs));
  if (!x.allFinite()) throw InputError("landmarks: the thin-plate spline system is singular");
  SpatialMap m;
  m.affine_.topRows<3>() = x.bottomRows(4).transpose();
  for (Index i = 0; i < n; ++i) {
    m.centres_.push_back(vec(pairs[i].model));
    m.weights_.push_back(x.row(i).transpose());
  }
  return m;
}

SpatialMap SpatialMap::warpThenAffine(const BSplineWarp& warp, const Eigen::Matrix4d& affine) {
  if (!warp.valid()) throw InputError("registration: the B-spline's control grid is malformed or not finite");
  SpatialMap m;
  m.affine_ = affine;
  m.warp_ = std::make_shared<const BSplineWarp>(warp);
  return m;
}

SpatialMap SpatialMap::inverse() const {
  if (!centres_.empty()) throw std::logic_error("SpatialMap::inverse: a thin-plate spline has no closed-form inverse");
  // The inverse's affine part is the inverse matrix either way: an inverted warp map applies it
  // first, then undoes the warp (exact()).
  SpatialMap m;
  m.warp_ = warp_;
  m.warpInverted_ = warp_ && !warpInverted_;
  m.affine_ = affine_.inverse();
  return m;
}

namespace {
// The point x with x + d(x) = z. Newton's method from z, each step halved until the residual
// shrinks: the warp's Jacobian stays near the identity (the plugin keeps only warps whose
// determinant stays above a fifth), so a few steps reach 1e-9 mm.
Eigen::Vector3d undoWarp(const BSplineWarp& warp, const Eigen::Vector3d& z) {
  const auto residual = [&](const Eigen::Vector3d& x, Eigen::Matrix3d* jac) {
    return Eigen::Vector3d(x + warp.displacement(x, jac) - z);
  };
  Eigen::Vector3d x = z;
  Eigen::Matrix3d jac;
  Eigen::Vector3d r = residual(x, &jac);
  for (int it = 0; it < 50 && r.norm() > 1e-9; ++it) {
    const Eigen::Vector3d step = (Eigen::Matrix3d::Identity() + jac).partialPivLu().solve(r);
    double scale = 1.0;
    Eigen::Vector3d next = x - step, rNext = residual(next, nullptr);
    for (int halving = 0; halving < 20 && !(rNext.norm() < r.norm()); ++halving) {
      scale *= 0.5;
      next = x - scale * step;
      rNext = residual(next, nullptr);
    }
    if (!(rNext.norm() < r.norm())) break;
    x = next;
    r = residual(x, &jac);
  }
  return r.norm() <= 1e-4 ? x : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
}
}  // namespace

Eigen::Vector3d SpatialMap::exact(const Eigen::Vector3d& p) const {
  const auto affine = [this](const Eigen::Vector3d& q) -> Eigen::Vector3d {
    return affine_.topLeftCorner<3, 3>() * q + affine_.topRightCorner<3, 1>();
  };
  if (warp_) return warpInverted_ ? undoWarp(*warp_, affine(p)) : affine(p + warp_->displacement(p));
  Eigen::Vector3d y = affine(p);
  for (size_t i = 0; i < centres_.size(); ++i) y += weights_[i] * (p - centres_[i]).norm();
  return y;
}

SpatialMap SpatialMap::sampledOn(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double spacingMm) const {
  SpatialMap m = *this;
  m.gridOrigin_ = lo;
  m.gridSpacing_ = spacingMm;
  for (int a = 0; a < 3; ++a) m.gridSize_[a] = std::max(2, int(std::ceil((hi[a] - lo[a]) / spacingMm)) + 1);
  const int nx = m.gridSize_[0], ny = m.gridSize_[1], nz = m.gridSize_[2];  // not a binding: clang's lambdas cannot take one
  m.gridValues_.resize(size_t(nx) * size_t(ny) * size_t(nz));
  tbb::parallel_for(0, nz, [&](int k) {
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i)
        m.gridValues_[(size_t(k) * size_t(ny) + size_t(j)) * size_t(nx) + size_t(i)] =
            exact(lo + spacingMm * Eigen::Vector3d(i, j, k));
  });
  return m;
}

Eigen::Vector3d SpatialMap::apply(const Eigen::Vector3d& p) const {
  if (gridValues_.empty()) return exact(p);
  const Eigen::Vector3d u = (p - gridOrigin_) / gridSpacing_;
  int c[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    if (!(u[a] >= 0.0 && u[a] <= double(gridSize_[a] - 1))) return exact(p);  // outside the grid (or NaN)
    c[a] = std::min(int(u[a]), gridSize_[a] - 2);
    f[a] = u[a] - double(c[a]);
  }
  const auto at = [&](int i, int j, int k) -> const Eigen::Vector3d& {
    return gridValues_[(size_t(c[2] + k) * size_t(gridSize_[1]) + size_t(c[1] + j)) * size_t(gridSize_[0]) + size_t(c[0] + i)];
  };
  Eigen::Vector3d y = Eigen::Vector3d::Zero();
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i)
        y += ((i ? f[0] : 1.0 - f[0]) * (j ? f[1] : 1.0 - f[1]) * (k ? f[2] : 1.0 - f[2])) * at(i, j, k);
  return y;
}

void SpatialMap::applyInPlace(std::span<Vec3> points) const {
  for (Vec3& p : points) p = apply(p);
}

std::string SpatialMap::spacingText() const {
  char b[32];
  std::snprintf(b, sizeof b, "%g", gridSpacing_);
  return b;
}

std::string SpatialMap::describe() const {
  const std::string sampled = gridValues_.empty() ? "" : ", sampled every " + spacingText() + " mm";
  if (warp_) {
    const auto& n = warp_->size;
    const std::string b = "B-spline (" + std::to_string(n[0]) + "x" + std::to_string(n[1]) + "x" + std::to_string(n[2]) +
                          " control points), then affine";
    return (warpInverted_ ? "inverse of " + b : b) + sampled;
  }
  if (!centres_.empty())
    return "thin-plate spline (" + std::to_string(centres_.size()) + " landmarks" + sampled + ")";
  return affine_.isIdentity(0.0) ? "identity" : "affine";
}

}  // namespace sinew
