#include "cohort_sides.h"

#include "label_parts.h"
#include "sinew/core/types.h"

#include <algorithm>
#include <map>
#include <string>
#include <vector>

namespace sinew::cohort {

namespace fs = std::filesystem;

std::optional<LabelVolume> splitTruthBySide(const Registry& registry, nlohmann::ordered_json& scene, const fs::path& partsFile) {
  if (!scene.contains("model") || !scene["model"].is_string() || !scene.contains("structures") || !scene["structures"].is_array())
    return std::nullopt;
  const std::map<std::string, bool> sides = sidesOfModel(scene["model"].get<std::string>());
  if (sides.empty()) return std::nullopt;
  // The sides' labels in the truth: the model's label, whatever the template's truth label was (a
  // template made with a subject's truth holds that subject's side values there). The floor for
  // the new values: every label the scene scores against.
  std::vector<std::int32_t> labels;
  std::int32_t floor = 0;
  std::string truth;
  for (const nlohmann::ordered_json& s : scene["structures"]) {
    if (!s.contains("ground_truth")) continue;
    const std::int32_t label = s.value("label", 0);
    floor = std::max({floor, label, std::int32_t(s["ground_truth"].value("label", 0))});
    if (!sides.count(s.value("name", std::string()))) continue;
    truth = s["ground_truth"].value("label_map", std::string());
    if (std::find(labels.begin(), labels.end(), label) == labels.end()) labels.push_back(label);
  }
  if (labels.empty()) return std::nullopt;
  LabelVolume map = registry.imageIOFor(truth).readLabels(truth);
  const std::vector<SideParts> made = sinew::splitTruthBySide(map, labels, floor, truth, "model");
  for (nlohmann::ordered_json& s : scene["structures"]) {
    if (!s.contains("ground_truth")) continue;
    s["ground_truth"]["label_map"] = partsFile.string();
    const auto side = sides.find(s.value("name", std::string()));
    if (side == sides.end()) continue;
    const std::int32_t label = s.value("label", 0);
    const SideParts& p = *std::find_if(made.begin(), made.end(), [&](const SideParts& x) { return x.label == label; });
    s["ground_truth"]["label"] = side->second ? p.left : p.right;
  }
  return map;
}

}  // namespace sinew::cohort
