// Scalar volumes in world millimetres. Physical space follows ITK (LPS): a voxel index i maps to
// origin + direction * diag(spacing) * i. Image IO plugins convert to this; core has no ITK.
#pragma once

#include "sinew/core/types.h"

#include <Eigen/Dense>

#include <array>
#include <vector>

namespace sinew {

struct ImageGeometry {
  std::array<int, 3> size{0, 0, 0};
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();

  std::size_t voxelCount() const {
    return static_cast<std::size_t>(size[0]) * size[1] * size[2];
  }
  Eigen::Matrix3d indexToWorldMatrix() const { return direction * spacing.asDiagonal(); }
  // Whether a continuous voxel index lies within the voxels' extent (half a voxel past the first
  // and last centres), where a sample still has a voxel to take.
  bool containsIndex(const Vec3& idx) const {
    for (int a = 0; a < 3; ++a)
      if (!(idx[a] >= -0.5f && idx[a] <= static_cast<float>(size[a]) - 0.5f)) return false;
    return true;
  }
};

template <class T>
class Volume {
public:
  Volume() = default;
  explicit Volume(const ImageGeometry& g, const T& fill = T{})
      : geometry_(g), voxels_(g.voxelCount(), fill) {
    const Eigen::Matrix3d m = g.indexToWorldMatrix();
    toIndex_ = m.inverse().cast<float>();
    origin_ = g.origin.cast<float>();
  }

  const ImageGeometry& geometry() const { return geometry_; }
  std::vector<T>& voxels() { return voxels_; }
  const std::vector<T>& voxels() const { return voxels_; }
  std::size_t bytes() const { return voxels_.size() * sizeof(T); }

  std::size_t offset(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * geometry_.size[1] + j) * geometry_.size[0] + i;
  }
  T& at(int i, int j, int k) { return voxels_[offset(i, j, k)]; }
  const T& at(int i, int j, int k) const { return voxels_[offset(i, j, k)]; }

  Vec3 worldToIndex(const Vec3& p) const { return toIndex_ * (p - origin_); }
  Vec3 indexToWorld(const Vec3& i) const {
    return (geometry_.indexToWorldMatrix().cast<float>() * i) + origin_;
  }

  // Trilinear interpolation at a world point; the border voxels extend outside the image.
  T sample(const Vec3& world) const { return sampleIndex(worldToIndex(world)); }

  T sampleIndex(const Vec3& idx) const {
    const auto& s = geometry_.size;
    float c[3];
    int i0[3];
    float f[3];
    for (int a = 0; a < 3; ++a) {
      // std::fmax / std::fmin are library calls here (NaN rules); these comparisons give the same
      // values (a NaN index clamps to 0, as std::fmax(NaN, 0) does) inline.
      const float hi = static_cast<float>(s[a] - 1);
      const float lo = idx[a] > 0.0f ? idx[a] : 0.0f;
      c[a] = lo < hi ? lo : hi;
      i0[a] = std::min(static_cast<int>(c[a]), std::max(s[a] - 2, 0));
      f[a] = c[a] - static_cast<float>(i0[a]);
    }
    // The cell's far corners one voxel on, or the same voxel on an axis of one voxel.
    const std::size_t dx = i0[0] + 1 < s[0], dy = (i0[1] + 1 < s[1]) * std::size_t(s[0]),
                      dz = (i0[2] + 1 < s[2]) * std::size_t(s[0]) * std::size_t(s[1]);
    return blendCell(&at(i0[0], i0[1], i0[2]), dx, dy, dz, f[0], f[1], f[2]);
  }

  // The index-space step of a world-space direction (worldToIndex(p + d) - worldToIndex(p)).
  Vec3 worldToIndexDirection(const Vec3& d) const { return toIndex_ * d; }

  // sampleIndex at start + q * step for q = 0 .. count - 1 (a search line). A line whose ends lie
  // inside the clamping limits in every axis (so every sample between them does: float rounding of
  // start + q * step is monotonic in q) skips the clamps; the values are sampleIndex's.
  void sampleLine(const Vec3& start, const Vec3& step, int count, T* out) const {
    if (count <= 0) return;
    const auto& s = geometry_.size;
    const Vec3 end = start + static_cast<float>(count - 1) * step;
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      const float top = static_cast<float>(s[a] - 1);  // sampleIndex clamps i0 below s - 1 (its last cell)
      inside = inside && start[a] >= 0.0f && end[a] >= 0.0f && start[a] < top && end[a] < top;
    }
    if (!inside) {
      for (int q = 0; q < count; ++q) out[q] = sampleIndex(start + static_cast<float>(q) * step);
      return;
    }
    const std::size_t dy = static_cast<std::size_t>(s[0]), dz = dy * static_cast<std::size_t>(s[1]);
    for (int q = 0; q < count; ++q) {
      const Vec3 idx = start + static_cast<float>(q) * step;
      const int i = static_cast<int>(idx[0]), j = static_cast<int>(idx[1]), k = static_cast<int>(idx[2]);
      out[q] = blendCell(&at(i, j, k), 1, dy, dz, idx[0] - static_cast<float>(i), idx[1] - static_cast<float>(j),
                         idx[2] - static_cast<float>(k));
    }
  }

  bool containsIndex(const Vec3& idx) const { return geometry_.containsIndex(idx); }

private:
  static T lerp(const T& a, const T& b, float t) { return a + (b - a) * t; }
  // Trilinear blend of the cell whose first corner is c, its other corners dx, dy, dz voxels on.
  static T blendCell(const T* c, std::size_t dx, std::size_t dy, std::size_t dz, float fx, float fy, float fz) {
    const T c00 = lerp(c[0], c[dx], fx);
    const T c10 = lerp(c[dy], c[dy + dx], fx);
    const T c01 = lerp(c[dz], c[dz + dx], fx);
    const T c11 = lerp(c[dz + dy], c[dz + dy + dx], fx);
    return lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz);
  }

  ImageGeometry geometry_;
  std::vector<T> voxels_;
  Eigen::Matrix3f toIndex_ = Eigen::Matrix3f::Identity();
  Vec3 origin_ = Vec3::Zero();
};

using Image3D = Volume<float>;
using VectorVolume = Volume<Vec3>;

// Gaussian smoothing (sigma in mm, per axis converted to voxels; 0 = none) followed by central
// differences, returned as the world-space gradient.
VectorVolume worldGradient(const Image3D& image, float sigmaMm);
Image3D gaussianSmooth(const Image3D& image, float sigmaMm);

}  // namespace sinew
