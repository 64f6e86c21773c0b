#include "sinew/core/model_file.h"

#include "json_integer.h"

#include <nlohmann/json.hpp>
#include <zlib.h>

#include <cstdio>
#include <fstream>
#include <limits>
#include <unistd.h>

namespace sinew {

namespace {
namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

std::string hex(std::uint32_t v) {
  char b[16];
  std::snprintf(b, sizeof b, "%08x", v);
  return b;
}

std::uint32_t parseHex(const std::string& s, const fs::path& file) {
  try {
    size_t used = 0;
    const unsigned long v = std::stoul(s, &used, 16);
    if (used == s.size() && s.size() == 8) return static_cast<std::uint32_t>(v);
  } catch (const std::exception&) {
  }
  throw InputError(file.string() + ": '" + s + "' is not a CRC-32 (8 hex digits)");
}

// Level 0's topology is stored as its dual triangle mesh (one triangle per simplex vertex, in
// vertex order); each level's reference shape as the Fig. 1b tessellation, whose first points are
// the simplex vertices in order. Both are read back exactly as written.
fs::path topologyFile(const std::string& structure) { return fs::path("structures") / structure / "topology.vtp"; }
fs::path levelFile(const std::string& structure, int level) {
  return fs::path("structures") / structure / ("level" + std::to_string(level) + ".vtp");
}

Json inputJson(const ModelInput& in) {
  return {{"role", in.role}, {"path", in.path.string()}, {"bytes", in.bytes}, {"crc32", hex(in.crc32)}};
}
}  // namespace

const ModelStructure* Model::find(const std::string& name) const {
  for (const auto& s : structures)
    if (s.name == name) return &s;
  return nullptr;
}

std::uint32_t fileCrc32(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file.string() + ": cannot be opened");
  // 64 KB: a zero-filled megabyte per file was a quarter of reading a small model (fuzz_model's profile).
  std::vector<char> buffer(1 << 16);
  uLong crc = crc32(0L, Z_NULL, 0);
  while (in) {
    in.read(buffer.data(), std::streamsize(buffer.size()));
    const auto n = in.gcount();
    if (n > 0) crc = crc32(crc, reinterpret_cast<const Bytef*>(buffer.data()), uInt(n));
  }
  if (in.bad()) throw InputError(file.string() + ": read error");
  return static_cast<std::uint32_t>(crc);
}

ModelInput describeInput(const std::string& role, const fs::path& file) {
  ModelInput in;
  in.role = role;
  in.path = fs::absolute(file).lexically_normal();
  std::error_code ec;
  in.bytes = fs::file_size(file, ec);
  if (ec) throw InputError(file.string() + ": " + ec.message());
  in.crc32 = fileCrc32(file);
  return in;
}

bool isLeftSide(const std::string& side, const std::string& where) {
  if (side != "left" && side != "right")
    throw InputError(where + ": \"side\" must be \"left\" or \"right\", not \"" + side + "\"");
  return side == "left";
}

void writeModel(const Registry& registry, const Model& model, const fs::path& folder) {
  if (model.structures.empty()) throw InputError(folder.string() + ": a model needs at least one structure");
  // Each structure's files live in a folder of its name: two of one name would overwrite each other.
  for (size_t i = 0; i < model.structures.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (model.structures[i].name == model.structures[j].name)
        throw InputError(folder.string() + ": two structures are named '" + model.structures[i].name + "'");
  std::error_code ec;
  if (fs::exists(folder, ec) && !fs::exists(folder / "model.json", ec))
    throw InputError(folder.string() + ": exists and is not a Sinew model; refusing to replace it");
  const fs::path parent = fs::absolute(folder).lexically_normal().parent_path();
  fs::create_directories(parent);
  const fs::path staging = parent / ("." + folder.filename().string() + ".sinew-staging-" + std::to_string(getpid()));
  fs::remove_all(staging, ec);
  struct Cleanup {
    fs::path p;
    bool keep = false;
    ~Cleanup() {
      std::error_code e;
      if (!keep) fs::remove_all(p, e);
    }
  } cleanup{staging};

  Json j;
  j["format"] = "sinew-model";
  j["version"] = kModelFormatVersion;
  j["created_by"] = model.createdBy;
  j["created"] = model.created;
  j["parameters"] = {{"coarse_spacing_mm", model.coarseSpacingMm},
                     {"levels", model.levelCount()},
                     {"relax_iterations", model.relaxIterations}};
  Json inputs = Json::array();
  for (const auto& in : model.inputs) inputs.push_back(inputJson(in));
  j["inputs"] = inputs;
  Json files = Json::object();
  auto record = [&](const fs::path& relative) { files[relative.generic_string()] = hex(fileCrc32(staging / relative)); };

  fs::create_directories(staging);
  const std::string atlasName = "atlas" + ioExtension(model.atlasImage);
  fs::copy_file(model.atlasImage, staging / atlasName, ec);
  if (ec) throw InputError(model.atlasImage.string() + ": cannot copy into the model: " + ec.message());
  record(atlasName);
  j["atlas_image"] = atlasName;

  const MeshIODescriptor& io = registry.meshIOFor("mesh.vtp");
  Json structures = Json::array();
  for (const ModelStructure& s : model.structures) {
    fs::create_directories(staging / "structures" / s.name);
    const SimplexTopology& t0 = s.levels.levels[0];
    io.write(staging / topologyFile(s.name), dualTriangleMesh(t0, s.positions[0]));
    record(topologyFile(s.name));
    Json counts = Json::array();
    for (int l = 0; l < s.levels.levelCount(); ++l) {
      io.write(staging / levelFile(s.name, l), tessellate(s.levels.levels[l], s.positions[l]));
      record(levelFile(s.name, l));
      counts.push_back(s.levels.levels[l].vertexCount());
    }
    structures.push_back({{"name", s.name}, {"label", s.label}, {"vertices", counts}});
    if (!s.side.empty()) structures.back()["side"] = s.side;
  }
  j["structures"] = structures;
  j["files"] = files;
  {
    std::ofstream out(staging / "model.json");
    out << j.dump(2) << "\n";
    if (!out.flush()) throw InputError(folder.string() + ": cannot write model.json");
  }
  // Replace an older model only once the new one is complete.
  if (fs::exists(folder, ec)) fs::remove_all(folder);
  fs::rename(staging, folder, ec);
  if (ec) throw InputError(folder.string() + ": cannot move the model into place: " + ec.message());
  cleanup.keep = true;
}

Model readModel(const Registry& registry, const fs::path& folder) {
  const fs::path manifest = folder / "model.json";
  std::ifstream in(manifest);
  if (!in) throw InputError(manifest.string() + ": cannot open the model (is " + folder.string() + " a Sinew model?)");
  Json j;
  try {
    j = Json::parse(in);
  } catch (const Json::exception& e) {
    throw InputError(manifest.string() + ": not valid JSON: " + e.what());
  }
  auto fail = [&](const std::string& problem) -> void { throw InputError(manifest.string() + ": " + problem); };
  // An integer field of T's range (json_integer.h).
  const auto integer = [&]<class T>(const Json& v, const std::string& what, T) -> T {
    const std::optional<T> i = integerOf<T>(v);
    if (!i) fail("\"" + what + "\" must be a whole number from " + std::to_string(std::numeric_limits<T>::min()) + " to " +
                 std::to_string(std::numeric_limits<T>::max()) + ", not " + v.dump());
    return *i;
  };
  try {
    if (j.value("format", "") != "sinew-model") fail("not a Sinew model (\"format\" is not \"sinew-model\")");
    const int version = integer(j.at("version"), "version", int());
    if (version != kModelFormatVersion)
      fail("model format version " + std::to_string(version) + " is not supported (this Sinew reads version " +
           std::to_string(kModelFormatVersion) + "); rebuild it with sinew-build-model");
    Model m;
    m.folder = folder;
    m.createdBy = j.value("created_by", "");
    m.created = j.value("created", "");
    m.coarseSpacingMm = j.at("parameters").at("coarse_spacing_mm").get<double>();
    m.relaxIterations = integer(j.at("parameters").at("relax_iterations"), "relax_iterations", int());
    const int levels = integer(j.at("parameters").at("levels"), "levels", int());
    if (levels < 1 || levels > 6) fail("parameters/levels must be 1 to 6");
    for (const auto& in : j.at("inputs"))
      m.inputs.push_back({in.at("role").get<std::string>(), in.at("path").get<std::string>(),
                          integer(in.at("bytes"), "bytes", std::uintmax_t()), parseHex(in.at("crc32").get<std::string>(), manifest)});
    const auto& files = j.at("files");
    auto checked = [&](const fs::path& relative) {
      const std::string key = relative.generic_string();
      if (!files.contains(key)) fail("the file list does not name " + key);
      const fs::path p = folder / relative;
      const std::uint32_t want = parseHex(files.at(key).get<std::string>(), manifest);
      const std::uint32_t got = fileCrc32(p);
      if (got != want)
        throw InputError(p.string() + ": checksum mismatch (CRC-32 " + hex(got) + ", the model says " + hex(want) +
                         "): the model is damaged; rebuild it");
      return p;
    };
    m.atlasImage = checked(j.at("atlas_image").get<std::string>());
    for (const auto& s : j.at("structures")) {
      ModelStructure ms;
      ms.name = s.at("name").get<std::string>();
      if (ms.name.empty() || ms.name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.") !=
                                 std::string::npos || ms.name[0] == '.')
        fail("structure name '" + ms.name + "' is not a plain name");
      ms.label = integer(s.at("label"), "label", int());
      ms.side = s.value("side", "");
      if (!ms.side.empty()) isLeftSide(ms.side, manifest.string() + ": structure '" + ms.name + "'");
      if (!s.at("vertices").is_array()) fail("structure '" + ms.name + "': \"vertices\" must be a list of counts");
      std::vector<Index> counts;
      for (const Json& c : s.at("vertices")) counts.push_back(integer(c, "vertices", Index()));
      if (int(counts.size()) != levels) fail("structure '" + ms.name + "': vertex counts for " +
                                             std::to_string(counts.size()) + " levels, " + std::to_string(levels) + " expected");
      const fs::path topo = checked(topologyFile(ms.name));
      const TriangleMesh dual = registry.exactMeshReaderFor(topo).readExact(topo);
      try {
        ms.levels = LevelHierarchy::build(SimplexTopology::dualOf(dual), levels);
      } catch (const InputError& e) {
        throw InputError(topo.string() + ": " + e.what());
      }
      for (int l = 0; l < levels; ++l) {
        const fs::path p = checked(levelFile(ms.name, l));
        TriangleMesh t = registry.exactMeshReaderFor(p).readExact(p);
        const Index n = ms.levels.levels[l].vertexCount();
        if (n != counts[l] || Index(t.points.size()) < n)
          throw InputError(p.string() + ": " + std::to_string(t.points.size()) + " points; level " + std::to_string(l) +
                           " of '" + ms.name + "' has " + std::to_string(n) + " vertices");
        t.points.resize(n);
        for (const Vec3& x : t.points)
          if (!x.allFinite()) throw InputError(p.string() + ": non-finite point");
        ms.positions.push_back(std::move(t.points));
      }
      m.structures.push_back(std::move(ms));
    }
    if (m.structures.empty()) fail("the model has no structure");
    return m;
  } catch (const Json::exception& e) {
    throw InputError(manifest.string() + ": malformed model manifest: " + e.what());
  }
}

}  // namespace sinew
