// One colour per structure, the same in every picture sinew-run writes and in the workstation's
// views: evenly spaced hues.
#pragma once

#include <QColor>

#include <algorithm>
#include <cstddef>

namespace sinew {

inline QColor structureColour(std::size_t structure, std::size_t count) {
  return QColor::fromHsv(int(360.0 * structure / std::max<std::size_t>(count, 1)), 210, 230);
}

}  // namespace sinew
