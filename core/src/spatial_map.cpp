#include "sinew/core/spatial_map.h"

#include <cmath>
#include <cstdio>

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
  const Eigen::MatrixXd x = L.fullPivLu().solve(rhs);
  if (!x.allFinite()) throw InputError("landmarks: the thin-plate spline system is singular");
  SpatialMap m;
  m.affine_.topRows<3>() = x.bottomRows(4).transpose();
  for (Index i = 0; i < n; ++i) {
    m.centres_.push_back(vec(pairs[i].model));
    m.weights_.push_back(x.row(i).transpose());
  }
  return m;
}

Eigen::Vector3d SpatialMap::apply(const Eigen::Vector3d& p) const {
  Eigen::Vector3d y = affine_.topLeftCorner<3, 3>() * p + affine_.topRightCorner<3, 1>();
  for (size_t i = 0; i < centres_.size(); ++i) y += weights_[i] * (p - centres_[i]).norm();
  return y;
}

void SpatialMap::applyInPlace(std::span<Vec3> points) const {
  for (Vec3& p : points) p = apply(p);
}

std::string SpatialMap::describe() const {
  if (hasSpline()) return "thin-plate spline (" + std::to_string(centres_.size()) + " landmarks)";
  return affine_.isIdentity(0.0) ? "identity" : "affine";
}

}  // namespace sinew
