// SceneRunner's loaded state, shared by its source files (scene_runner.cpp loads and runs,
// scene_runner_evaluation.cpp scores). Private to core/src.
#pragma once

#include "sinew/core/model_file.h"
#include "sinew/core/sampled_error.h"
#include "sinew/core/scene_runner.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <future>
#include <map>
#include <memory>
#include <mutex>

namespace sinew {

using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Throws InputError naming the scene file and the JSON path ("/initialise/transform").
[[noreturn]] void sceneError(const SceneDesc& s, const std::string& where, const std::string& problem);

struct SceneRunner::Loaded {
  // Files are read in the background from the start of load() (when more than one thread may run),
  // each once; whoever needs one waits for it, and a reading error surfaces there.
  template <class T>
  using Pending = std::shared_future<std::shared_ptr<T>>;
  std::launch reading = std::launch::deferred;
  // Declared before the files: the reads still running when a load fails finish (the futures' ends
  // wait for them) while these still exist.
  std::mutex backgroundMutex;
  std::vector<std::pair<std::string, double>> backgroundSeconds;  // each background read's own wall time
  std::map<std::filesystem::path, Pending<LabelVolume>> labelMaps;
  std::map<std::filesystem::path, Pending<Image3D>> images;

  std::unique_ptr<Simulation> sim;
  std::vector<std::unique_ptr<ReferenceSurface>> truth;  // per structure, null without one
  std::unique_ptr<SampledError> sampled;                 // the timeline's error; null without any truth
  double samplingSeconds = 0.0;
  // Each truth's label map and label (for Dice) and how many voxels hold the label.
  std::vector<std::pair<const LabelVolume*, std::int32_t>> truthLabels;
  std::vector<std::size_t> truthCount;
  std::shared_ptr<Image3D> target;
  std::optional<Model> model;
  std::vector<std::vector<Vec3>> modelPositions;         // level 0, before the initialisation
  // The model stage's scores (one per structure), when initialise() took them while the
  // registration ran beside; empty otherwise, and run() takes them with the start's.
  std::vector<StructureResult> modelScores;
  InitialisationResult init;
  SpatialMap trainingMap;  // target -> training image: the inverse of the initialisation
  Clock::time_point created = Clock::now();
  StageClock clock{created};  // the run's stages (RunOptions::start sets its start)

  template <class T, class Read>
  Pending<T>& startReading(std::map<std::filesystem::path, Pending<T>>& files, const std::filesystem::path& p, Read read) {
    auto& slot = files[p];
    if (!slot.valid())
      slot = std::async(reading, [this, p, read] {
               const auto t0 = Clock::now();
               auto file = std::make_shared<T>(read(p));
               const std::lock_guard lock(backgroundMutex);
               backgroundSeconds.emplace_back("read " + p.filename().string(), since(t0));
               return file;
             }).share();
    return slot;
  }
  Pending<Image3D>& startImage(const Registry& registry, const std::filesystem::path& p) {
    return startReading(images, p, [&registry](const std::filesystem::path& f) { return registry.imageIOFor(f).readImage(f); });
  }
  Pending<LabelVolume>& startLabels(const Registry& registry, const std::filesystem::path& p) {
    return startReading(labelMaps, p, [&registry](const std::filesystem::path& f) { return registry.imageIOFor(f).readLabels(f); });
  }
  std::shared_ptr<Image3D> image(const Registry& registry, const std::filesystem::path& p) { return startImage(registry, p).get(); }

  // The initialisation's registration, started in the background as soon as the model is read (it
  // needs only the target and the model's atlas image), so that making the structures and the
  // ground truths overlaps it; initialise() waits for it. Its log lines are kept until then.
  // Declared last: a load that fails while it runs cancels it, and waits for it to stop (at its
  // optimiser's next iteration or its next step) before anything it uses goes.
  struct PendingRegistration {
    std::vector<std::string> log;
    double seconds = 0.0;
    bool beside = false;  // in the background (its time is reported beside the stages)
    std::atomic<bool> cancel = false;  // before `result`: read until the task has stopped
    std::future<RegistrationResult> result;
    PendingRegistration() = default;
    PendingRegistration(const PendingRegistration&) = delete;
    PendingRegistration& operator=(const PendingRegistration&) = delete;
    ~PendingRegistration() { cancel = true; }  // then `result` goes first, waiting for the task
  } registration;
  // Starts it, unless it has started or the scene does not register; the policy: std::launch::async
  // beside the loading (only when files are read in the background), deferred to the first wait.
  // Scene errors (no atlas image, no registration plugin) are thrown here.
  void startRegistration(const Registry& registry, const SceneDesc& scene,
                         const std::function<void(const std::string&)>& log, std::launch policy);
};

}  // namespace sinew
