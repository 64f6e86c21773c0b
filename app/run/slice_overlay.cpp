// slices.png: axial, coronal and sagittal slices of the target image through the centre of the
// segmented structures, each structure's label-map boundary drawn in its colour. A quick look at a
// result without the workstation.
#include "pictures.h"
#include "report_writer.h"

#include <QColor>
#include <QImage>
#include <QPainter>

#include <algorithm>
#include <cmath>
#include <map>

namespace sinew {

void writeSliceOverlay(const std::filesystem::path& path, const Image3D& image, const LabelVolume& labels,
                       const SceneDesc& scene) {
  const auto& g = image.geometry();
  // Centre: the mean voxel of all labels; grey window: 1st to 99th percentile of at most about a
  // million voxels taken at a fixed stride (a window for display, not a measurement).
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  long count = 0;
  const std::vector<std::int32_t>& l = labels.voxels();
  const std::size_t nx = std::size_t(g.size[0]), nxy = nx * std::size_t(g.size[1]);
  for (std::size_t v = 0; v < l.size(); ++v)
    if (l[v]) {
      centre += Eigen::Vector3d(double(v % nx), double(v % nxy / nx), double(v / nxy));
      ++count;
    }
  centre = count ? Eigen::Vector3d(centre / double(count)) : Eigen::Vector3d(g.size[0] / 2.0, g.size[1] / 2.0, g.size[2] / 2.0);
  const std::size_t stride = std::max<std::size_t>(1, image.voxels().size() / (1u << 20));
  std::vector<float> sorted;
  sorted.reserve(image.voxels().size() / stride + 1);
  for (std::size_t v = 0; v < image.voxels().size(); v += stride)
    if (std::isfinite(image.voxels()[v])) sorted.push_back(image.voxels()[v]);
  if (sorted.empty()) sorted.push_back(0.0f);
  // Two selections, not a sort.
  auto percentile = [&](size_t at) {
    std::nth_element(sorted.begin(), sorted.begin() + at, sorted.end());
    return sorted[at];
  };
  const float lo = percentile(sorted.size() / 100);
  const float hi = std::max(percentile(sorted.size() * 99 / 100), lo + 1e-6f);
  std::map<int, QColor> colour;
  for (size_t s = 0; s < scene.structures.size(); ++s) colour[scene.structures[s].label] = structureColour(s, scene.structures.size());

  // Each view: (u axis, v axis, fixed axis); v runs upward on screen.
  const int views[3][3] = {{0, 1, 2}, {0, 2, 1}, {1, 2, 0}};
  const int scale = 3;
  std::vector<QImage> tiles;
  for (const auto& v : views) {
    const int nu = g.size[v[0]], nv = g.size[v[1]];
    QImage tile(nu * scale, nv * scale, QImage::Format_RGB32);
    int idx[3];
    idx[v[2]] = static_cast<int>(std::lround(centre[v[2]]));
    auto label = [&](int u, int w) {
      if (u < 0 || w < 0 || u >= nu || w >= nv) return 0;
      int p[3];
      p[v[0]] = u;
      p[v[1]] = w;
      p[v[2]] = idx[v[2]];
      return labels.at(p[0], p[1], p[2]);
    };
    for (int w = 0; w < nv; ++w)
      for (int u = 0; u < nu; ++u) {
        idx[v[0]] = u;
        idx[v[1]] = w;
        const float value = image.at(idx[0], idx[1], idx[2]);
        const int grey = std::isfinite(value) ? std::clamp(int(255.0f * (value - lo) / (hi - lo)), 0, 255) : 0;
        QRgb rgb = qRgb(grey, grey, grey);
        const int l = label(u, w);
        if (l && (label(u - 1, w) != l || label(u + 1, w) != l || label(u, w - 1) != l || label(u, w + 1) != l))
          rgb = colour.count(l) ? colour[l].rgb() : qRgb(255, 0, 0);
        for (int a = 0; a < scale; ++a)
          for (int b = 0; b < scale; ++b) tile.setPixel(u * scale + a, (nv - 1 - w) * scale + b, rgb);
      }
    tiles.push_back(tile);
  }
  int width = 0, height = 0;
  for (const QImage& t : tiles) {
    width += t.width();
    height = std::max(height, t.height());
  }
  QImage out(width, height + 30, QImage::Format_RGB32);
  out.fill(Qt::black);
  QPainter p(&out);
  int x = 0;
  for (const QImage& t : tiles) {
    p.drawImage(x, 0, t);
    x += t.width();
  }
  QFont font = p.font();
  font.setPixelSize(14);
  p.setFont(font);
  x = 8;
  for (size_t s = 0; s < scene.structures.size(); ++s) {
    p.setPen(structureColour(s, scene.structures.size()));
    const QString name = QString::fromStdString(scene.structures[s].name);
    p.drawText(x, height + 20, name);
    x += p.fontMetrics().horizontalAdvance(name) + 14;
  }
  p.end();
  savePng(out, path);
}

}  // namespace sinew
