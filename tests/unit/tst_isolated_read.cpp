// The mesh plugin's reader servers (plugins/mesh_io_vtk/isolated_read.h), with readers that crash,
// abort, throw and succeed on purpose: a crash ends one read, never the caller, and the next read
// works; reads run side by side; a server idle past its timeout is replaced without the caller
// noticing.
#include "../../plugins/mesh_io_vtk/isolated_read.h"

#include "sinew/core/types.h"

#include <QtTest>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <thread>
#include <unistd.h>

using namespace sinew;
namespace fs = std::filesystem;

namespace {
// The path's stem picks the mesh's size: "n7" gives 7 points, and the server's pid as a coordinate.
TriangleMesh readByName(const fs::path& path) {
  const int n = std::atoi(path.stem().string().c_str() + 1);
  TriangleMesh m;
  for (int i = 0; i < n; ++i) m.points.emplace_back(float(i), float(::getpid()), 0.0f);
  m.triangles.push_back({0, 1, 2});
  return m;
}
TriangleMesh readSegfault(const fs::path&) {
  std::raise(SIGSEGV);
  return {};
}
TriangleMesh readAbort(const fs::path&) { std::abort(); }
TriangleMesh readRefuse(const fs::path& path) { throw InputError(path.string() + ": refused on purpose"); }
TriangleMesh readOther(const fs::path& path) { throw std::runtime_error("bad " + path.string()); }

QString failure(const fs::path& path, MeshReadFunction read) {
  try {
    readIsolated(path, read);
  } catch (const InputError& e) {
    return QString::fromUtf8(e.what());
  }
  return {};
}
}  // namespace

class TestIsolatedRead : public QObject {
  Q_OBJECT
private slots:
  void returnsTheMeshAndReusesTheServer() {
    const TriangleMesh a = readIsolated("n5.vtp", &readByName);
    QCOMPARE(a.points.size(), std::size_t(5));
    QCOMPARE(a.triangles.size(), std::size_t(1));
    QVERIFY(a.points[0].y() != float(::getpid()));  // read in another process
    const TriangleMesh b = readIsolated("n70000.vtp", &readByName);  // larger than one socket buffer
    QCOMPARE(b.points.size(), std::size_t(70000));
    QCOMPARE(b.points[69999].x(), 69999.0f);
    QCOMPARE(b.points[0].y(), a.points[0].y());  // the same server
  }

  void aCrashEndsOneReadOnly() {
    const QString segv = failure("crash.vtk", &readSegfault);
    QVERIFY2(segv.startsWith("crash.vtk: ") && segv.contains("crashed"), qPrintable(segv));
    const QString abort = failure("abort.vtk", &readAbort);
    QVERIFY2(abort.startsWith("abort.vtk: ") && abort.contains("crashed"), qPrintable(abort));
    QCOMPARE(readIsolated("n3.vtp", &readByName).points.size(), std::size_t(3));
  }

  void errorsComeBackNamingTheFile() {
    QCOMPARE(failure("bad.vtp", &readRefuse), QString("bad.vtp: refused on purpose"));
    const QString other = failure("odd.vtp", &readOther);
    QVERIFY2(other.startsWith("odd.vtp: cannot read the mesh: bad odd.vtp"), qPrintable(other));
    QCOMPARE(readIsolated("n4.vtp", &readByName).points.size(), std::size_t(4));  // the server lives on
  }

  void readsRunSideBySide() {
    std::atomic<int> good{0}, crashed{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 6; ++t)
      threads.emplace_back([&, t] {
        for (int i = 0; i < 40; ++i) {
          if ((t + i) % 7 == 0) {
            if (failure("c.vtk", &readSegfault).contains("crashed")) ++crashed;
          } else if (readIsolated("n" + std::to_string(3 + i) + ".vtp", &readByName).points.size() == std::size_t(3 + i)) {
            ++good;
          }
        }
      });
    for (auto& th : threads) th.join();
    int expectCrashed = 0;
    for (int t = 0; t < 6; ++t)
      for (int i = 0; i < 40; ++i) expectCrashed += (t + i) % 7 == 0;
    QCOMPARE(crashed.load(), expectCrashed);
    QCOMPARE(good.load(), 240 - expectCrashed);
  }

  void anIdleServerIsReplaced() {
    const float before = readIsolated("n3.vtp", &readByName).points[0].y();
    QThread::sleep(6);  // past the servers' 5 s idle timeout: they have exited
    const float after = readIsolated("n3.vtp", &readByName).points[0].y();
    QVERIFY(after != before);
  }
};

QTEST_GUILESS_MAIN(TestIsolatedRead)
#include "tst_isolated_read.moc"
