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

std::unordered_map<std::int32_t, LabelExtent> labelExtents(const LabelVolume& labels) {
  std::unordered_map<std::int32_t, LabelExtent> out;
  const auto& size = labels.geometry().size;
  // Row by row, run by run: a run of one label widens its extent once.
  for (int k = 0; k < size[2]; ++k)
    for (int j = 0; j < size[1]; ++j) {
      const std::int32_t* row = &labels.at(0, j, k);
      for (int i = 0; i < size[0];) {
        const std::int32_t label = row[i];
        int end = i + 1;
        while (end < size[0] && row[end] == label) ++end;
        const auto [it, added] = out.try_emplace(label, LabelExtent{{i, j, k}, {end - 1, j, k}, 0});
        LabelExtent& e = it->second;
        if (!added) {
          e.lo = {std::min(e.lo[0], i), std::min(e.lo[1], j), e.lo[2]};  // rows come in k, then j order
          e.hi = {std::max(e.hi[0], end - 1), std::max(e.hi[1], j), k};
        }
        e.count += std::size_t(end - i);
        i = end;
      }
    }
  return out;
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
