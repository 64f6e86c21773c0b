// Running a cohort's subjects: one subject (a Slurm array task, or one slot of a local run), and a
// whole cohort spread over this host's GPUs or CPU cores.
#pragma once

#include "cohort.h"

#include <cmath>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>

namespace sinew::cohort {

struct TaskOptions {
  std::string sinewRun = "sinew-run";  // the program
  std::string backend = "auto";        // sinew-run --backend
  int threads = 0;                     // sinew-run -j (0: all)
  std::optional<std::string> gpu;      // CUDA_VISIBLE_DEVICES of the run, when set
  int retries = 1;                     // a failed run is tried again this many times
};

// Runs subject i unless it is done: sinew-run into subjects/ID/out, its output appended to
// subjects/ID/run.log; a failure is tried again (options.retries), except exit 4 (sinew-run ended
// by itself with its last good meshes: a deterministic verdict, docs/cohorts.md). Writes and
// returns the subject's status. ran is false when the subject was already done or could not start.
// After a stop signal (stopOnSignals) the status is "interrupted": not done, so it runs next time.
struct TaskResult {
  SubjectStatus status;
  bool ran = false;
  double meanAssdMm = std::nan("");  // over the structures of the report this run wrote; NaN without one
};
TaskResult runSubject(const Cohort& cohort, size_t i, const TaskOptions& options);

struct LocalOptions {
  TaskOptions task;
  int gpus = -1;         // GPUs to use: -1 every usable one, 0 none (CPU workers)
  // sinew-run processes per GPU (0: half the cores over the GPUs): a subject's run on a GPU is mostly
  // CPU work (reading, registration, evaluation), which the other runs overlap with their steps.
  int jobsPerGpu = 0;
  int cpuWorkers = 0;    // without GPUs: parallel runs (0: half the cores, at least 1)
  bool quiet = false;
};

struct CohortSummary {
  int total = 0, completed = 0, degraded = 0, failed = 0, skipped = 0;
  double seconds = 0.0;
};

// From now on SIGINT and SIGTERM end the runs in flight (SIGTERM to each) without a verdict: their
// subjects stay missing, for the next run of the cohort.
void stopOnSignals();

// Thrown by runLocal after SIGINT or SIGTERM: the runs in flight were ended, nothing recorded for them.
struct Interrupted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Every subject that is not done, over the slots: GPU k's slots run with CUDA_VISIBLE_DEVICES set
// to the k-th visible device and the cuda backend; CPU slots share the cores. Progress on stderr.
CohortSummary runLocal(const Cohort& cohort, const LocalOptions& options);

}  // namespace sinew::cohort
