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
#include <map>

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

// The pristine folder's files, in memory: each input changes one or two of them in a working copy,
// and they are put back afterwards (cheaper than copying the folder per input).
struct Files {
  fs::path folder = scratch() / "model";
  std::map<std::string, std::string> pristineBytes;
  nlohmann::json manifest;
  Files() {
    fs::remove_all(folder);
    fs::copy(pristine(), folder, fs::copy_options::recursive);
    for (const char* f : kFiles) {
      std::ifstream in(folder / f, std::ios::binary);
      pristineBytes[f].assign(std::istreambuf_iterator<char>(in), {});
    }
    manifest = nlohmann::json::parse(pristineBytes["model.json"]);
  }
  void write(const std::string& file, const void* data, std::size_t size) const {
    std::ofstream out(folder / file, std::ios::binary | std::ios::trunc);
    out.write(static_cast<const char*>(data), std::streamsize(size));
  }
  void restore(const std::string& file) const {
    const std::string& bytes = pristineBytes.at(file);
    write(file, bytes.data(), bytes.size());
  }
};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const Files files;
  const std::string file = kFiles[data[0] % kFiles.size()];
  files.write(file, data + 1, size - 1);
  if (file != "model.json") {
    nlohmann::json manifest = files.manifest;
    manifest["files"][file] = hex(std::uint32_t(crc32(0L, data + 1, uInt(size - 1))));
    const std::string text = manifest.dump(2);
    files.write("model.json", text.data(), text.size());
  }
  try {
    const sinew::Model model = sinew::readModel(sinew::fuzz::registry(), files.folder);
    for (const auto& s : model.structures) {
      if (s.positions.size() != std::size_t(s.levels.levelCount())) __builtin_trap();
      for (int l = 0; l < s.levels.levelCount(); ++l)
        if (s.positions[l].size() != std::size_t(s.levels.levels[l].vertexCount())) __builtin_trap();
    }
  } catch (const sinew::InputError&) {
  }
  files.restore(file);
  if (file != "model.json") files.restore("model.json");
  return 0;
}
