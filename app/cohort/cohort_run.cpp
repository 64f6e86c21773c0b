#include "cohort_run.h"

#include "backend_choice.h"
#include "cohort_process.h"
#include "process_lock.h"
#include "sinew/core/types.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>
#include <tuple>

namespace sinew::cohort {

namespace fs = std::filesystem;

namespace {

// Set by SIGINT/SIGTERM: the runs in flight are ended, nothing is retried, and they are recorded as
// interrupted (not done), so the next run of the cohort picks them up.
std::atomic<bool> stopRequested{false};
extern "C" void onStopSignal(int) { stopRequested = true; }

}  // namespace

void stopOnSignals() {
  struct sigaction sa {};
  sa.sa_handler = onStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  // The programs run in their own threads' waits; this one passes the stop on to them.
  static std::once_flag watcher;
  std::call_once(watcher, [] {
    std::thread([] {
      while (!stopRequested) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      terminatePrograms();
    }).detach();
  });
}

namespace {

std::string now() {
  const std::time_t t = std::time(nullptr);
  char s[32];
  std::tm local{};
  std::strftime(s, sizeof s, "%Y-%m-%d %H:%M:%S", localtime_r(&t, &local));
  return s;
}

// report.json's backend and the mean final ASSD (NaN without ground truth).
std::pair<std::string, double> reportSummary(const fs::path& report) {
  std::ifstream in(report);
  const Json j = Json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return {"", std::nan("")};
  double sum = 0.0;
  int n = 0;
  if (j.contains("structures"))
    for (const Json& s : j["structures"])
      if (s.contains("assd_mm") && s["assd_mm"].contains("final") && s["assd_mm"]["final"].is_number()) {
        sum += s["assd_mm"]["final"].get<double>();
        ++n;
      }
  return {j.value("backend", std::string()), n ? sum / n : std::nan("")};
}

std::string describe(const ProgramResult& r) {
  if (r.signal) {
    const char* name = sigabbrev_np(r.signal);
    return "killed by signal " + std::to_string(r.signal) + (name ? std::string(" (SIG") + name + ")" : std::string());
  }
  return "exit " + std::to_string(r.exitCode);
}

}  // namespace

TaskResult runSubject(const Cohort& cohort, size_t i, const TaskOptions& options) {
  TaskResult result;
  if (isDone(cohort, i)) {
    result.status = readStatus(cohort, i);
    return result;
  }
  if (!fs::exists(cohort.sceneFile(i))) {  // its scene could not be made: prepareCohort said why
    result.status = readStatus(cohort, i);
    if (result.status.status == "pending") {
      result.status.status = "failed";
      result.status.exitCode = 3;
      result.status.message = cohort.sceneFile(i).string() + ": no scene; prepare the cohort again";
    }
    return result;
  }
  SubjectStatus& st = result.status;
  st.host = hostName();
  st.gpu = options.gpu.value_or("");
  std::vector<std::string> argv = {options.sinewRun, cohort.sceneFile(i).string(), "-o", cohort.outputDir(i).string(),
                                   "--backend", options.backend, "-j", std::to_string(options.threads)};
  std::vector<std::pair<std::string, std::string>> env;
  if (options.gpu) env.emplace_back("CUDA_VISIBLE_DEVICES", *options.gpu);
  const auto start = std::chrono::steady_clock::now();
  const fs::path report = cohort.outputDir(i) / "report.json";
  for (int attempt = 1; attempt <= 1 + std::max(0, options.retries); ++attempt) {
    if (stopRequested) break;
    // A report left by an earlier run (another scene, a run killed after writing) must not pass
    // for this attempt's.
    std::error_code ec;
    fs::remove(report, ec);
    {
      std::ofstream log(cohort.logFile(i), std::ios::app);
      log << "== attempt " << attempt << " at " << now() << " on " << st.host << (options.gpu ? ", GPU " + *options.gpu : "")
          << ":";
      for (const std::string& a : argv) log << ' ' << a;
      log << "\n";
    }
    ProgramResult r;
    try {
      r = runProgram(argv, cohort.logFile(i), env);
    } catch (const InputError& e) {
      st.status = "failed";
      st.message = e.what();
      break;
    }
    result.ran = true;
    st.attempts = attempt;
    st.exitCode = r.signal ? -1 : r.exitCode;
    const bool wrote = fs::exists(report);
    if (r.exitCode == 0 && !r.signal && wrote) {  // a run that finished as the stop came counts
      st.status = "completed";
      st.message.clear();
      break;
    }
    if (stopRequested) break;
    const std::string line = lastErrorLine(cohort.logFile(i));
    st.message = describe(r) + (line.empty() ? "" : ": " + line);
    st.status = "failed";
    // Exit 4 is sinew-run's own verdict: with its last good meshes written (degraded), or with a
    // non-finite state and nothing written; running it again gives the same.
    if (r.exitCode == 4) {
      if (wrote) st.status = "degraded";
      break;
    }
  }
  if (stopRequested && st.status != "completed") {
    // Ctrl-C, scancel or Slurm's time limit: not a verdict on the subject, which runs again next time.
    st.status = "interrupted";
    st.message = "stopped by a signal (Ctrl-C, scancel or a time limit) before it ended";
  }
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (st.status == "completed" || st.status == "degraded")
    std::tie(st.backend, result.meanAssdMm) = reportSummary(report);
  writeStatus(cohort, i, st);
  return result;
}

CohortSummary runLocal(const Cohort& cohort, const LocalOptions& options) {
  // One local run per cohort folder at a time: a second would run the same missing subjects.
  ProcessLock lock(cohort.dir / ".sinew-cohort.lock");
  if (!lock.tryLock()) {
    const std::string holder = lock.holder();
    throw InputError(cohort.dir.string() + ": another sinew-cohort run" + (holder.empty() ? "" : " (process " + holder + ")") +
                     " is running this cohort; wait for it");
  }
  stopOnSignals();
  const auto start = std::chrono::steady_clock::now();
  CohortSummary sum;
  sum.total = int(cohort.subjects.size());
  std::vector<size_t> todo;
  for (size_t i = 0; i < cohort.subjects.size(); ++i) {
    if (isDone(cohort, i)) {
      ++sum.skipped;
      (readStatus(cohort, i).status == "degraded" ? sum.degraded : sum.completed)++;
    } else {
      todo.push_back(i);
    }
  }

  // The slots: jobsPerGpu per GPU, or CPU workers.
  const unsigned cores = availableCores();
  const std::vector<int> devices = options.task.backend == "cpu" || options.gpus == 0 ? std::vector<int>{} : usableGpus();
  const int usable = int(devices.size());
  if (options.gpus > usable)
    throw InputError("--gpus " + std::to_string(options.gpus) + ": this host has " + std::to_string(usable) +
                     " GPU(s) the CUDA backend can use" + (options.task.backend == "cpu" ? " with --backend cpu" : ""));
  const int gpus = options.gpus < 0 ? usable : options.gpus;
  std::vector<std::optional<std::string>> slots;
  if (gpus > 0) {
    // The usable GPUs by CUDA index among those this process sees; named for the child as this
    // process's CUDA_VISIBLE_DEVICES names them (Slurm sets it), else by that index.
    std::vector<std::string> visible;
    if (const char* v = std::getenv("CUDA_VISIBLE_DEVICES"); v && *v) {
      std::stringstream s(v);
      for (std::string id; std::getline(s, id, ',');) visible.push_back(id);
    }
    const int perGpu = options.jobsPerGpu > 0 ? options.jobsPerGpu : std::max(1, int(cores) / (2 * gpus));
    for (int g = 0; g < gpus; ++g) {
      const size_t d = size_t(devices[size_t(g)]);
      for (int j = 0; j < perGpu; ++j) slots.push_back(d < visible.size() ? visible[d] : std::to_string(d));
    }
  } else {
    const int workers = options.cpuWorkers > 0 ? options.cpuWorkers : std::max(1, int(cores) / 2);
    slots.assign(size_t(workers), std::nullopt);
  }
  TaskOptions task = options.task;
  if (gpus > 0 && task.backend == "auto") task.backend = "cuda";
  if (gpus == 0 && task.backend == "auto") task.backend = "cpu";
  if (task.threads == 0) task.threads = std::max(1, int(cores) / int(slots.size()));
  if (!options.quiet) {
    std::cerr << "sinew-cohort: " << todo.size() << " of " << sum.total << " subjects to run";
    if (sum.skipped) std::cerr << " (" << sum.skipped << " already done)";
    if (gpus > 0) std::cerr << " on " << gpus << " GPU(s), " << slots.size() / size_t(gpus) << " run(s) per GPU";
    else std::cerr << " on the CPU, " << slots.size() << " run(s) at a time";
    std::cerr << ", " << task.threads << " thread(s) each\n";
  }

  std::mutex m;
  std::atomic<size_t> next{0};
  int finished = 0;
  std::exception_ptr firstError;  // a file system error in a worker: the cohort stops after the others
  auto work = [&](const std::optional<std::string>& gpu) {
    TaskOptions t = task;
    t.gpu = gpu;
    for (size_t k; !stopRequested && (k = next++) < todo.size();) {
      const size_t i = todo[k];
      TaskResult r;
      try {
        r = runSubject(cohort, i, t);
      } catch (...) {
        const std::lock_guard lock(m);
        if (!firstError) firstError = std::current_exception();
        next = todo.size();
        break;
      }
      const std::lock_guard lock(m);
      if (stopRequested) break;
      ++finished;
      const SubjectStatus& st = r.status;
      (st.status == "completed" ? sum.completed : st.status == "degraded" ? sum.degraded : sum.failed)++;
      if (options.quiet) continue;
      char line[512];
      std::snprintf(line, sizeof line, "[%d/%zu] %s %s in %.1f s", finished, todo.size(), cohort.subjects[i].id.c_str(),
                    st.status.c_str(), st.seconds);
      std::cerr << line << (gpu ? " on GPU " + *gpu : std::string(" on the CPU"));
      if (!std::isnan(r.meanAssdMm)) std::fprintf(stderr, " (mean ASSD %.2f mm)", r.meanAssdMm);
      if (st.attempts > 1) std::cerr << " after " << st.attempts << " attempts";
      if (!st.message.empty()) std::cerr << ": " << st.message;
      std::cerr << std::endl;
    }
  };
  std::vector<std::thread> threads;
  for (const auto& slot : slots) threads.emplace_back(work, slot);
  for (std::thread& t : threads) t.join();
  if (firstError) std::rethrow_exception(firstError);
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (stopRequested) throw Interrupted("interrupted; run the cohort again to finish it (done subjects are kept)");
  return sum;
}

}  // namespace sinew::cohort
