// Shared by the report's pictures: one colour per structure (structure_colour.h) and writing a
// PNG safely.
#pragma once

#include "sinew/core/io.h"
#include "structure_colour.h"

#include <QImage>

namespace sinew {

inline void savePng(const QImage& image, const std::filesystem::path& path) {
  AtomicOutput out(path);
  // Quality 80: zlib level 2 instead of Qt's default 6, pictures 10-20 % larger, written faster.
  if (!image.save(QString::fromStdString(out.tempPath().string()), "PNG", 80))
    throw InputError(path.string() + ": cannot write the picture");
  out.commit();
}

}  // namespace sinew
