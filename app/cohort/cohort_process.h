// Running Sinew's other programs from sinew-cohort: each subject is its own sinew-run process, so a
// crash or a bad image ends that subject only.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace sinew::cohort {

struct ProgramResult {
  int exitCode = -1;  // -1 when killed by a signal
  int signal = 0;
};

// Runs argv[0] with argv, stdin from /dev/null, stdout and stderr appended to log; env entries are
// set (or replaced) in the child's environment. Throws InputError when the program cannot start.
ProgramResult runProgram(const std::vector<std::string>& argv, const std::filesystem::path& log,
                         const std::vector<std::pair<std::string, std::string>>& env = {});

// Sends SIGTERM to every program runProgram is waiting for, and to any it starts from now on (an
// interrupted cohort ends its runs).
void terminatePrograms();

// Sinew's program NAME: beside this executable when it is there (the build tree, an installed
// package), else NAME as found on PATH.
std::string siblingProgram(const std::string& name);

// The last line of a log's last section (from its last line starting "== ") that names an error
// ("sinew-run: error: ..."), else that section's last non-empty line.
std::string lastErrorLine(const std::filesystem::path& log);

// The CPU cores this process may run on (its affinity mask: a Slurm allocation, taskset).
unsigned availableCores();

std::string hostName();

}  // namespace sinew::cohort
