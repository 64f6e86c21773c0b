#include "cohort_slurm.h"

#include "sinew/core/types.h"

#include <array>
#include <cstdio>
#include <sstream>
#include <sys/stat.h>
#include <sys/wait.h>

namespace sinew::cohort {

namespace fs = std::filesystem;

namespace {

std::string quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

void writeScript(const fs::path& path, const std::string& text) {
  writeFileAtomically(path, text);
  ::chmod(path.c_str(), 0755);
}

// sbatch --parsable: prints "JOBID" or "JOBID;CLUSTER".
std::string submit(const SlurmOptions& o, const std::vector<std::string>& args, const fs::path& script) {
  std::vector<std::string> words = {o.sbatch, "--parsable"};
  words.insert(words.end(), args.begin(), args.end());
  words.push_back(script.string());
  std::string command;
  for (const std::string& w : words) command.append(quoted(w)).append(" ");
  // Only stdout is read: sites print warnings on stderr, which goes on to ours.
  FILE* p = ::popen(command.c_str(), "r");
  if (!p) throw InputError(o.sbatch + ": cannot start");
  std::string out, line;
  std::array<char, 512> buffer{};
  while (std::fgets(buffer.data(), int(buffer.size()), p)) out += buffer.data();
  const int status = ::pclose(p);
  std::istringstream lines(out);
  std::string id;
  while (std::getline(lines, line))  // the job id is the last line: "JOBID" or "JOBID;CLUSTER"
    if (!line.empty()) id = line.substr(0, line.find(';'));
  const bool numeric = !id.empty() && id.find_first_not_of("0123456789") == std::string::npos;
  if (status != 0 || !numeric)
    throw InputError(script.string() + ": sbatch refused it (exit " + std::to_string(WEXITSTATUS(status)) +
                     "; its message is above)");
  return id;
}

// A value on an #SBATCH line: sbatch splits those lines on white space and expands % in file names
// (a folder's % is doubled; pattern, such as "/task-%A_%a.log", is appended as it is).
std::string sbatchValue(const std::string& option, const std::string& v, bool folder = false,
                        const std::string& pattern = {}) {
  if (v.find_first_of("\"\n\r") != std::string::npos) throw InputError(option + " '" + v + "': no quotes or line breaks");
  std::string out;
  for (char c : v) out += folder && c == '%' ? std::string("%%") : std::string(1, c);
  out += pattern;
  return out.find_first_of(" \t") == std::string::npos ? out : "\"" + out + "\"";
}

std::string header(const SlurmOptions& o, const std::string& name, const std::string& logDir, const std::string& logName,
                   int cpus, int gpus, const std::string& memory) {
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# Written by sinew-cohort slurm (docs/cohorts.md).\n"
    << "#SBATCH --job-name=" << name << "\n"
    << "#SBATCH --output=" << sbatchValue("the cohort folder", logDir, true, "/" + logName) << "\n"
    << "#SBATCH --cpus-per-task=" << cpus << "\n"
    << "#SBATCH --mem=" << sbatchValue("--mem", memory) << "\n"
    << "#SBATCH --time=" << sbatchValue("--time", o.time) << "\n";
  if (gpus > 0) s << "#SBATCH --gres=gpu:" << gpus << "\n";
  if (!o.partition.empty()) s << "#SBATCH --partition=" << sbatchValue("--partition", o.partition) << "\n";
  if (!o.account.empty()) s << "#SBATCH --account=" << sbatchValue("--account", o.account) << "\n";
  for (const std::string& e : o.extra) s << "#SBATCH " << e << "\n";
  return s.str();
}

}  // namespace

std::string arraySpec(const std::vector<size_t>& indices) {
  std::ostringstream s;
  for (size_t a = 0; a < indices.size();) {
    size_t b = a;
    while (b + 1 < indices.size() && indices[b + 1] == indices[b] + 1) ++b;
    if (a) s << ',';
    s << indices[a];
    if (b > a) s << '-' << indices[b];
    a = b + 1;
  }
  return s.str();
}

SlurmJobs writeSlurmJobs(const Cohort& cohort, const SlurmOptions& o) {
  for (const std::string& e : o.extra)
    if (e.rfind("--", 0) != 0 || e.find('\n') != std::string::npos)
      throw InputError("--sbatch-option '" + e + "': give one sbatch option starting with --");
  SlurmJobs jobs;
  const fs::path dir = cohort.dir / "slurm";
  std::error_code ec;
  fs::create_directories(dir / "logs", ec);
  if (ec) throw InputError(dir.string() + ": cannot create: " + ec.message());
  for (size_t i = 0; i < cohort.subjects.size(); ++i)
    if (!isDone(cohort, i)) jobs.indices.push_back(i);
  if (cohort.subjects.size() > 1000)
    throw InputError(cohort.dir.string() + ": over 1000 subjects; Slurm's default MaxArraySize is 1001: split the manifest");

  jobs.arrayScript = dir / "array.sbatch";
  jobs.reportScript = dir / (o.followUp.empty() ? "report.sbatch" : "follow-up.sbatch");
  const std::string logs = (dir / "logs").string();
  // Without GPUs asked for, a task must not take one Slurm did not give it.
  const std::string backend = o.gpusPerTask == 0 && o.backend == "auto" ? "cpu" : o.backend;
  if (!jobs.indices.empty()) {
    std::string s = header(o, "sinew-cohort", logs, "task-%A_%a.log", o.cpusPerTask, o.gpusPerTask, o.memory);
    s.insert(s.find("#SBATCH --output"), "#SBATCH --array=" + arraySpec(jobs.indices) + "%" + std::to_string(std::max(1, o.throttle)) + "\n");
    // The subjects by name, so that a manifest edited while the array waits cannot swap them.
    s += "subjects=(";
    for (size_t i = 0; i < cohort.subjects.size(); ++i) {
      if (i) s += ' ';
      s += quoted(cohort.subjects[i].id);
    }
    s += ")\n";
    s += "# One subject per task; its exit code is the subject's (sinew-run's), so failures show in sacct.\n";
    s += "exec " + quoted(o.sinewCohort) + " task " + quoted(cohort.dir.string()) +
         " --subject \"${subjects[$SLURM_ARRAY_TASK_ID]}\" --threads \"${SLURM_CPUS_PER_TASK:-0}\" --backend " + quoted(backend) + "\n";
    writeScript(jobs.arrayScript, s);
  }
  std::string r;
  if (o.followUp.empty()) {
    r = header(o, "sinew-cohort-report", logs, "report-%j.log", 1, 0, "1G");
    r += "exec " + quoted(o.sinewCohort) + " report " + quoted(cohort.dir.string()) + "\n";
  } else {
    r = header(o, "sinew-cohort-follow-up", logs, "follow-up-%j.log", 1, 0, o.memory);
    r.append("cd ").append(quoted(o.followUpDir.string())).append(" || exit 1\nexec");
    for (const std::string& w : o.followUp) r.append(" ").append(quoted(w));
    r.append("\n");
  }
  writeScript(jobs.reportScript, r);
  if (!o.submit) return jobs;
  if (!jobs.indices.empty()) {
    jobs.arrayJob = submit(o, {}, jobs.arrayScript);
    std::fprintf(stdout, "submitted array job %s\n", jobs.arrayJob.c_str());
    std::fflush(stdout);
  }
  jobs.reportJob = submit(o, jobs.arrayJob.empty() ? std::vector<std::string>{} : std::vector<std::string>{"--dependency=afterany:" + jobs.arrayJob},
                          jobs.reportScript);
  return jobs;
}

}  // namespace sinew::cohort
