// Slurm: the cohort as one job array (one subject per array task) and an aggregation job that runs
// after it, however its tasks end.
#pragma once

#include "cohort.h"

#include <string>
#include <vector>

namespace sinew::cohort {

struct SlurmOptions {
  std::string sinewCohort;  // this program, as the tasks will call it
  std::string backend = "auto";
  int throttle = 8;         // at most this many array tasks at once (the array's % limit)
  int cpusPerTask = 4, gpusPerTask = 0;
  std::string memory = "8G", time = "01:00:00", partition, account;
  std::vector<std::string> extra;  // more #SBATCH options, as given ("--qos=short")
  bool submit = true;              // false: write the scripts only
  std::string sbatch = "sbatch";
  // When set, the job after the array runs this command line in followUpDir instead of the
  // report: for the learning runs, the sinew-cohort slurm command that learns from them and
  // submits the cohort (cohort_learning.h).
  std::vector<std::string> followUp;
  std::filesystem::path followUpDir;
};

struct SlurmJobs {
  std::filesystem::path arrayScript, reportScript;  // reportScript: the follow-up's, with one
  std::vector<size_t> indices;      // the array's tasks: the subjects not done
  std::string arrayJob, reportJob;  // job ids, when submitted
};

// Writes DIR/slurm/array.sbatch (only the subjects not done) and DIR/slurm/report.sbatch (or
// follow-up.sbatch, with options.followUp), and submits them (sbatch --parsable; the second with
// --dependency=afterany on the array). Logs go to DIR/slurm/logs. Throws InputError naming
// sbatch's message when a submission is refused.
SlurmJobs writeSlurmJobs(const Cohort& cohort, const SlurmOptions& options);

// Slurm's array syntax for indices: "0-3,7,9-11".
std::string arraySpec(const std::vector<size_t>& indices);

}  // namespace sinew::cohort
