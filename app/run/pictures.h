// Shared by the report's pictures: one colour per structure (structure_colour.h) and writing a
// PNG safely.
#pragma once

#include "sinew/core/io.h"
#include "structure_colour.h"

#include <QImage>

namespace sinew {

inline void savePng(const QImage& image, const std::filesystem::path& path) {
  AtomicOutput out(path);
  if (!image.save(QString::fromStdString(out.tempPath().string()), "PNG"))
    throw InputError(path.string() + ": cannot write the picture");
  out.commit();
}

}  // namespace sinew
