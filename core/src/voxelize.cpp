#include "sinew/core/voxelize.h"

#include <algorithm>
#include <cmath>

namespace sinew {

namespace {
// The inside of a closed mesh on a grid, row by row: span(offset of the row's first voxel, i0, i1)
// for every run of voxels whose centres are inside (even-odd rule along the grid's first axis).
template <class Span>
void insideSpans(const TriangleMesh& mesh, const ImageGeometry& grid, Span&& span) {
  const Eigen::Matrix3d toIndex = grid.indexToWorldMatrix().inverse();
  const int nx = grid.size[0], ny = grid.size[1], nz = grid.size[2];
  // Work in continuous index space; rays run along i at (j, k) slightly offset so they never
  // pass exactly through a vertex or an edge of a mesh built on the same grid.
  constexpr double dj = 1.234567e-4, dk = 2.345678e-4;
  std::vector<Eigen::Vector3d> p;
  p.reserve(mesh.points.size());
  for (const Vec3& w : mesh.points) p.push_back(toIndex * (w.cast<double>() - grid.origin));
  // The crossings of the rays with the mesh, (row, x), in one list sorted by row, then x: only the
  // rows the mesh crosses cost anything (a list per row of the whole grid cost a run's timeline
  // more than its Dice did).
  struct Crossing {
    std::size_t row;
    double x;
    bool operator<(const Crossing& o) const { return row != o.row ? row < o.row : x < o.x; }
  };
  std::vector<Crossing> crossings;
  crossings.reserve(2 * mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d &a = p[t[0]], &b = p[t[1]], &c = p[t[2]];
    // A corner off the grid's numbers (a run that blew up, sampled before it stops) crosses no row:
    // its crossings would be NaN, which no sort can order.
    if (!a.allFinite() || !b.allFinite() || !c.allFinite()) continue;
    const int j0 = std::max(0, int(std::ceil(std::min({a.y(), b.y(), c.y()}) - dj)));
    const int j1 = std::min(ny - 1, int(std::floor(std::max({a.y(), b.y(), c.y()}) - dj)));
    const int k0 = std::max(0, int(std::ceil(std::min({a.z(), b.z(), c.z()}) - dk)));
    const int k1 = std::min(nz - 1, int(std::floor(std::max({a.z(), b.z(), c.z()}) - dk)));
    const double det = (b.y() - a.y()) * (c.z() - a.z()) - (c.y() - a.y()) * (b.z() - a.z());
    if (det == 0.0) continue;  // parallel to the rays
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j) {
        const double y = j + dj - a.y(), z = k + dk - a.z();
        const double u = (y * (c.z() - a.z()) - (c.y() - a.y()) * z) / det;
        const double v = ((b.y() - a.y()) * z - y * (b.z() - a.z())) / det;
        if (u < 0 || v < 0 || u + v > 1) continue;
        crossings.push_back({static_cast<std::size_t>(k) * ny + j, a.x() + u * (b.x() - a.x()) + v * (c.x() - a.x())});
      }
  }
  std::sort(crossings.begin(), crossings.end());
  for (std::size_t first = 0; first < crossings.size();) {
    std::size_t end = first;
    while (end < crossings.size() && crossings[end].row == crossings[first].row) ++end;
    for (std::size_t q = first; q + 1 < end; q += 2) {
      const int i0 = std::max(0, int(std::ceil(crossings[q].x))), i1 = std::min(nx - 1, int(std::floor(crossings[q + 1].x)));
      if (i0 <= i1) span(crossings[first].row * nx, i0, i1);
    }
    first = end;
  }
}
}  // namespace

std::vector<std::uint8_t> voxelize(const TriangleMesh& mesh, const ImageGeometry& grid) {
  std::vector<std::uint8_t> mask(grid.voxelCount(), 0);
  insideSpans(mesh, grid, [&](std::size_t row, int i0, int i1) {
    for (int i = i0; i <= i1; ++i) mask[row + i] = 1;
  });
  return mask;
}

void forEachInsideRun(const TriangleMesh& mesh, const ImageGeometry& grid,
                      const std::function<void(std::size_t first, std::size_t count)>& inside) {
  insideSpans(mesh, grid, [&](std::size_t row, int i0, int i1) { inside(row + std::size_t(i0), std::size_t(i1 - i0 + 1)); });
}

double diceOfMesh(const TriangleMesh& mesh, const LabelVolume& labels, std::int32_t label, std::size_t labelCount) {
  std::size_t inside = 0, both = 0;
  const std::vector<std::int32_t>& v = labels.voxels();
  insideSpans(mesh, labels.geometry(), [&](std::size_t row, int i0, int i1) {
    inside += std::size_t(i1 - i0 + 1);
    for (int i = i0; i <= i1; ++i) both += v[row + i] == label;
  });
  return inside + labelCount ? 2.0 * double(both) / double(inside + labelCount) : 1.0;
}

namespace {
Eigen::AlignedBox3d boundsOf(const TriangleMesh& m) {
  Eigen::AlignedBox3d box;
  for (const Vec3& p : m.points) box.extend(p.cast<double>());
  return box;
}
}  // namespace

double overlapVolume(const TriangleMesh& a, const TriangleMesh& b, double spacingMm) {
  const Eigen::AlignedBox3d box = boundsOf(a).intersection(boundsOf(b));
  if (box.isEmpty()) return 0.0;
  ImageGeometry grid;
  grid.spacing = Eigen::Vector3d::Constant(spacingMm);
  grid.origin = box.min() + grid.spacing / 2;
  for (int d = 0; d < 3; ++d) grid.size[d] = std::max(1, int(std::ceil(box.sizes()[d] / spacingMm)));
  const auto ma = voxelize(a, grid), mb = voxelize(b, grid);
  std::size_t both = 0;
  for (std::size_t i = 0; i < ma.size(); ++i) both += ma[i] && mb[i];
  return double(both) * spacingMm * spacingMm * spacingMm;
}

std::vector<PairOverlap> pairwiseOverlaps(const std::vector<const TriangleMesh*>& meshes, double spacingMm) {
  std::vector<PairOverlap> out;
  for (int i = 0; i < int(meshes.size()); ++i)
    for (int j = i + 1; j < int(meshes.size()); ++j)
      if (const double v = overlapVolume(*meshes[i], *meshes[j], spacingMm); v > 0.0) out.push_back({i, j, v});
  return out;
}

double dice(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b) {
  std::size_t both = 0, na = 0, nb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    na += a[i] != 0;
    nb += b[i] != 0;
    both += a[i] != 0 && b[i] != 0;
  }
  return na + nb == 0 ? 1.0 : 2.0 * double(both) / double(na + nb);
}

}  // namespace sinew
