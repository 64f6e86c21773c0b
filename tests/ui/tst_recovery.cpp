// Crash recovery (issue "never garbage, never lost"): the workstation autosaves its session and a
// new one restores it after the first was killed with SIGKILL. The killed workstation is this same
// program started again with --child: a real MainWindow that places points, runs, and is killed
// while it keeps running and saving.
#include "builtin_plugins.h"
#include "interaction_tool.h"
#include "main_window.h"
#include "ui_test_setup.h"
#include "session_recovery.h"

#include <QApplication>
#include <QDir>
#include <QFile>
#include <QProcess>
#include <QSurfaceFormat>
#include <QTemporaryDir>
#include <QtTest>

#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <fstream>

using namespace sinew;

namespace {
namespace fs = std::filesystem;
const QString kTemplates = "/usr/share/mricron/templates/";
const Vec3 kPointA(-20.0f, 10.0f, 5.0f), kPointB(22.0f, -3.0f, 8.0f);  // for the session alone

SessionOpenOptions cpuOptions() {
  SessionOpenOptions o;
  o.threads = 2;
  o.backend = "cpu";
  return o;
}

// A test window: the CPU, no saved settings, autosave into root.
WorkstationOptions recoveringOptions(const QString& root) {
  WorkstationOptions o;
  o.backend = "cpu";
  o.persistSettings = false;
  o.recoveryRoot = root.toStdString();
  return o;
}

std::vector<Vec3> positionsOf(SegmentationSession& session) {
  session.syncHost();
  const auto x = session.simulation().store().positions();
  return {x.begin(), x.end()};
}

// The child: opens the scene with autosave every second, makes edits, runs, says when a save that
// holds all of it is on disk, and goes on running and saving until it is killed.
int runChild(const QString& scene, const QString& root) {
  Registry registry;
  registerBuiltinPlugins(registry);
  ToolRegistry tools;
  registerBuiltinTools(tools);
  WorkstationOptions o = recoveringOptions(root);
  o.autosaveSeconds = 1.0;
  MainWindow window(registry, tools, o);
  window.resize(900, 700);
  window.show();
  if (!window.openScene(scene)) return 3;
  SegmentationSession& session = window.session();
  // A point 2 mm beyond each structure, as a user would place one.
  Vec3 points[2];
  for (Index s = 0; s < 2; ++s) {
    const MeshStore& store = session.simulation().store();
    const MeshRange& r = store.range(s);
    points[s] = store.positions()[r.vertexBegin];
    for (Index v = r.vertexBegin; v < r.vertexEnd; ++v)
      if (store.positions()[v].x() > points[s].x()) points[s] = store.positions()[v];
    points[s] += Vec3(2, 0, 0);
    session.addAttractionPoint(s, points[s]);
  }
  session.addLandmark(Vec3(1, 2, 3), Vec3(2, 3, 4));
  window.setFollowSchedule(false);
  window.setRunning(true);
  QTimer poll;
  bool told = false;
  QObject::connect(&poll, &QTimer::timeout, [&] {
    // A save of our own, after the edits and some steps (the autosave goes on around it): what it
    // holds is on disk when saveNow returns.
    if (!told && window.recovery()->savesCompleted() >= 1 && session.simulation().iteration() > 20) {
      window.recovery()->saveNow(session);
      std::printf("saved-at-least %ld %a %a %a %a %a %a\n", long(session.simulation().iteration()), points[0].x(),
                  points[0].y(), points[0].z(), points[1].x(), points[1].y(), points[1].z());
      std::fflush(stdout);
      told = true;
    }
  });
  poll.start(20);
  return QApplication::exec();
}
}  // namespace

class TestRecovery : public QObject {
  Q_OBJECT

private Q_SLOTS:
  void initTestCase() {
    if (!QFile::exists(kTemplates + "aal.nii.gz")) QSKIP("Debian package mricron-data is not installed");
    QCOMPARE(testing::makeColin27Scene(SINEW_MAKE_SCENE, dir_.filePath("scene.json"), "Caudate_R,Putamen_L", "40,20"), 0);
    registerBuiltinPlugins(registry_);
  }

  // The session's state, undo steps included, written and read back exactly.
  void stateRoundTripsWithItsUndoSteps() {
    const fs::path root = dir_.filePath("roundtrip").toStdString();
    SegmentationSession a(registry_);
    a.open(dir_.filePath("scene.json").toStdString(), cpuOptions());
    a.step(5);
    a.addAttractionPoint(0, kPointA);
    a.step(5);
    a.addConstraintPoint(1, {kPointB, false});
    a.setParameter("smoothing", 1, "weight", 0.25);
    a.step(3);
    a.sample();
    fs::path slot;
    {
      SessionRecovery recovery(root);
      slot = recovery.folder();
      recovery.saveNow(a);
      QCOMPARE(recovery.savesCompleted(), 1);
      QVERIFY(SessionRecovery::orphans(root).empty());  // held by its living owner
      // Read while the owner lives, as a copy would be.
      const SessionState state = SessionRecovery::read(slot);
      SegmentationSession b(registry_);
      b.restoreState(state, cpuOptions());
      QVERIFY(positionsOf(b) == positionsOf(a));
      QCOMPARE(b.simulation().iteration(), a.simulation().iteration());
      QCOMPARE(b.levelIterationsDone(), a.levelIterationsDone());
      QCOMPARE(b.timeline().size(), a.timeline().size());
      QVERIFY(std::isfinite(a.timeline().back().dice) && a.timeline().back().dice > 0.5);  // a Colin27 scene: with truth
      QCOMPARE(b.timeline().back().dice, a.timeline().back().dice);
      QVERIFY(b.attractionPoints(0) == a.attractionPoints(0));
      QVERIFY(b.constraintPoints(1) == a.constraintPoints(1));
      QCOMPARE(b.parameter("smoothing", 1, "weight"), 0.25);
      QCOMPARE(b.undoLabel(), a.undoLabel());
      // Undo walks back the same way in both.
      while (a.canUndo()) {
        QVERIFY(b.undo());
        a.undo();
        QVERIFY(positionsOf(b) == positionsOf(a));
        QVERIFY(b.attractionPoints(0) == a.attractionPoints(0));
        QCOMPARE(b.parameter("smoothing", 1, "weight"), a.parameter("smoothing", 1, "weight"));
      }
      QVERIFY(!b.canUndo());
      QVERIFY(b.redo());
    }
    QVERIFY(!fs::exists(slot));  // a clean exit leaves nothing to recover
  }

  // A damaged save is refused with the file named; nothing is restored from it.
  void damagedSaveIsRefused() {
    const fs::path root = dir_.filePath("damaged").toStdString();
    SegmentationSession a(registry_);
    a.open(dir_.filePath("scene.json").toStdString(), cpuOptions());
    a.addAttractionPoint(0, kPointA);
    SessionRecovery recovery(root);
    recovery.saveNow(a);
    fs::path snapshot;
    for (const auto& e : fs::directory_iterator(recovery.folder()))
      if (e.path().extension() == ".bin") snapshot = e.path();
    QVERIFY(!snapshot.empty());
    {
      std::fstream f(snapshot, std::ios::in | std::ios::out | std::ios::binary);
      f.seekp(100);
      f.put('\x7f');
    }
    try {
      SessionRecovery::read(recovery.folder());
      QFAIL("a damaged snapshot was read");
    } catch (const InputError& e) {
      QVERIFY2(std::string(e.what()).find(snapshot.string() + ": checksum mismatch") != std::string::npos, e.what());
    }
  }

  // kill -9 of a running workstation with placed points; the next one restores its work.
  void restoresAfterKill() {
    const QString root = dir_.filePath("recovery");
    QProcess child;
    child.setProcessChannelMode(QProcess::ForwardedErrorChannel);
    child.start(QCoreApplication::applicationFilePath(), {"--child", dir_.filePath("scene.json"), root});
    QVERIFY(child.waitForStarted());
    long savedAtLeast = -1;
    Vec3 points[2];
    QElapsedTimer clock;
    clock.start();
    while (savedAtLeast < 0 && clock.elapsed() < 120000) {
      if (!child.waitForReadyRead(500) && child.state() != QProcess::Running) break;
      while (child.canReadLine()) {
        const QString line = QString::fromUtf8(child.readLine()).trimmed();
        if (!line.startsWith("saved-at-least ")) continue;
        const QStringList f = line.split(' ');
        savedAtLeast = f[1].toLong();
        for (int k = 0; k < 6; ++k) points[k / 3][k % 3] = std::strtof(f[2 + k].toLatin1().constData(), nullptr);
      }
    }
    QVERIFY2(savedAtLeast > 0, qPrintable(QString("the child never reported a save (state %1, exit code %2, %3)")
                                              .arg(int(child.state()))
                                              .arg(child.exitCode())
                                              .arg(child.errorString())));
    QTest::qWait(1500);  // it keeps running and saving: the kill may land during a save
    ::kill(pid_t(child.processId()), SIGKILL);
    QVERIFY(child.waitForFinished(10000));
    QCOMPARE(child.exitStatus(), QProcess::CrashExit);

    const auto orphans = SessionRecovery::orphans(root.toStdString());
    QCOMPARE(orphans.size(), std::size_t(1));
    ToolRegistry tools;
    registerBuiltinTools(tools);
    MainWindow window(registry_, tools, recoveringOptions(root));
    window.show();
    QVERIFY(QTest::qWaitForWindowExposed(&window));
    QVERIFY(window.restoreRecovered(QString::fromStdString(orphans.front().string())));
    SegmentationSession& s = window.session();
    QVERIFY(s.isOpen());
    QVERIFY(s.attractionPoints(0) == std::vector<Vec3>{points[0]});
    QVERIFY(s.attractionPoints(1) == std::vector<Vec3>{points[1]});
    QCOMPARE(s.landmarks().size(), std::size_t(1));
    qInfo("saved at iteration %ld before the kill; restored at %ld", savedAtLeast, long(s.simulation().iteration()));
    QVERIFY2(s.simulation().iteration() >= savedAtLeast,
             qPrintable(QString("restored at iteration %1, saved at %2").arg(s.simulation().iteration()).arg(savedAtLeast)));
    QVERIFY(!s.timeline().empty());
    for (const Vec3& v : positionsOf(s)) QVERIFY(v.allFinite());
    // The edits are still undoable: the landmark, then the points.
    QCOMPARE(QString::fromStdString(s.undoLabel()), QString("Add landmark"));
    QVERIFY(s.undo());
    QVERIFY(s.landmarks().empty());
    QVERIFY(SessionRecovery::orphans(root.toStdString()).empty());  // restored: removed
    QCOMPARE(QDir(root).entryList(QDir::Dirs | QDir::NoDotAndDotDot).size(), 1);  // only this window's slot
  }

private:
  QTemporaryDir dir_;
  Registry registry_;
};

int main(int argc, char** argv) {
  sinew::testing::prepareOpenGlForTests();
  QApplication app(argc, argv);
  if (argc == 4 && std::string(argv[1]) == "--child") return runChild(argv[2], argv[3]);
  TestRecovery test;
  return QTest::qExec(&test, argc, argv);
}

#include "tst_recovery.moc"
