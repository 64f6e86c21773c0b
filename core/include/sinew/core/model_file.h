// Reusable models (docs/model-format.md): built once from an atlas by sinew-build-model, named by
// scenes ("model": "putamen-model/"), loaded instead of rebuilt. A model is a folder: model.json
// (format version, provenance, the file list with CRC-32 checksums), the atlas image the model was
// trained on, and per structure its level-0 topology and its reference shape at every level as VTK
// XML meshes.
#pragma once

#include "sinew/core/level_of_detail.h"
#include "sinew/core/registry.h"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace sinew {

inline constexpr int kModelFormatVersion = 1;

struct ModelStructure {
  std::string name;
  int label = 0;
  LevelHierarchy levels;
  std::vector<std::vector<Vec3>> positions;  // reference shape per level
  // "left" or "right": one side of a label in parts on both sides (sinew-build-model
  // --split-parts), whose subjects' ground truths are split alike; empty: the whole label.
  std::string side;
};

struct ModelInput {
  std::string role;  // "labels", "label_list", "atlas_image", "mesh"
  std::filesystem::path path;
  std::uintmax_t bytes = 0;
  std::uint32_t crc32 = 0;
};

struct Model {
  std::filesystem::path folder;  // where it was read from (empty for a model being built)
  std::vector<ModelStructure> structures;
  std::filesystem::path atlasImage;  // the image the model is trained on (inside the folder once written)
  double coarseSpacingMm = 4.0;
  int relaxIterations = 10;
  std::vector<ModelInput> inputs;  // provenance
  std::string createdBy;           // "sinew-build-model 0.1.0"
  std::string created;             // UTC, ISO 8601

  int levelCount() const { return structures.empty() ? 0 : structures.front().levels.levelCount(); }
  // The structure of that name, or null.
  const ModelStructure* find(const std::string& name) const;
};

// A model structure's "side": true for "left", false for "right"; an InputError "WHERE: "side"
// must be ..." for anything else.
bool isLeftSide(const std::string& side, const std::string& where);

// CRC-32 (zlib's) of a file's bytes; throws InputError naming the file when it cannot be read.
std::uint32_t fileCrc32(const std::filesystem::path& file);
ModelInput describeInput(const std::string& role, const std::filesystem::path& file);

// Writes the model folder through a staging folder beside it, renamed into place at the end, so a
// failure leaves nothing half-written. Refuses to replace an existing folder that is not a model.
void writeModel(const Registry& registry, const Model& model, const std::filesystem::path& folder);
// Reads and checks a model folder (format and version, every file's checksum, topologies); throws
// InputError naming the file and the problem.
Model readModel(const Registry& registry, const std::filesystem::path& folder);

}  // namespace sinew
