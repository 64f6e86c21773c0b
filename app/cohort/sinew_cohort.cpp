// sinew-cohort: one model over many subjects, on this host's GPUs or CPU cores, or on Slurm as a
// job array, and one report for the cohort (docs/cohorts.md).
#include "cohort.h"
#include "cohort_learning.h"
#include "cohort_process.h"
#include "cohort_report.h"
#include "cohort_run.h"
#include "cohort_slurm.h"
#include "offscreen_qt.h"
#include "sinew/core/types.h"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>

namespace fs = std::filesystem;
using namespace sinew;
using namespace sinew::cohort;

namespace {

struct CohortInputs {
  std::string manifest, templateFile, model, out;
};

void addInputs(CLI::App* c, CohortInputs& in, bool manifestRequired) {
  auto* m = c->add_option("manifest", in.manifest, "subjects: CSV (subject,target[,ground_truth][,transform][,landmarks]) or JSON");
  if (manifestRequired) m->required();
  c->add_option("--template", in.templateFile,
                "scene template (sinew-make-scene --model ... on any subject); default: sinew-make-scene's subject scene of --model");
  c->add_option("--model", in.model, "model folder (sinew-build-model); replaces the template's");
  c->add_option("-o,--out", in.out, "cohort folder (created; an existing one is resumed)")->required();
}

// The template of a manifest's cohort: --template, else sinew-make-scene's subject scene of --model
// (DIR/template.json).
fs::path templateFor(const CohortInputs& in, const std::optional<fs::path>& model) {
  if (!in.templateFile.empty()) return in.templateFile;
  if (!model) throw InputError("give --template, or --model to use sinew-make-scene's subject scene");
  // sinew-make-scene only reads the model's manifest; the target is replaced for every subject.
  std::ifstream manifest(*model / "model.json");
  const Json m = Json::parse(manifest, nullptr, false);
  if (m.is_discarded() || !m.contains("atlas_image") || !m["atlas_image"].is_string())
    throw InputError(in.model + ": not a Sinew model (no valid model.json)");
  std::error_code ec;
  fs::create_directories(in.out, ec);
  if (ec) throw InputError(in.out + ": cannot create the cohort folder: " + ec.message());
  const fs::path templateFile = fs::path(in.out) / "template.json";
  const fs::path log = fs::path(in.out) / "template.log";
  const ProgramResult r = runProgram({siblingProgram("sinew-make-scene"), "--model", in.model, "--target",
                                      (*model / m["atlas_image"].get<std::string>()).string(), "-o", templateFile.string()},
                                     log);
  if (r.exitCode != 0) throw InputError("sinew-make-scene could not make the template: " + lastErrorLine(log));
  return templateFile;
}

// From the template and the model to the template with learned shares; nullopt while the learning
// runs are still to come (on Slurm).
using LearnShares = std::function<std::optional<fs::path>(const fs::path&, const std::optional<fs::path>&)>;

// The cohort folder, prepared from the manifest when one is given, else the existing one; with
// shares to learn, from the template `learn` returns (nullopt when it returns none).
std::optional<Cohort> cohortFrom(const CohortInputs& in, const ShareLearning& learning = {}, const LearnShares& learn = {}) {
  if (in.manifest.empty()) {
    if (!in.templateFile.empty() || !in.model.empty()) throw InputError("--template and --model go with a manifest");
    if (learning.subjects > 0) throw InputError("--learn-collision-shares goes with a manifest");
    return loadCohort(in.out);
  }
  if (!fs::exists(in.manifest)) throw InputError(in.manifest + ": no such file");
  std::optional<fs::path> model;
  if (!in.model.empty()) model = fs::path(in.model);
  fs::path templateFile = templateFor(in, model);
  if (learning.subjects > 0) {
    const std::optional<fs::path> learned = learn(templateFile, model);
    if (!learned) return std::nullopt;
    templateFile = *learned;
  }
  return prepareCohort(in.manifest, templateFile, model, in.out);
}

void addShareLearning(CLI::App* c, ShareLearning& learning) {
  c->add_option("--learn-collision-shares", learning.subjects,
                "learn the collision's shares by pair from the first N subjects with a ground truth, each run once "
                "more without collisions first (docs/cohorts.md); 0: the template's sharing")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  c->add_option("--collision-shares-min-contacts", learning.minContacts,
                "contact points each side of a pair needs, over the learning runs, for its shares")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
}

void printReport(const CohortReport& rep, const Cohort& cohort) {
  std::printf("%-20s %4s  %-26s %-26s\n", "structure", "n", "ASSD mm: median [q1, q3]", "Dice: median [q1, q3]");
  for (const std::string& s : rep.structures) {
    const Statistics a = statistics(rep.metric(s, &StructureResult::assdFinal));
    const Statistics d = statistics(rep.metric(s, &StructureResult::dice));
    char assd[64] = "-", dice[64] = "-";
    if (a.n) std::snprintf(assd, sizeof assd, "%.2f [%.2f, %.2f]", a.median, a.q1, a.q3);
    if (d.n) std::snprintf(dice, sizeof dice, "%.3f [%.3f, %.3f]", d.median, d.q1, d.q3);
    std::printf("%-20s %4d  %-26s %-26s\n", s.c_str(), std::max(a.n, d.n), assd, dice);
  }
  std::printf("subjects: %zu; completed %d, degraded %d, failed %d, not run %d\n", rep.subjects.size(), rep.completed,
              rep.degraded, rep.failed, rep.pending);
  for (const SubjectRow& r : rep.subjects)
    if (r.status.status == "failed" || r.status.status == "degraded")
      std::printf("  %s %s: %s\n", r.id.c_str(), r.status.status.c_str(), r.status.message.c_str());
  for (const SubjectRow& r : rep.subjects)
    if (rep.registrationStandsOut(r))
      std::printf("  %s: its registration stands out (Mattes MI %.3f, the cohort's median %.3f): check its initialisation\n",
                  r.id.c_str(), r.registrationMetric, rep.registrationMedian);
  for (const SubjectRow& r : rep.subjects)
    if (r.lowestImageFit < kPoorImageFit)
      std::printf("  %s: %s's image fit is %.2f (below %.2f: the image does not look as trained there): check it\n",
                  r.id.c_str(), r.lowestImageFitStructure.c_str(), r.lowestImageFit, kPoorImageFit);
  if (!rep.sharesLearnedFrom.empty()) {
    std::string from;
    for (const std::string& id : rep.sharesLearnedFrom) from += (from.empty() ? "" : ", ") + id;
    std::printf("collision shares by pair: %d pair(s) learned from %s (learning/shares.json)\n", rep.sharesLearnedPairs,
                from.c_str());
  }
  std::printf("report: %s\n", cohort.reportDir().string().c_str());
}

int report(const Cohort& cohort, bool print) {
  const CohortReport rep = gatherReport(cohort);
  writeReport(cohort, rep);
  if (print) printReport(rep, cohort);
  return rep.completed == int(rep.subjects.size()) ? 0 : kExitSomeFailed;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"sinew-cohort: run one model over a cohort of subjects, locally or on Slurm, and report on it.\n"
               "Exit codes: 0 every subject completed, 5 some failed (the report lists them), 2 bad command line,\n"
               "3 bad input (manifest, template, cohort folder), 130 interrupted, 1 internal error."};
  cli.require_subcommand(1);
  cli.set_version_flag("--version", std::string("sinew-cohort ") + SINEW_VERSION);

  CohortInputs runIn;
  LocalOptions local;
  bool noReport = false;
  auto* run = cli.add_subcommand("run", "run every subject not done yet on this host (GPUs, else CPU workers), then report");
  addInputs(run, runIn, false);
  run->add_option("--backend", local.task.backend, "sinew-run's backend")->check(CLI::IsMember({"auto", "cuda", "cpu"}))->capture_default_str();
  run->add_option("--gpus", local.gpus, "GPUs to use (-1: every usable one; 0: none)")->capture_default_str();
  run->add_option("--jobs-per-gpu", local.jobsPerGpu, "sinew-run processes per GPU (0: half the cores over the GPUs)")->check(CLI::Range(0, 64))->capture_default_str();
  run->add_option("--cpu-workers", local.cpuWorkers, "without GPUs: runs at a time (0: half the cores)")->check(CLI::NonNegativeNumber);
  run->add_option("-j,--threads", local.task.threads, "CPU threads per run (0: the cores shared among the runs)")->check(CLI::NonNegativeNumber);
  run->add_option("--retries", local.task.retries, "times a failed subject is tried again")->check(CLI::Range(0, 5))->capture_default_str();
  run->add_flag("-q,--quiet", local.quiet, "no progress output");
  run->add_flag("--no-report", noReport, "do not write the cohort report at the end");
  ShareLearning learning;
  addShareLearning(run, learning);

  CohortInputs slurmIn;
  SlurmOptions slurm;
  auto* sl = cli.add_subcommand("slurm", "write and submit a Slurm job array (one subject per task) and the report job after it");
  addInputs(sl, slurmIn, false);
  sl->add_option("--throttle", slurm.throttle, "array tasks running at once (the array's %)")->check(CLI::Range(1, 100000))->capture_default_str();
  sl->add_option("--partition", slurm.partition, "Slurm partition");
  sl->add_option("--account", slurm.account, "Slurm account");
  sl->add_option("--time", slurm.time, "time limit per subject")->capture_default_str();
  sl->add_option("--mem", slurm.memory, "memory per subject")->capture_default_str();
  sl->add_option("--cpus-per-task", slurm.cpusPerTask, "CPU cores per subject")->check(CLI::Range(1, 1024))->capture_default_str();
  sl->add_option("--gpus-per-task", slurm.gpusPerTask, "GPUs per subject (--gres=gpu:N; 0: CPU only)")->check(CLI::Range(0, 16))->capture_default_str();
  sl->add_option("--backend", slurm.backend, "sinew-run's backend")->check(CLI::IsMember({"auto", "cuda", "cpu"}))->capture_default_str();
  sl->add_option("--sbatch-option", slurm.extra, "another #SBATCH option, e.g. --qos=short (repeatable)");
  sl->add_option("--sbatch", slurm.sbatch, "the sbatch program")->capture_default_str();
  bool noSubmit = false;
  sl->add_flag("--no-submit", noSubmit, "write the scripts only");
  ShareLearning slurmLearning;
  addShareLearning(sl, slurmLearning);
  bool afterLearning = false;  // the learning runs' follow-up job: learn from those that completed
  sl->add_flag("--after-learning", afterLearning)->group("");

  std::string taskDir, taskSubject;
  size_t taskIndex = 0;
  TaskOptions task;
  auto* tk = cli.add_subcommand("task", "run one subject of a prepared cohort (what each Slurm array task does)");
  tk->add_option("cohort", taskDir, "cohort folder")->required();
  auto* byIndex = tk->add_option("--index", taskIndex, "the subject's index in cohort.json");
  auto* byName = tk->add_option("--subject", taskSubject, "the subject's id (what the array script passes)");
  byIndex->excludes(byName);
  tk->add_option("--backend", task.backend, "sinew-run's backend")->check(CLI::IsMember({"auto", "cuda", "cpu"}))->capture_default_str();
  tk->add_option("-j,--threads", task.threads, "CPU threads (0: all)")->check(CLI::NonNegativeNumber);
  tk->add_option("--retries", task.retries, "times a failed run is tried again")->check(CLI::Range(0, 5))->capture_default_str();

  std::string reportDir;
  auto* rp = cli.add_subcommand("report", "gather every subject's results into report/ (CSV, statistics, plots)");
  rp->add_option("cohort", reportDir, "cohort folder")->required();

  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;
  }
  const auto qt = startOffscreenQt(argv[0]);  // the report's plots need fonts
  try {
    if (*run) {
      local.task.sinewRun = siblingProgram("sinew-run");
      const Cohort cohort = *cohortFrom(runIn, learning, [&](const fs::path& t, const std::optional<fs::path>& m) {
        return std::optional<fs::path>(learnCollisionShares(runIn.manifest, t, m, runIn.out, learning, local));
      });
      const CohortSummary s = runLocal(cohort, local);
      if (!local.quiet)
        std::fprintf(stderr, "sinew-cohort: %d subjects in %.1f s: %d completed, %d degraded, %d failed (%d were done before)\n",
                     s.total, s.seconds, s.completed, s.degraded, s.failed, s.skipped);
      if (noReport) return s.completed == s.total ? 0 : kExitSomeFailed;
      return report(cohort, !local.quiet);
    }
    if (*sl) {
      std::error_code ec;
      const fs::path self = fs::read_symlink("/proc/self/exe", ec);
      slurm.sinewCohort = ec ? "sinew-cohort" : self.string();
      slurm.submit = !noSubmit;
      // With shares to learn and learning runs still to come: their array, then a job that runs
      // this command again (--after-learning: it learns from those that completed, then submits).
      const auto learnOnSlurm = [&](const fs::path& t, const std::optional<fs::path>& m) -> std::optional<fs::path> {
        const Cohort learners = prepareLearning(slurmIn.manifest, t, m, slurmIn.out, slurmLearning);
        if (afterLearning || learningDone(learners)) return learnFromRuns(learners, t, slurmIn.out, slurmLearning, false);
        SlurmOptions o = slurm;
        o.followUp = {slurm.sinewCohort};
        o.followUp.insert(o.followUp.end(), argv + 1, argv + argc);
        o.followUp.push_back("--after-learning");
        o.followUpDir = fs::current_path();
        const SlurmJobs jobs = writeSlurmJobs(learners, o);
        std::printf("learning the collision's shares first: %zu of %zu labelled subjects to run: %s\n", jobs.indices.size(),
                    learners.subjects.size(), jobs.indices.empty() ? "-" : jobs.arrayScript.string().c_str());
        std::printf("follow-up job (learns, then submits the cohort): %s\n", jobs.reportScript.string().c_str());
        if (!jobs.reportJob.empty()) std::printf("submitted follow-up job %s\n", jobs.reportJob.c_str());
        else std::printf("not submitted (--no-submit): once the learning tasks are done, this command learns and writes the cohort's jobs\n");
        return std::nullopt;
      };
      const std::optional<Cohort> prepared = cohortFrom(slurmIn, slurmLearning, learnOnSlurm);
      if (!prepared) return 0;
      const Cohort& cohort = *prepared;
      const SlurmJobs jobs = writeSlurmJobs(cohort, slurm);
      std::printf("%zu of %zu subjects to run: %s\n", jobs.indices.size(), cohort.subjects.size(),
                  jobs.indices.empty() ? "-" : jobs.arrayScript.string().c_str());
      std::printf("report job: %s\n", jobs.reportScript.string().c_str());
      if (!jobs.reportJob.empty()) std::printf("submitted report job %s\n", jobs.reportJob.c_str());
      return 0;
    }
    if (*tk) {
      if (byIndex->count() == 0 && byName->count() == 0) throw InputError("task: give --subject or --index");
      const Cohort cohort = loadCohort(taskDir);
      if (!taskSubject.empty()) {
        taskIndex = cohort.subjects.size();
        for (size_t i = 0; i < cohort.subjects.size(); ++i)
          if (cohort.subjects[i].id == taskSubject) taskIndex = i;
        if (taskIndex == cohort.subjects.size())
          throw InputError(taskDir + ": no subject '" + taskSubject + "' in the cohort");
      }
      if (taskIndex >= cohort.subjects.size())
        throw InputError(taskDir + ": --index " + std::to_string(taskIndex) + ": the cohort has " +
                         std::to_string(cohort.subjects.size()) + " subjects");
      task.sinewRun = siblingProgram("sinew-run");
      stopOnSignals();
      const TaskResult r = runSubject(cohort, taskIndex, task);
      const SubjectStatus& st = r.status;
      const std::string& id = cohort.subjects[taskIndex].id;
      if (!r.ran && (st.status == "completed" || st.status == "degraded")) {
        std::fprintf(stderr, "sinew-cohort: subject %s: already %s\n", id.c_str(), st.status.c_str());
        return st.status == "completed" ? 0 : 4;
      }
      std::fprintf(stderr, "sinew-cohort: subject %s: %s in %.1f s%s%s\n", id.c_str(), st.status.c_str(), st.seconds,
                   st.message.empty() ? "" : ": ", st.message.c_str());
      if (st.status == "completed") return 0;
      if (st.status == "interrupted") return 130;
      return st.exitCode > 0 ? st.exitCode : 1;
    }
    if (*rp) return report(loadCohort(reportDir), true);
  } catch (const Interrupted& e) {
    std::cerr << "sinew-cohort: " << e.what() << "\n";
    return 130;
  } catch (const InputError& e) {
    std::cerr << "sinew-cohort: error: " << e.what() << "\n";
    return 3;
  } catch (const Json::exception& e) {  // a template or model manifest of the wrong shape
    std::cerr << "sinew-cohort: error: unexpected JSON: " << e.what() << "\n";
    return 3;
  } catch (const fs::filesystem_error& e) {
    std::cerr << "sinew-cohort: error: " << e.what() << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "sinew-cohort: internal error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
