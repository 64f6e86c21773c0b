#include "collision_share_learning.h"

#include "sinew/core/io.h"
#include "sinew/core/scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

namespace fs = std::filesystem;

namespace sinew {

namespace {
// Whether the collision force acts anywhere in the scene: a weight above 0 for the scene, a level
// or a structure (the force's own default weight is 0).
bool collides(const SceneDesc& scene) {
  const auto weighs = [](const ForceSettings& forces) {
    for (const auto& [force, params] : forces)
      if (force == "collision")
        for (const auto& [name, value] : params)
          if (name == "weight" && value > 0.0) return true;
    return false;
  };
  if (weighs(scene.forces)) return true;
  for (const LevelDesc& level : scene.schedule)
    if (weighs(level.forces)) return true;
  for (const StructureDesc& s : scene.structures)
    if (weighs(s.forces)) return true;
  return false;
}
}  // namespace

ContactSidesByName learnContactSides(const Registry& registry, const std::vector<std::string>& runDirs) {
  std::map<std::string, LabelVolume> labelMaps;  // read once for all the runs
  std::map<std::pair<std::string, std::string>, ContactSide> sums;  // by the pair's names, over the runs
  for (const std::string& dir : runDirs) {
    const fs::path reportFile = fs::path(dir) / "report.json";
    std::ifstream in(reportFile);
    if (!in) throw InputError(reportFile.string() + ": no report (give the folders of finished sinew-run runs)");
    const nlohmann::json report = nlohmann::json::parse(in, nullptr, false);
    if (report.is_discarded() || !report.contains("scene") || !report["scene"].is_string())
      throw InputError(reportFile.string() + ": not a sinew-run report (no \"scene\")");
    const SceneDesc scene = readScene(report["scene"].get<std::string>());
    if (collides(scene))
      throw InputError(scene.file.string() + ": the run in " + dir + " collided; learn shares from runs without "
                       "collisions (sinew-make-scene --collision-weight 0)");
    std::vector<std::vector<Vec3>> points;
    std::vector<const LabelVolume*> truths;
    std::vector<int> labels;
    for (const StructureDesc& s : scene.structures) {
      if (!s.groundTruth)
        throw InputError(scene.file.string() + ": structure '" + s.name + "' has no ground truth to learn from");
      const fs::path mesh = fs::path(dir) / (s.name + scene.meshFormat);
      if (!fs::exists(mesh)) throw InputError(mesh.string() + ": no such file (the run's mesh of '" + s.name + "')");
      points.push_back(registry.meshIOFor(mesh).read(mesh).points);
      const std::string map = s.groundTruth->labelMap.string();
      auto it = labelMaps.find(map);
      if (it == labelMaps.end()) it = labelMaps.emplace(map, registry.imageIOFor(map).readLabels(map)).first;
      truths.push_back(&it->second);
      labels.push_back(s.groundTruth->label);
    }
    const std::vector<ContactSide> counts = countContactSides(points, truths, labels);
    const size_t n = scene.structures.size();
    for (size_t a = 0; a < n; ++a)
      for (size_t b = 0; b < n; ++b)
        if (a != b) {
          ContactSide& sum = sums[{scene.structures[a].name, scene.structures[b].name}];
          sum.contact += counts[a * n + b].contact;
          sum.inOtherTruth += counts[a * n + b].inOtherTruth;
        }
  }
  ContactSidesByName out;
  for (const auto& [pair, c] : sums)  // the map's order: every name as a first member, sorted
    if (out.names.empty() || out.names.back() != pair.first) out.names.push_back(pair.first);
  const size_t n = out.names.size();
  out.counts.assign(n * n, {});
  const auto index = [&](const std::string& name) {
    return size_t(std::lower_bound(out.names.begin(), out.names.end(), name) - out.names.begin());
  };
  for (const auto& [pair, c] : sums) out.counts[index(pair.first) * n + index(pair.second)] = c;
  return out;
}

nlohmann::json collisionSharesFor(const ContactSidesByName& learned, const std::vector<std::string>& structures,
                                  Index minContacts) {
  nlohmann::json out = nlohmann::json::array();
  const Index n = Index(learned.names.size());
  for (const PairShares& p : sharesFromContactSides(learned.counts, n, minContacts)) {
    const std::string &a = learned.names[size_t(p.a)], &b = learned.names[size_t(p.b)];
    const bool inScene = std::count(structures.begin(), structures.end(), a) && std::count(structures.begin(), structures.end(), b);
    // Rounded to 4 digits, as a user reads them: a share is a proportion, not a measurement.
    const auto rounded = [](double v) { return std::round(v * 1e4) / 1e4; };
    if (inScene) out.push_back({{"pair", {a, b}}, {"shares", {rounded(p.aShare), rounded(p.bShare)}}});
  }
  return out;
}

}  // namespace sinew
