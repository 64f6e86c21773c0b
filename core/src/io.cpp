#include "sinew/core/io.h"

#include <algorithm>
#include <atomic>
#include <unistd.h>

namespace sinew {

std::string ioExtension(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) return "/";
  std::string name = path.filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* twoPart : {".nii.gz", ".vtk.gz"})
    if (name.size() > std::string(twoPart).size() && name.ends_with(twoPart)) return twoPart;
  const auto dot = name.rfind('.');
  return dot == std::string::npos ? std::string() : name.substr(dot);
}

AtomicOutput::AtomicOutput(std::filesystem::path target) : target_(std::move(target)) {
  static std::atomic<int> counter{0};
  const std::string ext = ioExtension(target_) == "/" ? "" : ioExtension(target_);
  const std::string stem = target_.filename().string().substr(0, target_.filename().string().size() - ext.size());
  temp_ = target_.parent_path() /
          ("." + stem + ".tmp" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + ext);
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) {
    std::error_code ec;
    std::filesystem::remove(temp_, ec);
  }
}

void AtomicOutput::commit() {
  std::filesystem::rename(temp_, target_);
  committed_ = true;
}

}  // namespace sinew
