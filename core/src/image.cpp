#include "sinew/core/image.h"

#include <cmath>

namespace sinew {

Image3D gaussianSmooth(const Image3D& image, float sigmaMm) {
  Image3D out = image;
  if (sigmaMm <= 0.0f) return out;
  const auto& g = image.geometry();
  std::vector<float> line;
  for (int axis = 0; axis < 3; ++axis) {
    const float sigma = sigmaMm / static_cast<float>(g.spacing[axis]);
    if (sigma < 0.1f) continue;
    const int radius = static_cast<int>(std::ceil(3.0f * sigma));
    std::vector<float> kernel(2 * radius + 1);
    float sum = 0.0f;
    for (int i = -radius; i <= radius; ++i) sum += kernel[i + radius] = std::exp(-0.5f * i * i / (sigma * sigma));
    for (float& k : kernel) k /= sum;
    const int n = g.size[axis];
    line.resize(n);
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (int u = 0; u < g.size[a1]; ++u)
      for (int v = 0; v < g.size[a2]; ++v) {
        int idx[3];
        idx[a1] = u;
        idx[a2] = v;
        for (int i = 0; i < n; ++i) {
          idx[axis] = i;
          line[i] = out.at(idx[0], idx[1], idx[2]);
        }
        for (int i = 0; i < n; ++i) {
          float acc = 0.0f;
          for (int k = -radius; k <= radius; ++k) acc += kernel[k + radius] * line[std::clamp(i + k, 0, n - 1)];
          idx[axis] = i;
          out.at(idx[0], idx[1], idx[2]) = acc;
        }
      }
  }
  return out;
}

VectorVolume worldGradient(const Image3D& image, float sigmaMm) {
  const Image3D smooth = gaussianSmooth(image, sigmaMm);
  const auto& g = image.geometry();
  VectorVolume grad(g, Vec3::Zero());
  // d/dworld = direction * diag(1/spacing) * d/dindex.
  const Eigen::Matrix3f toWorld =
      (g.direction * g.spacing.cwiseInverse().asDiagonal()).cast<float>();
  for (int k = 0; k < g.size[2]; ++k)
    for (int j = 0; j < g.size[1]; ++j)
      for (int i = 0; i < g.size[0]; ++i) {
        auto diff = [&](int axis) {
          int lo[3] = {i, j, k}, hi[3] = {i, j, k};
          lo[axis] = std::max(lo[axis] - 1, 0);
          hi[axis] = std::min(hi[axis] + 1, g.size[axis] - 1);
          const int span = hi[axis] - lo[axis];
          if (span == 0) return 0.0f;
          return (smooth.at(hi[0], hi[1], hi[2]) - smooth.at(lo[0], lo[1], lo[2])) / span;
        };
        grad.at(i, j, k) = toWorld * Vec3(diff(0), diff(1), diff(2));
      }
  return grad;
}

}  // namespace sinew
