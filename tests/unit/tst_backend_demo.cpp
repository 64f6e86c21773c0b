// The Colin27 demo (reduced: four structures, two levels) on both backends through sinew-run
// (label gpu): the same ASSD within 0.01 mm per structure, and the same mesh files. Skips without a
// GPU or mricron-data. The timeline's sampled error agrees too (sampled on the device for CUDA).
#include "sinew/cuda/cuda_engine.h"

#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QProcess>
#include <QTemporaryDir>
#include <QtTest>

namespace {
int run(const QString& program, const QStringList& args, QString* err = nullptr) {
  QProcess p;
  p.start(program, args);
  p.waitForFinished(600000);
  if (err) *err = p.readAllStandardError();
  return p.exitStatus() == QProcess::NormalExit ? p.exitCode() : -1;
}

QJsonObject report(const QString& file) {
  QFile f(file);
  f.open(QIODevice::ReadOnly);
  return QJsonDocument::fromJson(f.readAll()).object();
}
QJsonArray structures(const QString& file) { return report(file)["structures"].toArray(); }
}  // namespace

class TestBackendDemo : public QObject {
  Q_OBJECT
private slots:
  void sameAssdOnBothBackends() {
    const auto st = sinew::cuda::probeDevice();
    if (!st.usable) QSKIP(qPrintable("needs an NVIDIA GPU: " + QString::fromStdString(st.reason)));
    const QString t = "/usr/share/mricron/templates/";
    if (!QFile::exists(t + "aal.nii.gz")) QSKIP("Debian package mricron-data is not installed");
    QTemporaryDir dir;
    const QString scene = dir.filePath("scene.json");
    QString err;
    QCOMPARE(run(SINEW_MAKE_SCENE, {"--atlas", t + "aal.nii.gz", "--labels", t + "aal.nii.txt", "--training",
                                    t + "ch2better.nii.gz", "--target", t + "ch2.nii.gz", "--structures",
                                    "Hippocampus_L,Caudate_R,Putamen_L,Thalamus_R", "--iterations", "150,80", "-o", scene}),
             0);
    for (const char* backend : {"cpu", "cuda"}) {
      QCOMPARE(run(SINEW_RUN, {scene, "-q", "--backend", backend, "-o", dir.filePath(backend)}, &err), 0);
      QVERIFY2(err.isEmpty(), qPrintable(err));  // no fallback notice
    }
    const QJsonArray cpu = structures(dir.filePath("cpu/report.json")), gpu = structures(dir.filePath("cuda/report.json"));
    QCOMPARE(cpu.size(), 4);
    QCOMPARE(gpu.size(), 4);
    for (int i = 0; i < 4; ++i) {
      const double a = cpu[i].toObject()["assd_mm"].toObject()["final"].toDouble();
      const double b = gpu[i].toObject()["assd_mm"].toObject()["final"].toDouble();
      const QString name = cpu[i].toObject()["name"].toString();
      qInfo("%s: ASSD cpu %.4f mm, cuda %.4f mm", qPrintable(name), a, b);
      QVERIFY(std::abs(a - b) <= 0.01);
      // The final evaluation's distances, searched on the device for the CUDA run
      // (closestDistances) and on the host for the CPU run: the same scores.
      for (const char* key : {"hd95_mm", "dice"})
        QVERIFY2(std::abs(cpu[i].toObject()[key].toDouble() - gpu[i].toObject()[key].toDouble()) <= 1e-6, key);
      QVERIFY(std::abs(a - b) <= 1e-6);
      // Stronger: the written meshes are the same bytes.
      QFile fa(dir.filePath("cpu/" + name + ".vtp")), fb(dir.filePath("cuda/" + name + ".vtp"));
      QVERIFY(fa.open(QIODevice::ReadOnly) && fb.open(QIODevice::ReadOnly));
      QVERIFY2(fa.readAll() == fb.readAll(), qPrintable(name + ": meshes differ"));
    }
    // The timeline's error, sampled on the device for the CUDA run (device_error.h) and on the host
    // for the CPU run, by the same inline queries: the same values at every sample.
    const QJsonArray tc = report(dir.filePath("cpu/report.json"))["timeline"].toArray();
    const QJsonArray tg = report(dir.filePath("cuda/report.json"))["timeline"].toArray();
    QCOMPARE(tc.size(), tg.size());
    double worst = 0;
    for (int k = 0; k < tc.size(); ++k)
      for (const char* key : {"assd_mm", "hd95_mm"}) {
        QVERIFY(tg[k].toObject()[key].isDouble());
        worst = std::max(worst, std::abs(tc[k].toObject()[key].toDouble() - tg[k].toObject()[key].toDouble()));
      }
    qInfo("timeline: %lld samples, largest difference cpu/cuda %.2e mm", qint64(tc.size()), worst);
    QVERIFY(worst <= 1e-4);
  }
};

QTEST_GUILESS_MAIN(TestBackendDemo)
#include "tst_backend_demo.moc"
