#include "offscreen_qt.h"

#include <filesystem>
#include <string>
#include <unistd.h>

namespace sinew {

std::unique_ptr<QGuiApplication> startOffscreenQt(char* programName) {
  namespace fs = std::filesystem;
  qputenv("QT_QPA_PLATFORM", "offscreen");
  if (qgetenv("XDG_RUNTIME_DIR").isEmpty()) {  // keeps Qt from warning about it
    const fs::path runtime = fs::temp_directory_path() / ("sinew-runtime-" + std::to_string(::getuid()));
    std::error_code ec;
    fs::create_directories(runtime, ec);
    fs::permissions(runtime, fs::perms::owner_all, ec);
    qputenv("XDG_RUNTIME_DIR", QByteArray::fromStdString(runtime.string()));
  }
  static int argc = 1;
  static char* argv[] = {programName, nullptr};
  return std::make_unique<QGuiApplication>(argc, argv);
}

}  // namespace sinew
