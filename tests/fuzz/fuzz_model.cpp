// The model reader (docs/model-format.md): one file of a valid model folder replaced by the input.
// The first byte picks the file: the manifest, or one of the meshes, whose checksum in the manifest
// is then rewritten to match (the checksum would refuse nearly every damaged mesh; a mesh written
// wrong but whole must be refused by the checks behind it). Any input gives a model whose every
// level has the point count of its topology, or an InputError.
#include "fuzz_support.h"

#include "sinew/core/executor.h"
#include "sinew/core/model_builder.h"
#include "sinew/core/model_file.h"
#include "sinew/core/triangle_mesh.h"

#include <nlohmann/json.hpp>
#include <zlib.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <iterator>

namespace {
namespace fs = std::filesystem;
using sinew::fuzz::scratch;

constexpr std::array<const char*, 4> kFiles = {"model.json", "structures/Sphere/topology.vtp",
                                               "structures/Sphere/level0.vtp", "structures/Sphere/level1.vtp"};

// A one-structure, two-level model, written once per process.
const fs::path& pristine() {
  static const fs::path folder = [] {
    const fs::path atlas = scratch() / "atlas.nii.gz";
    { std::ofstream(atlas) << "stand-in for the atlas image"; }
    sinew::Executor executor(1);
    sinew::Model m;
    m.atlasImage = atlas;
    m.createdBy = "fuzz_model";
    const sinew::BuiltModel b = sinew::buildModelFromMesh(sinew::icosphere(1, 10.0f), "sphere", 2, executor);
    m.structures.push_back({"Sphere", 1, b.levels, b.positions});
    const fs::path out = scratch() / "pristine";
    sinew::writeModel(sinew::fuzz::registry(), m, out);
    return out;
  }();
  return folder;
}

std::string hex(std::uint32_t v) {
  char s[9];
  std::snprintf(s, sizeof s, "%08x", v);
  return s;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string file = kFiles[data[0] % kFiles.size()];
  const fs::path folder = scratch() / "model";
  fs::remove_all(folder);
  fs::copy(pristine(), folder, fs::copy_options::recursive);
  {
    std::ofstream out(folder / file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  }
  if (file != "model.json") {
    std::ifstream in(folder / "model.json");
    nlohmann::json manifest = nlohmann::json::parse(in);
    manifest["files"][file] = hex(std::uint32_t(crc32(0L, data + 1, uInt(size - 1))));
    std::ofstream(folder / "model.json", std::ios::trunc) << manifest.dump(2);
  }
  try {
    const sinew::Model model = sinew::readModel(sinew::fuzz::registry(), folder);
    for (const auto& s : model.structures) {
      if (s.positions.size() != std::size_t(s.levels.levelCount())) __builtin_trap();
      for (int l = 0; l < s.levels.levelCount(); ++l)
        if (s.positions[l].size() != std::size_t(s.levels.levels[l].vertexCount())) __builtin_trap();
    }
  } catch (const sinew::InputError&) {
  }
  return 0;
}
