#include "cohort_sides.h"

#include "builtin_plugins.h"
#include "label_parts.h"
#include "sinew/core/plugin_loader.h"
#include "sinew/core/types.h"

#include <algorithm>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace sinew::cohort {

namespace fs = std::filesystem;

namespace {
// Name -> "left" or "right" for the model's structures that are one side of a label. A model that
// cannot be read gives none here: sinew-run names its problem.
std::map<std::string, std::string> sidesOfModel(const nlohmann::ordered_json& scene) {
  std::map<std::string, std::string> out;
  if (!scene.contains("model") || !scene["model"].is_string()) return out;
  std::ifstream in(fs::path(scene["model"].get<std::string>()) / "model.json");
  const nlohmann::ordered_json m = nlohmann::ordered_json::parse(in, nullptr, false);
  if (m.is_discarded() || !m.is_object() || !m.contains("structures") || !m["structures"].is_array()) return out;
  for (const nlohmann::ordered_json& s : m["structures"])
    if (s.is_object() && s.contains("name") && s["name"].is_string() && s.contains("side") && s["side"].is_string())
      out[s["name"].get<std::string>()] = s["side"].get<std::string>();
  return out;
}
}  // namespace

std::optional<LabelVolume> splitTruthBySide(nlohmann::ordered_json& scene, const fs::path& partsFile) {
  const std::map<std::string, std::string> sides = sidesOfModel(scene);
  if (sides.empty() || !scene.contains("structures") || !scene["structures"].is_array()) return std::nullopt;
  std::vector<std::int32_t> labels;
  std::string truth;
  for (const nlohmann::ordered_json& s : scene["structures"]) {
    if (!s.contains("ground_truth") || !sides.count(s.value("name", std::string()))) continue;
    truth = s["ground_truth"].value("label_map", std::string());
    const std::int32_t label = s.value("label", 0);
    if (std::find(labels.begin(), labels.end(), label) == labels.end()) labels.push_back(label);
  }
  if (labels.empty()) return std::nullopt;
  Registry registry;
  PluginLoader plugins(registry);
  addBuiltinPlugins(plugins);
  LabelVolume map = registry.imageIOFor(truth).readLabels(truth);
  const std::vector<SideParts> made = splitBySide(map, labels, {}, truth);
  for (const std::int32_t label : labels)
    if (std::none_of(made.begin(), made.end(), [&](const SideParts& p) { return p.label == label; }))
      throw InputError(truth + ": label " + std::to_string(label) +
                       " is not in parts on both sides here, as it is in the model; it cannot be split alike");
  for (nlohmann::ordered_json& s : scene["structures"]) {
    if (!s.contains("ground_truth")) continue;
    s["ground_truth"]["label_map"] = partsFile.string();
    const auto side = sides.find(s.value("name", std::string()));
    if (side == sides.end()) continue;
    const std::int32_t label = s.value("label", 0);
    const SideParts& p = *std::find_if(made.begin(), made.end(), [&](const SideParts& x) { return x.label == label; });
    s["ground_truth"]["label"] = side->second == "left" ? p.left : p.right;
  }
  return map;
}

}  // namespace sinew::cohort
