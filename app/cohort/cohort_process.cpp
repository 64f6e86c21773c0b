#include "cohort_process.h"

#include "sinew/core/types.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <csignal>
#include <fstream>
#include <mutex>
#include <set>
#include <sched.h>
#include <spawn.h>
#include <thread>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace sinew::cohort {

namespace fs = std::filesystem;

namespace {
std::mutex runningMutex;
std::set<pid_t> running;
bool terminating = false;
}  // namespace

void terminatePrograms() {
  const std::lock_guard lock(runningMutex);
  terminating = true;
  for (pid_t pid : running) ::kill(pid, SIGTERM);
}

ProgramResult runProgram(const std::vector<std::string>& argv, const fs::path& log,
                         const std::vector<std::pair<std::string, std::string>>& env) {
  std::vector<std::string> environment;
  for (char** e = environ; *e; ++e) {
    const std::string entry(*e);
    bool replaced = false;
    for (const auto& [key, value] : env) replaced = replaced || entry.rfind(key + "=", 0) == 0;
    if (!replaced) environment.push_back(entry);
  }
  for (const auto& [key, value] : env) environment.push_back(key + "=" + value);
  std::vector<char*> args, envp;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  for (const std::string& e : environment) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = 0;
  const int rc = argv[0].find('/') == std::string::npos
                     ? posix_spawnp(&pid, argv[0].c_str(), &actions, nullptr, args.data(), envp.data())
                     : posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, args.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw InputError(argv[0] + ": cannot start: " + std::strerror(rc));
  {
    const std::lock_guard lock(runningMutex);
    running.insert(pid);
    if (terminating) ::kill(pid, SIGTERM);  // started as the stop came
  }
  int status = 0;
  int waited;
  while ((waited = ::waitpid(pid, &status, 0)) < 0 && errno == EINTR) {
  }
  {
    const std::lock_guard lock(runningMutex);
    running.erase(pid);
  }
  if (waited < 0) throw InputError(argv[0] + ": lost the process: " + std::strerror(errno));
  ProgramResult r;
  if (WIFEXITED(status)) r.exitCode = WEXITSTATUS(status);
  else if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  return r;
}

std::string siblingProgram(const std::string& name) {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path beside = self.parent_path() / name;
    if (fs::exists(beside)) return beside.string();
  }
  return name;
}

std::string lastErrorLine(const fs::path& log) {
  std::ifstream in(log);
  std::string line, lastError, lastLine;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // Progress redraws leave carriage returns: keep what follows the last one.
    if (const auto cr = line.rfind('\r'); cr != std::string::npos) line = line.substr(cr + 1);
    if (line.rfind("== ", 0) == 0) {  // a new attempt: what came before is not its
      lastError.clear();
      lastLine.clear();
      continue;
    }
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    lastLine = line;
    if (line.find("error:") != std::string::npos) lastError = line;
  }
  return lastError.empty() ? lastLine : lastError;
}

unsigned availableCores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0) return unsigned(CPU_COUNT(&set));
  return std::max(1u, std::thread::hardware_concurrency());
}

std::string hostName() {
  char name[256] = {0};
  if (::gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

}  // namespace sinew::cohort
