#include "cohort_learning.h"

#include "builtin_plugins.h"
#include "collision_share_learning.h"
#include "sinew/core/plugin_loader.h"
#include "sinew/core/types.h"

#include <iostream>

namespace sinew::cohort {

namespace fs = std::filesystem;

namespace {

// Sets the collision force's weight to 0 in one "forces" block; true where it was above 0.
bool switchOff(Json& forces) {
  if (!forces.is_object() || !forces.contains("collision") || !forces["collision"].is_object()) return false;
  Json& collision = forces["collision"];
  const bool on = collision.contains("weight") && collision["weight"].is_number() && collision["weight"].get<double>() > 0.0;
  collision["weight"] = 0.0;
  return on;
}

// The scene without collisions anywhere it may set their weight (the scene, its levels, its
// structures; docs/scene-format.md); false when they were off already.
bool withoutCollisions(Json& scene) {
  bool on = scene.contains("forces") && switchOff(scene["forces"]);
  for (const char* list : {"schedule", "structures"})
    if (scene.contains(list) && scene[list].is_array())
      for (Json& item : scene[list])
        if (item.is_object() && item.contains("forces")) on = switchOff(item["forces"]) || on;
  scene.erase("collision_shares");
  return on;
}

}  // namespace

Cohort prepareLearning(const fs::path& manifest, const fs::path& sceneTemplate, const std::optional<fs::path>& model,
                       const fs::path& dir, const ShareLearning& learning) {
  Json learningScene = readSceneTemplate(sceneTemplate);
  absolutise(learningScene, fs::absolute(sceneTemplate).parent_path());
  if (!withoutCollisions(learningScene))
    throw InputError(sceneTemplate.string() + ": --learn-collision-shares: the template has no collisions to share "
                     "(the collision force's weight is 0 everywhere)");
  Json chosen = Json::array();
  for (const Subject& s : readManifest(manifest)) {
    if (!s.groundTruth || int(chosen.size()) == learning.subjects) continue;
    Json j = {{"id", s.id}, {"target", fs::absolute(s.target).string()},
              {"ground_truth", fs::absolute(*s.groundTruth).string()}};
    if (s.transform) j["transform"] = fs::absolute(*s.transform).string();
    if (s.landmarks) j["landmarks"] = fs::absolute(*s.landmarks).string();
    chosen.push_back(j);
  }
  if (chosen.empty())
    throw InputError(manifest.string() + ": --learn-collision-shares: no subject has a ground_truth to learn from");
  const fs::path learnDir = fs::absolute(dir) / "learning";
  std::error_code ec;
  fs::create_directories(learnDir, ec);
  if (ec) throw InputError(learnDir.string() + ": cannot create: " + ec.message());
  writeFileAtomically(learnDir / "manifest.json", Json{{"subjects", chosen}}.dump(2) + "\n");
  writeFileAtomically(learnDir / "template.json", learningScene.dump(2) + "\n");
  return prepareCohort(learnDir / "manifest.json", learnDir / "template.json", model, learnDir);
}

bool learningDone(const Cohort& learners) {
  for (size_t i = 0; i < learners.subjects.size(); ++i)
    if (!isDone(learners, i)) return false;
  return true;
}

fs::path learnFromRuns(const Cohort& learners, const fs::path& sceneTemplate, const fs::path& dir,
                       const ShareLearning& learning, bool quiet) {
  std::vector<std::string> runs, from;
  for (size_t i = 0; i < learners.subjects.size(); ++i)
    if (isDone(learners, i) && readStatus(learners, i).status == "completed") {
      runs.push_back(learners.outputDir(i).string());
      from.push_back(learners.subjects[i].id);
    }
  if (runs.empty())
    throw InputError(learners.dir.string() + ": --learn-collision-shares: no learning run completed (each subject's "
                     "run.log under subjects/ says why)");
  Json tmpl = readSceneTemplate(sceneTemplate);
  absolutise(tmpl, fs::absolute(sceneTemplate).parent_path());
  Registry registry;
  PluginLoader plugins(registry);
  addBuiltinPlugins(plugins);
  std::vector<std::string> names;
  for (const Json& s : tmpl["structures"])
    if (s.contains("name") && s["name"].is_string()) names.push_back(s["name"].get<std::string>());
  const nlohmann::json learned =
      collisionSharesFor(learnContactSides(registry, runs), names, Index(learning.minContacts));
  const Json shares = Json::parse(learned.dump());
  writeFileAtomically(learners.dir / "shares.json",
                      Json{{"from", from}, {"min_contacts", learning.minContacts}, {"collision_shares", shares}}.dump(2) + "\n");
  if (shares.empty()) tmpl.erase("collision_shares");
  else tmpl["collision_shares"] = shares;
  if (!quiet)
    std::cerr << "sinew-cohort: collision shares by pair: " << shares.size() << " pair(s) learned from " << from.size()
              << " subject(s)" << (shares.empty() ? " (no pair touched often enough: the shares by size stay)" : "")
              << "\n";
  const fs::path out = fs::absolute(dir) / "template-shares.json";
  writeFileAtomically(out, tmpl.dump(2) + "\n");
  return out;
}

fs::path learnCollisionShares(const fs::path& manifest, const fs::path& sceneTemplate, const std::optional<fs::path>& model,
                              const fs::path& dir, const ShareLearning& learning, const LocalOptions& local) {
  const Cohort learners = prepareLearning(manifest, sceneTemplate, model, dir, learning);
  if (!local.quiet)
    std::cerr << "sinew-cohort: learning the collision's shares from " << learners.subjects.size()
              << " labelled subject(s), each run without collisions in " << learners.dir.string() << "\n";
  runLocal(learners, local);
  return learnFromRuns(learners, sceneTemplate, dir, learning, local.quiet);
}

}  // namespace sinew::cohort
