#include "isolated_read.h"

#include "sinew/core/types.h"

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <mutex>
#include <poll.h>
#include <string>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SINEW_ASAN 1
#endif
#endif
#ifdef __SANITIZE_ADDRESS__
#define SINEW_ASAN 1
#endif

#ifdef SINEW_ASAN
extern "C" void __sanitizer_set_death_callback(void (*callback)(void));
#endif

namespace sinew {

namespace fs = std::filesystem;

std::shared_mutex& vtkWorkMutex() {
  static std::shared_mutex m;
  return m;
}

namespace {
[[noreturn]] void fail(const fs::path& path, const std::string& problem) { throw InputError(path.string() + ": " + problem); }

void writeAll(int fd, const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    done += std::size_t(n);
  }
}

// The child's side: read, then send 'M' + counts + points + triangles, or 'E' + the message.
[[noreturn]] void child(int fd, const fs::path& path, const std::function<TriangleMesh()>& read) {
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) std::signal(sig, SIG_DFL);  // die quietly
#ifdef SINEW_ASAN
  // Under the fuzzer: an ASan report in the child ends the child only (libFuzzer's death callback
  // would record the input as the parent's crash).
  __sanitizer_set_death_callback(nullptr);
#else  // ASan reserves terabytes of address space: no limit under it
  const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
  rlimit limit{};
  if (::getrlimit(RLIMIT_AS, &limit) == 0 && pages > 0) {
    std::size_t used = 0;
    if (FILE* f = std::fopen("/proc/self/statm", "r")) {
      unsigned long size = 0;
      if (std::fscanf(f, "%lu", &size) == 1) used = std::size_t(size) * std::size_t(pageSize);
      std::fclose(f);
    }
    const rlim_t want = rlim_t(used + std::size_t(pages) * std::size_t(pageSize) / 4);
    if (limit.rlim_max == RLIM_INFINITY || want < limit.rlim_max) limit.rlim_cur = want;
    ::setrlimit(RLIMIT_AS, &limit);
  }
#endif
  std::string out;
  try {
    const TriangleMesh m = read();
    const std::uint64_t counts[2] = {m.points.size(), m.triangles.size()};
    out.assign(1, 'M');
    out.append(reinterpret_cast<const char*>(counts), sizeof counts);
    out.append(reinterpret_cast<const char*>(m.points.data()), m.points.size() * sizeof(Vec3));
    out.append(reinterpret_cast<const char*>(m.triangles.data()), m.triangles.size() * sizeof(m.triangles[0]));
  } catch (const InputError& e) {
    out = std::string("E") + e.what();
  } catch (const std::exception& e) {
    out = "E" + path.string() + ": cannot read the mesh: " + e.what();
  }
  writeAll(fd, out);
  ::_exit(0);
}
}  // namespace

TriangleMesh readIsolated(const fs::path& path, const std::function<TriangleMesh()>& read) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) fail(path, std::string("cannot start the mesh reader: ") + std::strerror(errno));
  pid_t pid;
  {
    const std::unique_lock lock(vtkWorkMutex());
    pid = ::fork();
  }
  if (pid == 0) {
    ::close(fds[0]);
    child(fds[1], path, read);
  }
  ::close(fds[1]);
  if (pid < 0) {
    ::close(fds[0]);
    fail(path, std::string("cannot start the mesh reader: ") + std::strerror(errno));
  }
  // Everything the child sends, for at most 120 s.
  std::string bytes;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  bool timedOut = false;
  char buffer[1 << 16];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      timedOut = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, int(std::min<long long>(left, 1000)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) continue;
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    bytes.append(buffer, std::size_t(n));
  }
  ::close(fds[0]);
  if (timedOut) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timedOut) fail(path, "reading the mesh took over 120 s; the file is corrupt or too large");
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.empty())
    fail(path, "the mesh reader crashed or ran out of memory on this file (it is corrupt, or in a form it cannot read)");
  if (bytes[0] == 'E') throw InputError(bytes.substr(1));
  std::uint64_t counts[2];
  if (bytes[0] != 'M' || bytes.size() < 1 + sizeof counts) fail(path, "the mesh reader sent no mesh");
  std::memcpy(counts, bytes.data() + 1, sizeof counts);
  TriangleMesh m;
  const std::size_t need = 1 + sizeof counts + counts[0] * sizeof(Vec3) + counts[1] * sizeof(m.triangles[0]);
  if (counts[0] > bytes.size() || counts[1] > bytes.size() || bytes.size() != need) fail(path, "the mesh reader sent a broken mesh");
  m.points.resize(counts[0]);
  m.triangles.resize(counts[1]);
  std::memcpy(m.points.data(), bytes.data() + 1 + sizeof counts, counts[0] * sizeof(Vec3));
  std::memcpy(m.triangles.data(), bytes.data() + 1 + sizeof counts + counts[0] * sizeof(Vec3), counts[1] * sizeof(m.triangles[0]));
  return m;
}

}  // namespace sinew
