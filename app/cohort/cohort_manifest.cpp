// Reading a cohort manifest (CSV or JSON) and putting a subject into the scene template.
#include "cohort.h"

#include "sinew/core/types.h"

#include <fstream>
#include <set>
#include <sstream>

namespace sinew::cohort {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const fs::path& file, const std::string& problem) { throw InputError(file.string() + ": " + problem); }

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r"), e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

// One CSV record: fields separated by commas, a field in double quotes may hold commas and "" for ".
std::vector<std::string> csvFields(const std::string& line, const fs::path& file, int lineNo) {
  std::vector<std::string> out;
  std::string field;
  bool quoted = false, wasQuoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') field += '"', ++i;
      else if (c == '"') quoted = false;
      else field += c;
    } else if (wasQuoted && c != ',' && c != ' ' && c != '\t') {
      fail(file, "line " + std::to_string(lineNo) + ": text after a quoted field");
    } else if (c == '"' && trim(field).empty()) {
      quoted = wasQuoted = true;
      field.clear();
    } else if (c == ',') {
      out.push_back(wasQuoted ? field : trim(field));
      field.clear();
      wasQuoted = false;
    } else {
      field += c;
    }
  }
  if (quoted) fail(file, "line " + std::to_string(lineNo) + ": a quoted field is not closed");
  out.push_back(wasQuoted ? field : trim(field));
  return out;
}

bool validId(const std::string& id) {
  if (id.empty() || id.size() > 128 || id[0] == '.') return false;
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) return false;
  return true;
}

fs::path resolved(const std::string& p, const fs::path& base) {
  const fs::path path(p);
  return (path.is_absolute() ? path : base / path).lexically_normal();
}

std::vector<Subject> readCsv(std::istream& in, const fs::path& file) {
  const fs::path base = fs::absolute(file).parent_path();
  std::vector<Subject> out;
  std::vector<std::string> header;
  int idCol = -1, targetCol = -1, truthCol = -1, transformCol = -1, landmarksCol = -1;
  std::string line;
  for (int lineNo = 1; std::getline(in, line); ++lineNo) {
    if (!line.empty() && line.back() == '\r') line.pop_back();  // written on Windows
    if (lineNo == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // a UTF-8 byte-order mark
    if (trim(line).empty() || trim(line)[0] == '#') continue;
    const auto fields = csvFields(line, file, lineNo);
    if (header.empty()) {
      header = fields;
      for (size_t c = 0; c < header.size(); ++c) {
        const std::string& h = header[c];
        int* slot = h == "subject" || h == "id" ? &idCol : h == "target" ? &targetCol : h == "ground_truth" ? &truthCol
                  : h == "transform" ? &transformCol : h == "landmarks" ? &landmarksCol : nullptr;
        if (!slot) fail(file, "line " + std::to_string(lineNo) + ": unknown column '" + h +
                                  "' (columns: subject, target, ground_truth, transform, landmarks)");
        if (*slot >= 0) fail(file, "line " + std::to_string(lineNo) + ": column '" + h + "' given twice");
        *slot = int(c);
      }
      if (idCol < 0 || targetCol < 0) fail(file, "the header row needs the columns subject and target");
      continue;
    }
    if (fields.size() != header.size())
      fail(file, "line " + std::to_string(lineNo) + ": " + std::to_string(fields.size()) + " fields, the header has " +
                     std::to_string(header.size()));
    Subject s;
    s.id = fields[size_t(idCol)];
    if (fields[size_t(targetCol)].empty()) fail(file, "line " + std::to_string(lineNo) + ": subject '" + s.id + "' has no target");
    s.target = resolved(fields[size_t(targetCol)], base);
    auto optional = [&](int col, std::optional<fs::path>& slot) {
      if (col >= 0 && !fields[size_t(col)].empty()) slot = resolved(fields[size_t(col)], base);
    };
    optional(truthCol, s.groundTruth);
    optional(transformCol, s.transform);
    optional(landmarksCol, s.landmarks);
    out.push_back(std::move(s));
  }
  if (header.empty()) fail(file, "empty manifest (a header row and one row per subject are needed)");
  return out;
}

std::vector<Subject> readJson(std::istream& in, const fs::path& file) {
  const fs::path base = fs::absolute(file).parent_path();
  Json j;
  try {
    j = Json::parse(in);
  } catch (const Json::exception& e) {
    fail(file, std::string("not valid JSON: ") + e.what());
  }
  const Json& list = j.is_object() && j.contains("subjects") ? j["subjects"] : j;
  if (!list.is_array()) fail(file, "expected {\"subjects\": [...]} or an array of subjects");
  std::vector<Subject> out;
  for (size_t i = 0; i < list.size(); ++i) {
    const Json& e = list[i];
    const std::string where = "subjects[" + std::to_string(i) + "]";
    if (!e.is_object()) fail(file, where + ": expected an object");
    for (const auto& [key, value] : e.items()) {
      if (key != "id" && key != "subject" && key != "target" && key != "ground_truth" && key != "transform" && key != "landmarks")
        fail(file, where + "." + key + ": unknown key (keys: id, target, ground_truth, transform, landmarks)");
      if (!value.is_string() || value.get<std::string>().empty()) fail(file, where + "." + key + ": expected a non-empty string");
    }
    Subject s;
    s.id = e.contains("id") ? e["id"].get<std::string>() : e.value("subject", std::string());
    if (!e.contains("target")) fail(file, where + ": no target");
    s.target = resolved(e["target"].get<std::string>(), base);
    if (e.contains("ground_truth")) s.groundTruth = resolved(e["ground_truth"].get<std::string>(), base);
    if (e.contains("transform")) s.transform = resolved(e["transform"].get<std::string>(), base);
    if (e.contains("landmarks")) s.landmarks = resolved(e["landmarks"].get<std::string>(), base);
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace

std::vector<Subject> readManifest(const fs::path& manifest) {
  std::ifstream in(manifest);
  if (!in) fail(manifest, "cannot open the manifest");
  std::vector<Subject> subjects = manifest.extension() == ".json" ? readJson(in, manifest) : readCsv(in, manifest);
  if (subjects.empty()) fail(manifest, "no subjects");
  std::set<std::string> seen;
  for (const Subject& s : subjects) {
    if (!validId(s.id))
      fail(manifest, "subject id '" + s.id + "': use letters, digits, '.', '_' and '-' (it names a folder)");
    if (!seen.insert(s.id).second) fail(manifest, "subject id '" + s.id + "' appears twice");
    if (s.transform && s.landmarks) fail(manifest, "subject '" + s.id + "': give a transform or landmarks, not both");
  }
  return subjects;
}

void absolutise(Json& scene, const fs::path& base) {
  auto fix = [&](Json& parent, const char* key) {
    if (parent.is_object() && parent.contains(key) && parent[key].is_string()) {
      const fs::path p(parent[key].get<std::string>());
      if (p.is_relative()) parent[key] = (base / p).lexically_normal().string();
    }
  };
  if (scene.contains("images")) {
    fix(scene["images"], "target");
    fix(scene["images"], "training");
  }
  fix(scene, "model");
  if (scene.contains("model")) fix(scene["model"], "path");
  if (scene.contains("initialise")) {
    fix(scene["initialise"], "moving_image");
    fix(scene["initialise"], "transform");
  }
  if (scene.contains("structures") && scene["structures"].is_array())
    for (Json& s : scene["structures"]) {
      for (const char* part : {"reference", "ground_truth"})
        if (s.contains(part)) {
          fix(s[part], "mesh");
          fix(s[part], "label_map");
        }
      if (s.contains("initial")) fix(s["initial"], "mesh");
    }
}

Json subjectScene(const Json& sceneTemplate, const fs::path& templateDir, const Subject& subject,
                  const std::optional<fs::path>& model) {
  Json scene = sceneTemplate;
  absolutise(scene, templateDir);
  scene["description"] = "cohort subject " + subject.id;
  scene["images"]["target"] = subject.target.string();
  if (model) scene["model"] = fs::absolute(*model).lexically_normal().string();
  if (scene.contains("structures") && scene["structures"].is_array())
    for (Json& s : scene["structures"]) {
      if (!subject.groundTruth) {
        s.erase("ground_truth");
        continue;
      }
      // The template's label of the structure in its ground truth, else its own label.
      const Json label = s.contains("ground_truth") && s["ground_truth"].contains("label") ? s["ground_truth"]["label"]
                         : s.contains("label")                                              ? s["label"]
                                                                                            : Json(1);
      s["ground_truth"] = {{"label_map", subject.groundTruth->string()}, {"label", label}};
    }
  if (subject.transform) {
    scene["initialise"] = {{"transform", subject.transform->string()}};
  } else if (subject.landmarks) {
    std::ifstream in(*subject.landmarks);
    if (!in) fail(*subject.landmarks, "cannot open the landmarks file");
    Json pairs = Json::parse(in, nullptr, false);
    if (pairs.is_object() && pairs.contains("landmarks")) pairs = pairs["landmarks"];
    if (!pairs.is_array())
      fail(*subject.landmarks, "expected a JSON array of {\"model\": [x, y, z], \"target\": [x, y, z]} pairs");
    Json init = {{"landmarks", pairs}};
    if (sceneTemplate.contains("initialise") && sceneTemplate["initialise"].contains("landmark_fit"))
      init["landmark_fit"] = sceneTemplate["initialise"]["landmark_fit"];
    scene["initialise"] = init;
  }
  return scene;
}

}  // namespace sinew::cohort
