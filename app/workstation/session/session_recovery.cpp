#include "session_recovery.h"

#include <nlohmann/json.hpp>
#include <zlib.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <limits>
#include <set>
#include <sys/file.h>
#include <unistd.h>

namespace sinew {

namespace {
namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;  // keeps the scene's force order (its evaluation order)
constexpr int kFormatVersion = 1;
constexpr char kMagic[8] = {'S', 'N', 'W', 'S', 'N', 'A', 'P', '1'};

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

[[noreturn]] void fail(const fs::path& file, const std::string& problem) {
  throw InputError(file.string() + ": " + problem);
}

fs::path snapshotFile(const fs::path& folder, std::uint64_t id) {
  return folder / ("snapshot-" + std::to_string(id) + ".bin");
}

// Writes to a temporary name beside the file, then renames it over the file.
void writeAtomically(const fs::path& file, const std::string& bytes) {
  const fs::path temp = file.string() + ".tmp";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.flush();
    if (!out) fail(temp, "cannot be written (disk full?)");
  }
  std::error_code ec;
  fs::rename(temp, file, ec);
  if (ec) fail(file, "cannot be replaced: " + ec.message());
}

// --- snapshots: a flat little-endian byte stream with its CRC-32 at the end ------------------------

class Bytes {
public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T> || std::is_same_v<T, Vec3>);  // Vec3: three packed floats
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T>
  void putVector(const std::vector<T>& v) {
    put<std::uint64_t>(v.size());
    out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void putString(const std::string& s) {
    put<std::uint64_t>(s.size());
    out += s;
  }
  std::string out;
};

class Reader {
public:
  Reader(const fs::path& file, const std::string& bytes) : file_(file), bytes_(bytes) {}
  template <class T>
  T get() {
    T v;
    need(sizeof v);
    std::memcpy(static_cast<void*>(&v), bytes_.data() + at_, sizeof v);
    at_ += sizeof v;
    return v;
  }
  std::uint64_t count(std::size_t elementBytes) {
    const auto n = get<std::uint64_t>();
    if (n > (bytes_.size() - at_) / std::max<std::size_t>(elementBytes, 1)) fail(file_, "is truncated or corrupt");
    return n;
  }
  template <class T>
  std::vector<T> getVector() {
    std::vector<T> v(count(sizeof(T)));
    std::memcpy(static_cast<void*>(v.data()), bytes_.data() + at_, v.size() * sizeof(T));
    at_ += v.size() * sizeof(T);
    return v;
  }
  std::string getString() {
    const auto n = count(1);
    std::string s = bytes_.substr(at_, n);
    at_ += n;
    return s;
  }
  void need(std::size_t n) const {
    if (n > bytes_.size() - at_) fail(file_, "is truncated or corrupt");
  }
  bool done() const { return at_ == bytes_.size(); }

private:
  const fs::path& file_;
  const std::string& bytes_;
  std::size_t at_ = 0;
};

std::string encode(const SessionSnapshot& s) {
  Bytes b;
  b.out.append(kMagic, sizeof kMagic);
  b.putString(s.label);
  b.put<std::int32_t>(s.level);
  b.putVector(s.positions);
  b.putVector(s.previous);
  b.put<std::uint64_t>(s.points.size());
  for (const auto& p : s.points) b.putVector(p);
  b.put<std::uint64_t>(s.constraints.size());
  for (const auto& list : s.constraints) {
    b.put<std::uint64_t>(list.size());
    for (const auto& c : list) {
      b.put(c.at);
      b.put<std::uint8_t>(c.include ? 1 : 0);
    }
  }
  b.put<std::uint64_t>(s.landmarks.size());
  for (const auto& l : s.landmarks) {
    b.put(l.from);
    b.put(l.to);
  }
  b.put<std::uint64_t>(s.forceParams.size());
  for (const ParamTable& t : s.forceParams) {
    b.put<std::uint64_t>(t.decls().size());
    for (const auto& d : t.decls()) b.putString(d.name);
    b.put<std::uint64_t>(t.rows());
    for (Index r = 0; r < t.rows(); ++r)
      for (int p = 0; p < int(t.decls().size()); ++p) b.put(t.get(r, p));
  }
  b.put<std::uint32_t>(std::uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(b.out.data()), uInt(b.out.size()))));
  return std::move(b.out);
}

SessionSnapshot decode(const fs::path& file, std::uint64_t id) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, "cannot be opened");
  const std::string bytes{std::istreambuf_iterator<char>(in), {}};
  if (bytes.size() < sizeof kMagic + 4 || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
    fail(file, "is not a Sinew recovery snapshot");
  std::uint32_t stored;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  if (stored != std::uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), uInt(bytes.size() - 4))))
    fail(file, "checksum mismatch (damaged)");
  const std::string body = bytes.substr(sizeof kMagic, bytes.size() - sizeof kMagic - 4);
  Reader r(file, body);
  SessionSnapshot s;
  s.id = id;
  s.label = r.getString();
  s.level = r.get<std::int32_t>();
  s.positions = r.getVector<Vec3>();
  s.previous = r.getVector<Vec3>();
  s.points.resize(r.count(8));
  for (auto& p : s.points) p = r.getVector<Vec3>();
  s.constraints.resize(r.count(8));
  for (auto& list : s.constraints) {
    list.resize(r.count(sizeof(Vec3) + 1));
    for (auto& c : list) {
      c.at = r.get<Vec3>();
      c.include = r.get<std::uint8_t>() != 0;
    }
  }
  s.landmarks.resize(r.count(2 * sizeof(Vec3)));
  for (auto& l : s.landmarks) {
    l.from = r.get<Vec3>();
    l.to = r.get<Vec3>();
  }
  const auto tables = r.count(16);
  for (std::uint64_t t = 0; t < tables; ++t) {
    std::vector<ParamDecl> decls(r.count(8));
    for (auto& d : decls) {
      // The names only: restoreState() puts the values into the scene's own declarations.
      d.name = r.getString();
      d.min = -std::numeric_limits<double>::infinity();
      d.max = std::numeric_limits<double>::infinity();
    }
    const auto rows = r.count(8 * std::max<std::size_t>(decls.size(), 1));
    ParamTable table(std::move(decls), Index(rows));
    for (Index row = 0; row < Index(rows); ++row)
      for (int p = 0; p < int(table.decls().size()); ++p) table.set(row, p, r.get<double>());
    s.forceParams.push_back(std::move(table));
  }
  if (!r.done()) fail(file, "has trailing bytes (damaged)");
  return s;
}

Json sampleJson(const SessionSample& s) {
  return Json::array({s.seconds, s.iteration, s.level, std::isfinite(s.assdMm) ? Json(s.assdMm) : Json(nullptr),
                      s.displacementMm, std::isfinite(s.dice) ? Json(s.dice) : Json(nullptr)});
}

SessionSample sampleOf(const Json& j) {
  SessionSample s;
  s.seconds = j.at(0).get<double>();
  s.iteration = j.at(1).get<long>();
  s.level = j.at(2).get<int>();
  s.assdMm = j.at(3).is_null() ? std::nan("") : j.at(3).get<double>();
  s.displacementMm = j.at(4).get<double>();
  if (j.size() > 5 && !j.at(5).is_null()) s.dice = j.at(5).get<double>();  // saved since 2026-12-02
  return s;
}

// Whether some process holds the slot's lock (a living workstation).
bool held(const fs::path& folder) {
  const int fd = ::open((folder / ".lock").c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return false;
  const bool busy = ::flock(fd, LOCK_EX | LOCK_NB) != 0;
  ::close(fd);
  return busy;
}
}  // namespace

SessionRecovery::SessionRecovery(const fs::path& root) : folder_(root / std::to_string(::getpid())) {
  std::error_code ec;
  fs::create_directories(folder_, ec);
  if (ec) fail(folder_, "cannot create the recovery folder: " + ec.message());
  lockFd_ = ::open((folder_ / ".lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lockFd_ < 0 || ::flock(lockFd_, LOCK_EX | LOCK_NB) != 0)
    fail(folder_, std::string("cannot hold the recovery folder: ") + std::strerror(errno));
  clear();  // a slot of a dead process that had this pid
}

SessionRecovery::~SessionRecovery() {
  try {
    wait();
  } catch (...) {
  }
  std::error_code ec;
  fs::remove_all(folder_, ec);  // while still holding it
  if (lockFd_ >= 0) ::close(lockFd_);
}

std::string SessionRecovery::lastError() const {
  const std::lock_guard lock(errorMutex_);
  return error_;
}

void SessionRecovery::wait() {
  if (pending_.valid()) pending_.get();
}

void SessionRecovery::clear() {
  try {
    wait();
  } catch (...) {
  }
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder_, ec))
    if (e.path().filename() != ".lock") fs::remove_all(e.path(), ec);
  savedRevision_ = 0;
}

bool SessionRecovery::maybeSave(SegmentationSession& session, double intervalSeconds) {
  if (!session.isOpen() || session.revision() == savedRevision_ || now() - lastSave_ < intervalSeconds) return false;
  if (pending_.valid() && pending_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return false;
  start(session);
  return true;
}

void SessionRecovery::saveNow(SegmentationSession& session) {
  wait();
  start(session);
  wait();
}

void SessionRecovery::start(SegmentationSession& session) {
  if (pending_.valid()) {
    try {
      pending_.get();
    } catch (const std::exception& e) {
      const std::lock_guard lock(errorMutex_);
      error_ = e.what();
    }
  }
  const double t0 = now();
  auto state = std::make_shared<SessionState>(session.state());
  copySeconds_ = now() - t0;
  maxCopySeconds_ = std::max(maxCopySeconds_, copySeconds_);
  savedRevision_ = session.revision();
  lastSave_ = now();
  pending_ = std::async(std::launch::async, [this, state] { write(*state); });
}

void SessionRecovery::write(const SessionState& state) {
  // Snapshots first (each once: they never change), then the manifest, then what it no longer names.
  std::set<std::string> keep = {".lock", "session.json"};
  auto snapshot = [&](const SessionSnapshot& s) {
    const fs::path file = snapshotFile(folder_, s.id);
    keep.insert(file.filename().string());
    if (!fs::exists(file)) writeAtomically(file, encode(s));
    return s.id;
  };
  Json j;
  j["format"] = "sinew-recovery";
  j["version"] = kFormatVersion;
  j["scene"] = Json::parse(sceneToJson(state.scene));
  j["scene_file"] = state.scene.file.string();
  j["level_iterations_done"] = state.levelIterationsDone;
  j["iteration"] = state.iteration;
  j["simulation_seconds"] = state.simulationSeconds;
  j["timeline"] = Json::array();
  for (const auto& s : state.timeline) j["timeline"].push_back(sampleJson(s));
  j["current"] = snapshot(*state.current);
  j["undo"] = Json::array();
  for (const auto& s : state.undo) j["undo"].push_back(snapshot(*s));
  j["redo"] = Json::array();
  for (const auto& s : state.redo) j["redo"].push_back(snapshot(*s));
  writeAtomically(folder_ / "session.json", j.dump(1));
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder_, ec))
    if (!keep.count(e.path().filename().string())) fs::remove(e.path(), ec);
  ++completed_;
}

std::vector<fs::path> SessionRecovery::orphans(const fs::path& root) {
  std::vector<std::pair<fs::file_time_type, fs::path>> found;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec)) {
    const fs::path manifest = e.path() / "session.json";
    if (e.is_directory() && fs::exists(manifest) && !held(e.path()))
      found.emplace_back(fs::last_write_time(manifest, ec), e.path());
  }
  std::sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<fs::path> out;
  for (auto& f : found) out.push_back(std::move(f.second));
  return out;
}

SessionState SessionRecovery::read(const fs::path& folder) {
  const fs::path manifest = folder / "session.json";
  std::ifstream in(manifest);
  if (!in) fail(manifest, "cannot be opened");
  SessionState state;
  try {
    const Json j = Json::parse(in);
    if (j.at("format") != "sinew-recovery") fail(manifest, "is not a Sinew recovery file");
    if (j.at("version") != kFormatVersion) fail(manifest, "was written by another version of Sinew");
    state.scene = parseScene(j.at("scene").dump(), manifest);
    state.scene.file = j.at("scene_file").get<std::string>();
    state.levelIterationsDone = j.at("level_iterations_done").get<int>();
    state.iteration = j.at("iteration").get<long>();
    state.simulationSeconds = j.at("simulation_seconds").get<double>();
    for (const auto& s : j.at("timeline")) state.timeline.push_back(sampleOf(s));
    auto load = [&](const Json& id) {
      const auto n = id.get<std::uint64_t>();
      return std::make_shared<const SessionSnapshot>(decode(snapshotFile(folder, n), n));
    };
    state.current = load(j.at("current"));
    for (const auto& id : j.at("undo")) state.undo.push_back(load(id));
    for (const auto& id : j.at("redo")) state.redo.push_back(load(id));
  } catch (const Json::exception& e) {
    fail(manifest, std::string("is damaged: ") + e.what());
  }
  return state;
}

void SessionRecovery::discard(const fs::path& folder) {
  if (held(folder)) return;  // a living workstation's
  std::error_code ec;
  fs::remove_all(folder, ec);
}

}  // namespace sinew
