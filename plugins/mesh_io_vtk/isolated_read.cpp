#include "isolated_read.h"

#include "sinew/core/types.h"

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <mutex>
#include <poll.h>
#include <string>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

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
constexpr int kServerFd = 3;              // the server's end of its socket, moved here
constexpr int kIdleExitCode = 75;         // a server idle this long exits with this code
constexpr int kIdleMilliseconds = 5000;   // short: an idle server holds the parent's old pages
constexpr int kReadsPerServer = 256;      // bounds what VTK's leaks on bad files add up to
// A read's deadline: 120 s, or SINEW_MESH_READ_SECONDS (1-3600; the fuzz runs take 5, below their
// own 20 s timeout, so that a hung server is what a user would get: an InputError).
int readSeconds() {
  static const int seconds = [] {
    const char* text = std::getenv("SINEW_MESH_READ_SECONDS");
    const int s = text ? std::atoi(text) : 0;
    return s >= 1 && s <= 3600 ? s : 120;
  }();
  return seconds;
}
constexpr int kReadySeconds = 10;

[[noreturn]] void fail(const fs::path& path, const std::string& problem) { throw InputError(path.string() + ": " + problem); }

bool sendAll(int fd, const void* data, std::size_t size) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::send(fd, bytes, size, MSG_NOSIGNAL);  // a dead peer is an error, not SIGPIPE
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    bytes += n;
    size -= std::size_t(n);
  }
  return true;
}

// Blocking read of exactly size bytes; false at end of stream or on an error.
bool receiveAll(int fd, void* data, std::size_t size) {
  char* bytes = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = ::read(fd, bytes, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    bytes += n;
    size -= std::size_t(n);
  }
  return true;
}

// A reply: its length, then 'M' + counts + points + triangles, or 'E' + the message.
std::string reply(const fs::path& path, MeshReadFunction read) {
  std::string out(sizeof(std::uint64_t), '\0');
  try {
    const TriangleMesh m = read(path);
    const std::uint64_t counts[2] = {m.points.size(), m.triangles.size()};
    out += 'M';
    out.append(reinterpret_cast<const char*>(counts), sizeof counts);
    out.append(reinterpret_cast<const char*>(m.points.data()), m.points.size() * sizeof(Vec3));
    out.append(reinterpret_cast<const char*>(m.triangles.data()), m.triangles.size() * sizeof(m.triangles[0]));
  } catch (const InputError& e) {
    out += 'E';
    out += e.what();
  } catch (const std::exception& e) {
    out += 'E';
    out += path.string();
    out += ": cannot read the mesh: ";
    out += e.what();
  }
  const std::uint64_t length = out.size() - sizeof(std::uint64_t);
  std::memcpy(out.data(), &length, sizeof length);
  return out;
}

void limitMemory() {
#ifdef SINEW_ASAN
  // Under the fuzzer: an ASan report in the server ends the server only (libFuzzer's death callback
  // would record the input as the parent's crash). ASan reserves terabytes of address space, so no
  // address-space limit under it.
  __sanitizer_set_death_callback(nullptr);
#else
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
}

// The server: requests are a function address, a path length and the path; it answers each until
// its socket closes or it has been idle kIdleMilliseconds.
[[noreturn]] void serve(int socket) {
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) std::signal(sig, SIG_DFL);  // die quietly
  std::signal(SIGINT, SIG_IGN);  // Ctrl-C is for the parent, which ends the server by closing it
  // Keep only stdio and the socket: an inherited descriptor would keep a parent's flock or pipe
  // alive for as long as the server lives.
  if (socket != kServerFd) {
    ::dup2(socket, kServerFd);
    ::close(socket);
  }
  ::close_range(kServerFd + 1, ~0U, 0);
  limitMemory();
  // Ready, once the allocator has been used: a fork taken while another thread held an allocator
  // lock would hang here (seen under ASan, whose allocator has no fork handlers in clang 14), and the
  // parent then starts another server instead of waiting out a read's 120 s.
  {
    std::vector<std::string> warm;
    for (std::size_t size = 16; size <= (1u << 20); size *= 4) warm.emplace_back(size, 'w');
  }
  if (!sendAll(kServerFd, "R", 1)) ::_exit(0);
  for (;;) {
    pollfd p{kServerFd, POLLIN, 0};
    const int ready = ::poll(&p, 1, kIdleMilliseconds);
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) ::_exit(kIdleExitCode);
    std::uint64_t header[2];  // the function, the path's length
    if (!receiveAll(kServerFd, header, sizeof header) || header[1] > (1u << 20)) ::_exit(0);
    std::string path(header[1], '\0');
    if (!receiveAll(kServerFd, path.data(), path.size())) ::_exit(0);
    const std::string out = reply(path, reinterpret_cast<MeshReadFunction>(header[0]));
    if (!sendAll(kServerFd, out.data(), out.size())) ::_exit(0);
  }
}

struct Server {
  pid_t pid = -1;
  int fd = -1;
  int reads = 0;
};

// Idle servers, ready for the next read.
struct Pool {
  std::mutex mutex;
  std::vector<Server> idle;
};
Pool& pool() {
  static Pool* p = new Pool;  // never destroyed: servers end when the process's sockets close
  return *p;
}

// Ends a server; returns how it ended (a waitpid status).
int discard(const Server& s, bool kill) {
  ::close(s.fd);
  if (kill) ::kill(s.pid, SIGKILL);
  int status = 0;
  while (::waitpid(s.pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

// Whether a new server said it is ready within kReadySeconds.
bool ready(const Server& s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(kReadySeconds);
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) return false;
    pollfd p{s.fd, POLLIN, 0};
    const int n = ::poll(&p, 1, int(left));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    char byte = 0;
    const ssize_t got = ::read(s.fd, &byte, 1);
    if (got < 0 && errno == EINTR) continue;
    return got == 1 && byte == 'R';
  }
}

Server forkServer(const fs::path& path) {
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0)
    fail(path, std::string("cannot start the mesh reader: ") + std::strerror(errno));
  pid_t pid;
  {
    const std::unique_lock lock(vtkWorkMutex());
    pid = ::fork();
  }
  if (pid == 0) {
    ::close(fds[0]);
    serve(fds[1]);
  }
  ::close(fds[1]);
  if (pid < 0) {
    ::close(fds[0]);
    fail(path, std::string("cannot start the mesh reader: ") + std::strerror(errno));
  }
  return {pid, fds[0], 0};
}

// A new server that said it is ready; a second try when the first did not.
Server startServer(const fs::path& path) {
  for (int attempt = 0;; ++attempt) {
    const Server s = forkServer(path);
    if (ready(s)) return s;
    discard(s, true);
    if (attempt == 1) fail(path, "cannot start the mesh reader: it did not answer");
  }
}

// An idle server that is still alive, else a new one; fresh says which.
Server takeServer(const fs::path& path, bool& fresh) {
  {
    const std::lock_guard lock(pool().mutex);
    auto& idle = pool().idle;
    while (!idle.empty()) {
      const Server s = idle.back();
      idle.pop_back();
      int status = 0;
      if (::waitpid(s.pid, &status, WNOHANG) == 0) {
        fresh = false;
        return s;
      }
      ::close(s.fd);  // exited while idle: reaped above
    }
  }
  fresh = true;
  return startServer(path);
}

void giveBack(Server s) {
  if (++s.reads >= kReadsPerServer) {
    discard(s, true);
    return;
  }
  const std::lock_guard lock(pool().mutex);
  pool().idle.push_back(s);
}

enum class Outcome { Replied, Ended, TimedOut };

// Sends the request and waits at most readSeconds() for the whole reply.
Outcome ask(const Server& s, const fs::path& path, MeshReadFunction read, std::string& bytes) {
  const std::string p = path.string();
  const std::uint64_t header[2] = {reinterpret_cast<std::uint64_t>(read), p.size()};
  if (!sendAll(s.fd, header, sizeof header) || !sendAll(s.fd, p.data(), p.size())) return Outcome::Ended;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(readSeconds());
  std::uint64_t length = 0;
  bool haveLength = false;
  std::string received;
  char buffer[1 << 16];
  for (;;) {
    if (haveLength && received.size() >= length) break;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) return Outcome::TimedOut;
    pollfd pf{s.fd, POLLIN, 0};
    const int ready = ::poll(&pf, 1, int(std::min<long long>(left, 1000)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) continue;
    const std::size_t want = haveLength ? std::min<std::size_t>(sizeof buffer, length - received.size())
                                        : sizeof length - received.size();
    const ssize_t n = ::read(s.fd, buffer, want);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return Outcome::Ended;
    received.append(buffer, std::size_t(n));
    if (!haveLength && received.size() == sizeof length) {
      std::memcpy(&length, received.data(), sizeof length);
      received.clear();
      haveLength = true;
    }
  }
  bytes = std::move(received);
  return Outcome::Replied;
}

TriangleMesh decode(const fs::path& path, const std::string& bytes) {
  if (bytes.empty()) fail(path, "the mesh reader sent nothing");
  if (bytes[0] == 'E') throw InputError(bytes.substr(1));
  std::uint64_t counts[2];
  if (bytes[0] != 'M' || bytes.size() < 1 + sizeof counts) fail(path, "the mesh reader sent no mesh");
  std::memcpy(counts, bytes.data() + 1, sizeof counts);
  TriangleMesh m;
  const std::size_t need = 1 + sizeof counts + counts[0] * sizeof(Vec3) + counts[1] * sizeof(m.triangles[0]);
  if (counts[0] > bytes.size() || counts[1] > bytes.size() || bytes.size() != need) fail(path, "the mesh reader sent a broken mesh");
  m.points.resize(counts[0]);
  m.triangles.resize(counts[1]);
  std::memcpy(static_cast<void*>(m.points.data()), bytes.data() + 1 + sizeof counts, counts[0] * sizeof(Vec3));
  std::memcpy(static_cast<void*>(m.triangles.data()), bytes.data() + 1 + sizeof counts + counts[0] * sizeof(Vec3), counts[1] * sizeof(m.triangles[0]));
  return m;
}
}  // namespace

TriangleMesh readIsolated(const fs::path& path, MeshReadFunction read) {
  for (;;) {
    bool fresh = false;
    const Server server = takeServer(path, fresh);
    std::string bytes;
    const Outcome outcome = ask(server, path, read, bytes);
    if (outcome == Outcome::Replied) {
      giveBack(server);
      return decode(path, bytes);
    }
    const int status = discard(server, true);
    if (outcome == Outcome::TimedOut)
      fail(path, "reading the mesh took over " + std::to_string(readSeconds()) + " s; the file is corrupt or too large");
    // A reused server may have gone idle and exited just as the request came: ask a new one.
    const bool exitedIdle = WIFEXITED(status) && WEXITSTATUS(status) == kIdleExitCode;
    if (!fresh && exitedIdle) continue;
    fail(path, "the mesh reader crashed or ran out of memory on this file (it is corrupt, or in a form it cannot read)");
  }
}

}  // namespace sinew
