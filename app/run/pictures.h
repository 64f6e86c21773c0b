// Shared by the report's pictures: one colour per structure (the same in every picture) and
// writing a PNG safely.
#pragma once

#include "sinew/core/io.h"

#include <QColor>
#include <QImage>

namespace sinew {

inline QColor structureColour(std::size_t structure, std::size_t count) {
  return QColor::fromHsv(int(360.0 * structure / std::max<std::size_t>(count, 1)), 210, 230);
}

inline void savePng(const QImage& image, const std::filesystem::path& path) {
  AtomicOutput out(path);
  if (!image.save(QString::fromStdString(out.tempPath().string()), "PNG"))
    throw InputError(path.string() + ": cannot write the picture");
  out.commit();
}

}  // namespace sinew
