// The image readers behind every format the ITK plugin accepts: the header checks, the gzip
// check, the read itself. The first byte picks the file name (so the format), the rest is the
// file. Any input gives a volume whose size matches its header, or an InputError, and leaves no file
// open (a reader that leaks a descriptor per bad file runs a long session out of them: the long run
// on the device met "The file couldn't be opened for reading" after about 270,000 inputs).
#include "fuzz_support.h"

#include "sinew/core/io.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>

namespace {
// .nhdr and .mhd name a second file for their data: that file is the input's tail after a NUL.
constexpr std::array<const char*, 6> kNames = {"image.nii", "image.nii.gz", "image.nrrd", "image.mha", "image.nhdr", "image.mhd"};

int openDescriptors() {
  int n = 0;
  for (auto it = std::filesystem::directory_iterator("/proc/self/fd"); it != std::filesystem::directory_iterator(); ++it) ++n;
  return n;
}
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string name = kNames[data[0] % kNames.size()];
  ++data, --size;
  if (name.ends_with(".nhdr") || name.ends_with(".mhd")) {
    std::size_t split = 0;
    while (split < size && data[split] != 0) ++split;
    const std::size_t tail = split < size ? split + 1 : size;
    sinew::fuzz::writeFile("image.raw", data + tail, size - tail);
    size = split;
  }
  const auto file = sinew::fuzz::writeFile(name, data, size);
  const int descriptors = openDescriptors();
  const sinew::ImageIODescriptor& io = sinew::fuzz::registry().imageIOFor(file);
  try {
    const sinew::Image3D image = io.readImage(file);
    const auto& g = image.geometry();
    if (image.voxels().size() != std::size_t(g.size[0]) * g.size[1] * g.size[2]) __builtin_trap();
  } catch (const sinew::InputError&) {
  }
  try {
    const sinew::LabelVolume labels = io.readLabels(file);
    (void)labels;
  } catch (const sinew::InputError&) {
  }
  if (openDescriptors() > descriptors) __builtin_trap();  // a reader left a file open
  return 0;
}
