// Colours shared by sinew-run's pictures and the workstation's views: one per structure (evenly
// spaced hues), the thickness and the image fit colour maps.
#pragma once

#include <QColor>

#include <algorithm>
#include <array>
#include <cstddef>

namespace sinew {

inline QColor structureColour(std::size_t structure, std::size_t count) {
  return QColor::fromHsv(int(360.0 * structure / std::max<std::size_t>(count, 1)), 210, 230);
}

// The thickness colours (the workstation's View > Show Thickness): hue from red (medial radius
// 1 mm or less) through yellow and green to blue (6 mm or more), so that thin parts stand out as
// in paper 001's Fig. 3b.
inline std::array<unsigned char, 3> thicknessColour(float radiusMm) {
  const float t = std::clamp((radiusMm - 1.0f) / 5.0f, 0.0f, 1.0f);
  const QColor c = QColor::fromHsvF(t * 240.0f / 360.0f, 1.0f, 1.0f);
  return {static_cast<unsigned char>(c.red()), static_cast<unsigned char>(c.green()), static_cast<unsigned char>(c.blue())};
}

// The image fit colours (the workstation's View > Show Image Fit, core vertexImageFit): red at 0.3
// or less, yellow at 0.6 (kPoorImageFit, where sinew-run says "check"), green at 0.9 or more.
inline std::array<unsigned char, 3> fitColour(float fit) {
  const float t = std::clamp((fit - 0.3f) / 0.6f, 0.0f, 1.0f);
  const QColor c = QColor::fromHsvF(t * 120.0f / 360.0f, 1.0f, 1.0f);
  return {static_cast<unsigned char>(c.red()), static_cast<unsigned char>(c.green()), static_cast<unsigned char>(c.blue())};
}

}  // namespace sinew
