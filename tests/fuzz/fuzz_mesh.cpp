// The mesh readers (VTK's, behind Sinew's checks): VTP, VTK, STL, OBJ, PLY, and the exact reader
// used for a model's meshes. The first byte picks the format, the rest is the file. Any input
// gives triangles over existing, finite points, or an InputError.
#include "fuzz_support.h"

#include "sinew/core/io.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <string>

namespace {
constexpr std::array<const char*, 6> kNames = {"mesh.vtp", "mesh.vtk", "mesh.stl", "mesh.obj", "mesh.ply", "exact.vtp"};

void checkMesh(const sinew::TriangleMesh& mesh) {
  for (const auto& p : mesh.points)
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z())) __builtin_trap();
  for (const auto& t : mesh.triangles)
    for (auto v : t)
      if (v < 0 || std::size_t(v) >= mesh.points.size()) __builtin_trap();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string name = kNames[data[0] % kNames.size()];
  const auto file = sinew::fuzz::writeFile(name, data + 1, size - 1);
  const sinew::MeshIODescriptor& io = sinew::fuzz::registry().meshIOFor(file);
  try {
    checkMesh(name == "exact.vtp" ? io.readExact(file) : io.read(file));
  } catch (const sinew::InputError&) {
  }
  return 0;
}
