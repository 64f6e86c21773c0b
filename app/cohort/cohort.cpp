// The cohort folder: preparing it from a manifest and a template, reading it back, and the status
// each subject's task leaves.
#include "cohort.h"

#include "builtin_plugins.h"
#include "cohort_sides.h"
#include "sinew/core/io.h"
#include "sinew/core/plugin_loader.h"
#include "sinew/core/types.h"

#include <fstream>
#include <sstream>

namespace sinew::cohort {

namespace fs = std::filesystem;

namespace {

constexpr const char* kFormat = "sinew-cohort";
constexpr int kVersion = 1;

Json readJsonFile(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError(file.string() + ": cannot open");
  try {
    return Json::parse(in);
  } catch (const Json::exception& e) {
    throw InputError(file.string() + ": not valid JSON: " + e.what());
  }
}

std::string readText(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

Json subjectJson(const Subject& s) {
  Json j = {{"id", s.id}, {"target", s.target.string()}};
  if (s.groundTruth) j["ground_truth"] = s.groundTruth->string();
  if (s.transform) j["transform"] = s.transform->string();
  if (s.landmarks) j["landmarks"] = s.landmarks->string();
  return j;
}

}  // namespace

void writeFileAtomically(const fs::path& path, const std::string& text) {
  AtomicOutput out(path);
  {
    std::ofstream f(out.tempPath(), std::ios::binary);
    f << text;
    f.close();
    if (!f) throw InputError(path.string() + ": cannot write");
  }
  out.commit();
}

Json readSceneTemplate(const fs::path& file) {
  Json tmpl = readJsonFile(file);
  if (!tmpl.is_object() || !tmpl.contains("structures") || !tmpl["structures"].is_array())
    throw InputError(file.string() + ": not a scene (no structures); make one with sinew-make-scene --model");
  return tmpl;
}

Cohort prepareCohort(const fs::path& manifest, const fs::path& sceneTemplate, const std::optional<fs::path>& model,
                     const fs::path& dir) {
  Cohort c;
  c.dir = fs::absolute(dir).lexically_normal();
  c.subjects = readManifest(manifest);
  const Json tmpl = readSceneTemplate(sceneTemplate);
  if (model && !fs::exists(*model / "model.json")) throw InputError(model->string() + ": not a Sinew model (no model.json)");
  const fs::path templateDir = fs::absolute(sceneTemplate).parent_path();

  std::error_code ec;
  fs::create_directories(c.dir / "subjects", ec);
  if (ec) throw InputError(c.dir.string() + ": cannot create the cohort folder: " + ec.message());
  Json subjects = Json::array();
  for (const Subject& s : c.subjects) subjects.push_back(subjectJson(s));
  Json j = {{"format", kFormat}, {"version", kVersion},
            {"manifest", fs::absolute(manifest).lexically_normal().string()},
            {"template", fs::absolute(sceneTemplate).lexically_normal().string()}, {"subjects", subjects}};
  if (model) j["model"] = fs::absolute(*model).lexically_normal().string();

  Registry registry;  // the subjects' ground truths, where the model's sides split them
  PluginLoader plugins(registry);
  addBuiltinPlugins(plugins);
  for (size_t i = 0; i < c.subjects.size(); ++i) {
    fs::create_directories(c.subjectDir(i), ec);
    if (ec) throw InputError(c.subjectDir(i).string() + ": cannot create: " + ec.message());
    std::string scene;
    bool unchanged = false;
    try {
      Json sceneJson = subjectScene(tmpl, templateDir, c.subjects[i], model);
      const fs::path partsFile = c.subjectDir(i) / "truth-parts.nii.gz";
      const std::optional<LabelVolume> truthParts = splitTruthBySide(registry, sceneJson, partsFile);
      scene = sceneJson.dump(2) + "\n";
      // A changed scene (another template or manifest entry) makes earlier outputs stale.
      unchanged = fs::exists(c.sceneFile(i)) && readText(c.sceneFile(i)) == scene;
      // The split truth, before the scene that names it: written again unless the subject is done
      // with this very scene, so that a truth replaced at the same path is not scored as it was.
      if (truthParts && !(unchanged && isDone(c, i) && fs::exists(partsFile))) {
        AtomicOutput parts(partsFile);
        registry.imageIOFor(partsFile).writeLabels(parts.tempPath(), *truthParts);
        parts.commit();
      }
    } catch (const InputError& e) {
      // This subject cannot run; the others can.
      fs::remove(c.sceneFile(i), ec);
      SubjectStatus st;
      st.status = "failed";
      st.exitCode = 3;
      st.message = e.what();
      writeStatus(c, i, st);
      continue;
    }
    if (unchanged) continue;
    fs::remove(c.statusFile(i), ec);
    fs::remove(c.outputDir(i) / "report.json", ec);
    writeFileAtomically(c.sceneFile(i), scene);
  }
  writeFileAtomically(c.dir / "cohort.json", j.dump(2) + "\n");
  return c;
}

Cohort loadCohort(const fs::path& dir) {
  const fs::path file = dir / "cohort.json";
  if (!fs::exists(file))
    throw InputError(dir.string() + ": not a cohort folder (no cohort.json); prepare it with sinew-cohort run or slurm and a manifest");
  const Json j = readJsonFile(file);
  if (j.value("format", std::string()) != kFormat || !j.contains("subjects") || !j["subjects"].is_array())
    throw InputError(file.string() + ": not a sinew-cohort file");
  if (j.value("version", 0) != kVersion)
    throw InputError(file.string() + ": cohort format version " + std::to_string(j.value("version", 0)) +
                     ", this sinew-cohort reads version " + std::to_string(kVersion));
  Cohort c;
  c.dir = fs::absolute(dir).lexically_normal();
  try {
    for (const Json& s : j["subjects"]) {
      Subject sub;
      sub.id = s.at("id").get<std::string>();
      sub.target = s.at("target").get<std::string>();
      if (s.contains("ground_truth")) sub.groundTruth = s["ground_truth"].get<std::string>();
      if (s.contains("transform")) sub.transform = s["transform"].get<std::string>();
      if (s.contains("landmarks")) sub.landmarks = s["landmarks"].get<std::string>();
      c.subjects.push_back(std::move(sub));
    }
  } catch (const Json::exception& e) {
    throw InputError(file.string() + ": damaged subject list: " + e.what());
  }
  return c;
}

SubjectStatus readStatus(const Cohort& cohort, size_t i) {
  SubjectStatus st;
  if (!fs::exists(cohort.statusFile(i))) return st;
  try {
    std::ifstream in(cohort.statusFile(i));
    const Json j = Json::parse(in);
    st.status = j.value("status", std::string("pending"));
    st.exitCode = j.value("exit_code", -1);
    st.attempts = j.value("attempts", 0);
    st.seconds = j.value("seconds", 0.0);
    st.message = j.value("message", std::string());
    st.backend = j.value("backend", std::string());
    st.host = j.value("host", std::string());
    st.gpu = j.value("gpu", std::string());
  } catch (const Json::exception&) {
    st = SubjectStatus{};  // a status cut short by a kill: the subject runs again
  }
  return st;
}

void writeStatus(const Cohort& cohort, size_t i, const SubjectStatus& st) {
  Json j = {{"subject", cohort.subjects[i].id}, {"status", st.status}, {"exit_code", st.exitCode},
            {"attempts", st.attempts}, {"seconds", st.seconds}, {"message", st.message}};
  if (!st.backend.empty()) j["backend"] = st.backend;
  if (!st.host.empty()) j["host"] = st.host;
  if (!st.gpu.empty()) j["gpu"] = st.gpu;
  writeFileAtomically(cohort.statusFile(i), j.dump(2) + "\n");
}

bool isDone(const Cohort& cohort, size_t i) {
  const SubjectStatus st = readStatus(cohort, i);
  return (st.status == "completed" || st.status == "degraded") && fs::exists(cohort.outputDir(i) / "report.json");
}

}  // namespace sinew::cohort
