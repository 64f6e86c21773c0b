// The plugin SDK end to end: this build is installed to a staging prefix, examples/force-plugin is
// configured and built out of tree against it (find_package(Sinew COMPONENTS pluginsdk)), its own
// tests run, and the installed sinew-run uses the balloon plugin in a scene on Colin27. The balloon
// must grow the mesh: the same scene with the balloon weighted 0 is the control.
#include "sinew/core/registry.h"
#include "synthetic.h"

#include <QDir>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QProcess>
#include <QTemporaryDir>
#include <QtTest>

#include <fstream>

using namespace sinew;

namespace {
// Runs a program; on failure the test fails with its output.
bool run(const QString& program, const QStringList& args, const QProcessEnvironment& env, int expected = 0,
         QString* err = nullptr) {
  QProcess p;
  p.setProcessEnvironment(env);
  p.setProcessChannelMode(err ? QProcess::SeparateChannels : QProcess::MergedChannels);
  p.start(program, args);
  if (!p.waitForFinished(900000)) {
    qWarning("%s timed out", qPrintable(program));
    return false;
  }
  const QString out = QString::fromUtf8(p.readAllStandardOutput());
  if (err) *err = QString::fromUtf8(p.readAllStandardError());
  if (p.exitStatus() != QProcess::NormalExit || p.exitCode() != expected) {
    qWarning("%s %s: exit %d\n%s%s", qPrintable(program), qPrintable(args.join(' ')), p.exitCode(), qPrintable(out),
             err ? qPrintable(*err) : "");
    return false;
  }
  return true;
}
}  // namespace

class TestExamplePlugin : public QObject {
  Q_OBJECT
private Q_SLOTS:
  void balloonPluginBuiltOutOfTreeGrowsTheMesh() {
    if (!QFile::exists("/usr/share/mricron/templates/aal.nii.gz")) QSKIP("Debian package mricron-data is not installed");
    QTemporaryDir work;
    const QString stage = work.filePath("stage"), build = work.filePath("balloon-build");
    QProcessEnvironment env = QProcessEnvironment::systemEnvironment();
    env.remove("SINEW_PLUGIN_PATH");
    env.insert("XDG_DATA_HOME", work.filePath("data"));  // no user plugins
    QVERIFY(run(CMAKE_COMMAND, {"--install", SINEW_BUILD_DIR, "--prefix", stage}, env));
    QVERIFY(QFileInfo::exists(stage + "/include/sinew/core/plugin_api.h"));

    QVERIFY(run(CMAKE_COMMAND, {"-S", SINEW_SOURCE_DIR "/examples/force-plugin", "-B", build, "-G", "Ninja",
                                "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_PREFIX_PATH=" + stage},
                env));
    QVERIFY(run(CMAKE_COMMAND, {"--build", build}, env));
    QVERIFY(run(CTEST_COMMAND, {"--test-dir", build, "--output-on-failure"}, env));
    QVERIFY(QFileInfo::exists(build + "/sinew-plugin-balloon.so"));

    // The scene names the plugin; without a directory holding it, sinew-run refuses the scene.
    const QString sinewRun = stage + "/bin/sinew-run";
    const QString scene = SINEW_SOURCE_DIR "/examples/force-plugin/balloon_scene.sinew.json";
    QString err;
    QVERIFY(run(sinewRun, {scene, "-o", work.filePath("none"), "-q", "--backend", "cpu"}, env, 3, &err));
    QVERIFY2(err.contains("plugin 'balloon' not found"), qPrintable(err));

    env.insert("SINEW_PLUGIN_PATH", build);
    QVERIFY(run(sinewRun, {scene, "-o", work.filePath("balloon"), "-q", "--backend", "cpu"}, env));
    // The control: the same scene with the balloon switched off.
    QFile in(scene);
    QVERIFY(in.open(QIODevice::ReadOnly));
    QString text = QString::fromUtf8(in.readAll());
    QVERIFY(text.contains("\"balloon\": {\"weight\": 1.0"));
    text.replace("\"balloon\": {\"weight\": 1.0", "\"balloon\": {\"weight\": 0.0");
    const QString control = work.filePath("control.sinew.json");
    std::ofstream(control.toStdString()) << text.toStdString();
    QVERIFY(run(sinewRun, {control, "-o", work.filePath("control"), "-q", "--backend", "cpu"}, env));

    // The report names the plugin build that made the result.
    QFile report(work.filePath("balloon/report.json"));
    QVERIFY(report.open(QIODevice::ReadOnly));
    const QJsonArray plugins = QJsonDocument::fromJson(report.readAll())["plugins"].toArray();
    QCOMPARE(plugins.size(), 1);
    QCOMPARE(plugins[0]["name"].toString(), QString("balloon"));
    QCOMPARE(plugins[0]["version"].toString(), QString("1.0.0"));
    QCOMPARE(plugins[0]["file"].toString(), build + "/sinew-plugin-balloon.so");

    const Registry& registry = testing::builtinRegistry();
    auto volume = [&](const QString& dir) {
      const std::filesystem::path mesh = (dir + "/Thalamus_L.vtp").toStdString();
      return registry.meshIOFor(mesh).read(mesh).volume();
    };
    const double grown = volume(work.filePath("balloon")), kept = volume(work.filePath("control"));
    qInfo("Thalamus_L volume: %.0f mm3 with the balloon, %.0f mm3 without", grown, kept);
    QVERIFY(kept > 1000.0);
    QVERIFY2(grown > 1.3 * kept, qPrintable(QString("%1 vs %2").arg(grown).arg(kept)));
  }
};

QTEST_GUILESS_MAIN(TestExamplePlugin)
#include "tst_example_plugin.moc"
