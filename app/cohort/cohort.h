// A cohort: one model and one scene template run over many subjects (docs/cohorts.md). The cohort
// folder holds everything: cohort.json (the subjects, the model, the template), and per subject
// subjects/ID/scene.json, subjects/ID/out/ (sinew-run's outputs), subjects/ID/status.json and
// subjects/ID/run.log. Local runs, Slurm array tasks and the report all work from that folder.
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace sinew::cohort {

using Json = nlohmann::ordered_json;

struct Subject {
  std::string id;  // letters, digits, '.', '_', '-': it names the subject's folder
  std::filesystem::path target;
  std::optional<std::filesystem::path> groundTruth, transform, landmarks;  // landmarks: a JSON file
};

// Reads a manifest: CSV with a header row (columns subject or id, target, and optionally
// ground_truth, transform, landmarks) or JSON ({"subjects": [{"id", "target", ...}]} or the bare
// array). Relative paths are relative to the manifest's folder. Missing images are not checked
// here: such a subject fails in its own task. A malformed manifest is an InputError.
std::vector<Subject> readManifest(const std::filesystem::path& manifest);

// A scene template (a JSON object with a list of structures); an InputError naming the file otherwise.
Json readSceneTemplate(const std::filesystem::path& file);

// Every key of a scene that holds a path (docs/scene-format.md), made absolute against base.
void absolutise(Json& scene, const std::filesystem::path& base);

// The template with the subject's images, ground truth and initialisation put in, every path made
// absolute (relative ones in the template are relative to templateDir), the model replaced when
// given.
Json subjectScene(const Json& sceneTemplate, const std::filesystem::path& templateDir, const Subject& subject,
                  const std::optional<std::filesystem::path>& model);

struct Cohort {
  std::filesystem::path dir;
  std::vector<Subject> subjects;

  std::filesystem::path subjectDir(size_t i) const { return dir / "subjects" / subjects[i].id; }
  std::filesystem::path sceneFile(size_t i) const { return subjectDir(i) / "scene.json"; }
  std::filesystem::path outputDir(size_t i) const { return subjectDir(i) / "out"; }
  std::filesystem::path statusFile(size_t i) const { return subjectDir(i) / "status.json"; }
  std::filesystem::path logFile(size_t i) const { return subjectDir(i) / "run.log"; }
  std::filesystem::path reportDir() const { return dir / "report"; }
};

// Writes (or rewrites) the cohort folder: cohort.json and every subject's scene. A subject whose
// scene cannot be made (its landmarks file is unreadable, say) gets a failed status.json instead,
// naming the problem; the others go on. An existing cohort folder keeps its subjects' outputs.
Cohort prepareCohort(const std::filesystem::path& manifest, const std::filesystem::path& sceneTemplate,
                     const std::optional<std::filesystem::path>& model, const std::filesystem::path& dir);

// Reads a prepared cohort folder (an InputError naming the folder when it is not one).
Cohort loadCohort(const std::filesystem::path& dir);

// The status a subject's task leaves, or what its outputs say when there is none.
struct SubjectStatus {
  std::string status = "pending";  // pending, completed, degraded, failed, interrupted
  int exitCode = -1;               // sinew-run's last exit code; -1: not run, or killed by a signal
  int attempts = 0;
  double seconds = 0.0;            // wall time of every attempt together
  std::string message, backend, host, gpu;
};
SubjectStatus readStatus(const Cohort& cohort, size_t i);
void writeStatus(const Cohort& cohort, size_t i, const SubjectStatus& status);

// A subject is done when sinew-run ended by itself and wrote its outputs: completed, or degraded
// (exit 4: the last good meshes, its report says which check fired). Those are never run again.
bool isDone(const Cohort& cohort, size_t i);

// Exit codes of sinew-cohort (docs/cohorts.md).
inline constexpr int kExitSomeFailed = 5;

// Writes a file by a temporary file and a rename.
void writeFileAtomically(const std::filesystem::path& path, const std::string& text);

}  // namespace sinew::cohort
