// sinew-cohort end to end on Colin27 (mricron-data): a model, two generated subjects and two broken
// ones (an image that does not exist, a truncated one), run locally, resumed, reported; the same
// cohort on a real Slurm (munged, slurmctld and slurmd started on this host by
// tests/cohort/slurm_local.sh) as a job array with its report job; manifests refused.
#include "run_tool.h"

#include <algorithm>

#include <QDir>
#include <QFile>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QSet>
#include <QTemporaryDir>
#include <QThread>
#include <QtTest>

using namespace sinew::testing;

namespace {

const QString kTemplates = "/usr/share/mricron/templates/";

QJsonObject readJson(const QString& path) {
  QFile f(path);
  if (!f.open(QIODevice::ReadOnly)) return {};
  return QJsonDocument::fromJson(f.readAll()).object();
}

QString readText(const QString& path) {
  QFile f(path);
  return f.open(QIODevice::ReadOnly) ? QString::fromUtf8(f.readAll()) : QString();
}

void writeText(const QString& path, const QString& text) {
  QFile f(path);
  QVERIFY(f.open(QIODevice::WriteOnly | QIODevice::Truncate));
  f.write(text.toUtf8());
}

}  // namespace

class TestCohort : public QObject {
  Q_OBJECT
  QTemporaryDir dir_;
  QString slurmDir_;
  bool slurmStarted_ = false;

  QString path(const QString& name) const { return dir_.filePath(name); }

  // Checks a cohort's report after one run over the manifest: s1 and s2 completed with results
  // for both structures, the two broken subjects failed with exit 3 after two attempts, each
  // message naming its file.
  void checkReport(const QString& cohort) {
    const QJsonObject r = readJson(cohort + "/report/cohort_report.json");
    QCOMPARE(r["subjects"].toInt(), 4);
    QVERIFY(r["collision_shares_learned"].isNull());  // prepared without learning
    QCOMPARE(r["completed"].toInt(), 2);
    QCOMPARE(r["failed"].toInt(), 2);
    const QJsonArray failures = r["failures"].toArray();
    QCOMPARE(failures.size(), 2);
    for (const auto& f : failures) {
      const QJsonObject o = f.toObject();
      QCOMPARE(o["exit_code"].toInt(), 3);
      QCOMPARE(o["attempts"].toInt(), 2);
      const QString expected = o["subject"].toString() == "missing" ? "nowhere.nii.gz" : "truncated.nii.gz";
      QVERIFY2(o["message"].toString().contains(expected), qPrintable(o["message"].toString()));
    }
    // Statistics over the two completed subjects, per structure.
    for (const QString s : {"Putamen_R", "Thalamus_R"}) {
      const QJsonObject assd = r["structures"].toObject()[s].toObject()["assd_final_mm"].toObject();
      QCOMPARE(assd["n"].toInt(), 2);
      QVERIFY2(assd["median"].toDouble() > 0.0 && assd["median"].toDouble() < 1.5, qPrintable(s));
      QVERIFY(assd["min"].toDouble() <= assd["median"].toDouble() && assd["median"].toDouble() <= assd["max"].toDouble());
    }
    const QStringList rows = readText(cohort + "/report/structures.csv").split('\n', Qt::SkipEmptyParts);
    QCOMPARE(rows.size(), 1 + 2 * 2);
    QVERIFY(readText(cohort + "/report/subjects.csv").contains("missing,failed,3,2,"));
    for (const QString png : {"assd_boxplot.png", "dice_boxplot.png", "run_time.png"})
      QVERIFY2(QFileInfo(cohort + "/report/" + png).size() > 1000, qPrintable(png));
  }

private slots:
  void initTestCase() {
    if (!QFile::exists(kTemplates + "ch2.nii.gz")) QSKIP("mricron-data is not installed");
    ToolResult r = runTool(SINEW_BUILD_MODEL, {"--atlas", kTemplates + "aal.nii.gz", "--labels", kTemplates + "aal.nii.txt",
                                               "--training", kTemplates + "ch2better.nii.gz", "--structures",
                                               "Putamen_R,Thalamus_R", "-o", path("model"), "-q"});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    for (const QString seed : {"1", "2"}) {
      r = runTool(SINEW_MAKE_SUBJECT, {"--image", kTemplates + "ch2.nii.gz", "--labels", kTemplates + "aal.nii.gz",
                                       "--seed", seed, "-o", path("subject" + seed)});
      QVERIFY2(r.code == 0, qPrintable(r.err));
    }
    // A truncated image: the gzip stream ends early.
    QFile image(path("subject2/image.nii.gz"));
    QVERIFY(image.open(QIODevice::ReadOnly));
    writeText(path("truncated.nii.gz"), QString());
    QFile truncated(path("truncated.nii.gz"));
    QVERIFY(truncated.open(QIODevice::WriteOnly));
    truncated.write(image.read(image.size() / 3));
    truncated.close();
    writeText(path("cohort.csv"), "subject,target,ground_truth\n"
                                  "s1,subject1/image.nii.gz,subject1/labels.nii.gz\n"
                                  "missing,nowhere.nii.gz,subject1/labels.nii.gz\n"
                                  "s2,\"subject2/image.nii.gz\",subject2/labels.nii.gz\n"
                                  "truncated,truncated.nii.gz,subject2/labels.nii.gz\n");
  }

  void localRunReportsFailuresAndResumes() {
    const QString cohort = path("local");
    ToolResult r = runTool(SINEW_COHORT, {"run", path("cohort.csv"), "--model", path("model"), "-o", cohort, "--cpu-workers", "2"});
    QVERIFY2(r.code == 5, qPrintable(r.err + r.out));  // 5: some subjects failed
    checkReport(cohort);
    QVERIFY(QFile::exists(cohort + "/subjects/s1/out/Putamen_R.vtp"));
    QVERIFY(readText(cohort + "/subjects/missing/run.log").contains("== attempt 2"));

    // Again: the completed subjects are not run again, the failed ones are.
    const QString s1Log = readText(cohort + "/subjects/s1/run.log");
    r = runTool(SINEW_COHORT, {"run", "-o", cohort});
    QCOMPARE(r.code, 5);
    QVERIFY2(r.err.contains("2 of 4 subjects to run (2 already done)"), qPrintable(r.err));
    QCOMPARE(readText(cohort + "/subjects/s1/run.log"), s1Log);
    checkReport(cohort);

    // The missing image appears: the next run completes it, and only it.
    QVERIFY(QFile::copy(path("subject1/image.nii.gz"), path("nowhere.nii.gz")));
    r = runTool(SINEW_COHORT, {"run", "-o", cohort, "--retries", "0"});
    QCOMPARE(r.code, 5);
    const QJsonObject report = readJson(cohort + "/report/cohort_report.json");
    QCOMPARE(report["completed"].toInt(), 3);
    QCOMPARE(report["failed"].toInt(), 1);
    QCOMPARE(report["failures"].toArray()[0].toObject()["subject"].toString(), QString("truncated"));
    QVERIFY(QFile::remove(path("nowhere.nii.gz")));
  }

  // A cohort of six completed subjects (s1's report, its affine stage's Mattes MI set per subject):
  // the one whose registration stands out from the others' is named in the report, its CSV row and
  // the printed summary; in a cohort that spreads widely it is not. Fewer than five registered subjects
  // (the local cohort's three) name none.
  void registrationsThatStandOutAreNamed() {
    const QJsonObject local = readJson(path("local/cohort.json"));
    QVERIFY(!local.isEmpty());
    QCOMPARE(local["subjects"].toArray().size(), 4);
    const QJsonObject localRegistration = readJson(path("local/report/cohort_report.json"))["registration"].toObject();
    QVERIFY(localRegistration["median_mattes_mi"].isNull());
    QVERIFY(localRegistration["outliers"].toArray().isEmpty());

    const QJsonObject s1 = readJson(path("local/subjects/s1/out/report.json"));
    const QJsonArray stages = s1["initialisation"].toObject()["registration"].toArray();
    QVERIFY(std::any_of(stages.begin(), stages.end(), [](const QJsonValue& v) { return v.toObject()["name"] == "affine"; }));
    const auto makeCohort = [&](const QString& name, const QList<double>& metrics) {
      QJsonObject cohort = local;
      QJsonArray subjects;
      for (int i = 0; i < metrics.size(); ++i) {
        const QString id = QString("q%1").arg(i);
        subjects.append(QJsonObject{{"id", id}, {"target", path("subject1/image.nii.gz")}});
        QVERIFY(QDir().mkpath(path(name + "/subjects/" + id + "/out")));
        writeText(path(name + "/subjects/" + id + "/status.json"),
                  R"({"status": "completed", "exit_code": 0, "attempts": 1, "seconds": 1.0, "message": ""})");
        QJsonArray changed;
        for (const QJsonValue& v : stages) {
          QJsonObject stage = v.toObject();
          if (stage["name"] == "affine") stage["mattes_mi"] = metrics[i];
          changed.append(stage);
        }
        QJsonObject report = s1, init = s1["initialisation"].toObject();
        init["registration"] = changed;
        report["initialisation"] = init;
        if (i == 2) {  // one structure where the image does not look as trained
          QJsonArray structures = report["structures"].toArray();
          QJsonObject first = structures[0].toObject();
          first["image_fit"] = 0.2;
          structures[0] = first;
          report["structures"] = structures;
        }
        writeText(path(name + "/subjects/" + id + "/out/report.json"), QJsonDocument(report).toJson());
      }
      cohort["subjects"] = subjects;
      writeText(path(name + "/cohort.json"), QJsonDocument(cohort).toJson());
    };

    makeCohort("qc", {-0.72, -0.70, -0.74, -0.71, -0.73, -0.35});
    ToolResult r = runTool(SINEW_COHORT, {"report", path("qc")});
    QVERIFY2(r.code == 0, qPrintable(r.err + r.out));
    QJsonObject registration = readJson(path("qc/report/cohort_report.json"))["registration"].toObject();
    QCOMPARE(registration["median_mattes_mi"].toDouble(), -0.715);
    const QJsonArray outliers = registration["outliers"].toArray();
    QCOMPARE(outliers.size(), 1);
    QCOMPARE(outliers[0].toObject()["subject"].toString(), QString("q5"));
    QVERIFY2(r.out.contains("q5: its registration stands out (Mattes MI -0.350"), qPrintable(r.out));
    const QStringList rows = readText(path("qc/report/subjects.csv")).split('\n', Qt::SkipEmptyParts);
    QVERIFY2(rows[0].contains("registration_mattes_mi,registration_outlier,outside_image_share,lowest_image_fit"), qPrintable(rows[0]));
    for (const QString& row : rows.mid(1))
      QVERIFY2(row.contains(",-0.35,yes,") == row.startsWith("q5,"), qPrintable(row));
    // A structure's image fit below kPoorImageFit names the subject and the structure; the real
    // run's structures (every other subject's) fit.
    const QString firstStructure = s1["structures"].toArray()[0].toObject()["name"].toString();
    const QJsonArray poor = readJson(path("qc/report/cohort_report.json"))["poor_image_fit"].toObject()["subjects"].toArray();
    QCOMPARE(poor.size(), 1);
    QCOMPARE(poor[0].toObject()["subject"].toString(), QString("q2"));
    QCOMPARE(poor[0].toObject()["structure"].toString(), firstStructure);
    QVERIFY2(r.out.contains("q2: " + firstStructure + "'s image fit is 0.20"), qPrintable(r.out));
    QVERIFY2(!r.out.contains("q1: "), qPrintable(r.out));

    // The same value in a cohort that spreads widely: 5 robust standard deviations (1.11 here) above
    // the median, not the margin of 0.1 alone, set the limit.
    makeCohort("qc-spread", {-0.9, -0.7, -0.5, -0.8, -0.6, -0.35});
    r = runTool(SINEW_COHORT, {"report", path("qc-spread")});
    QVERIFY2(r.code == 0, qPrintable(r.err + r.out));
    registration = readJson(path("qc-spread/report/cohort_report.json"))["registration"].toObject();
    QVERIFY2(registration["outliers"].toArray().isEmpty(), qPrintable(QJsonDocument(registration).toJson()));
    QVERIFY(!r.out.contains("stands out"));
  }

  // --learn-collision-shares 1: the first labelled subject runs once more without collisions (in
  // learning/), and every subject's scene, labelled or not, gets the shares learned from it. Run
  // again, nothing runs. Refused: a manifest without a ground truth, a template without collisions.
  void learnsCollisionSharesFromItsLabelledSubjects() {
    ToolResult r = runTool(SINEW_BUILD_MODEL, {"--atlas", kTemplates + "aal.nii.gz", "--labels", kTemplates + "aal.nii.txt",
                                               "--training", kTemplates + "ch2better.nii.gz", "--structures",
                                               "Pallidum_R,Putamen_R", "-o", path("touching"), "-q"});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    writeText(path("learn.csv"), "subject,target,ground_truth\n"
                                 "u,subject2/image.nii.gz,\n"
                                 "s1,subject1/image.nii.gz,subject1/labels.nii.gz\n"
                                 "s2,subject2/image.nii.gz,subject2/labels.nii.gz\n");
    const QString cohort = path("learn");
    const QStringList args = {"run", path("learn.csv"), "--model", path("touching"), "-o", cohort, "--cpu-workers", "2",
                              "--learn-collision-shares", "1", "--collision-shares-min-contacts", "10"};
    r = runTool(SINEW_COHORT, args);
    QVERIFY2(r.code == 0, qPrintable(r.err + r.out));
    QVERIFY2(r.err.contains("learning the collision's shares from 1 labelled subject(s)"), qPrintable(r.err));
    const QJsonObject learned = readJson(cohort + "/learning/shares.json");
    QCOMPARE(learned["from"].toArray(), QJsonArray({"s1"}));
    const QJsonArray shares = learned["collision_shares"].toArray();
    QCOMPARE(shares.size(), 1);  // the two touch in every segmentation
    const QJsonArray pair = shares[0].toObject()["pair"].toArray(), share = shares[0].toObject()["shares"].toArray();
    QCOMPARE(QSet<QString>({pair[0].toString(), pair[1].toString()}), QSet<QString>({"Pallidum_R", "Putamen_R"}));
    QVERIFY(share[0].toDouble() >= 0.0 && share[1].toDouble() >= 0.0);
    QCOMPARE(std::max(share[0].toDouble(), share[1].toDouble()), 1.0);  // the side that reached over more takes all
    QVERIFY(!QDir(cohort + "/learning/subjects/u").exists() && !QDir(cohort + "/learning/subjects/s2").exists());
    // The learning run collided nowhere; every subject of the cohort has the shares.
    const QJsonObject learningScene = readJson(cohort + "/learning/subjects/s1/scene.json");
    QCOMPARE(learningScene["forces"].toObject()["collision"].toObject()["weight"].toDouble(), 0.0);
    for (const auto& level : learningScene["schedule"].toArray())
      QCOMPARE(level.toObject()["forces"].toObject()["collision"].toObject()["weight"].toDouble(0.0), 0.0);
    QVERIFY(QFile::exists(cohort + "/learning/subjects/s1/out/report.json"));
    for (const QString id : {"u", "s1", "s2"}) {
      QCOMPARE(readJson(cohort + "/subjects/" + id + "/scene.json")["collision_shares"].toArray(), shares);
      QVERIFY(QFile::exists(cohort + "/subjects/" + id + "/out/report.json"));
    }
    // The report says where the shares came from.
    const QJsonObject reported = readJson(cohort + "/report/cohort_report.json")["collision_shares_learned"].toObject();
    QCOMPARE(reported["from"].toArray(), QJsonArray({"s1"}));
    QCOMPARE(reported["pairs"].toInt(), 1);
    QVERIFY2(r.out.contains("collision shares by pair: 1 pair(s) learned from s1"), qPrintable(r.out));

    const QString logs = readText(cohort + "/learning/subjects/s1/run.log") + readText(cohort + "/subjects/u/run.log");
    r = runTool(SINEW_COHORT, args);
    QCOMPARE(r.code, 0);
    QVERIFY2(r.err.contains("0 of 1 subjects to run (1 already done)") && r.err.contains("0 of 3 subjects to run (3 already done)"),
             qPrintable(r.err));
    QCOMPARE(readText(cohort + "/learning/subjects/s1/run.log") + readText(cohort + "/subjects/u/run.log"), logs);

    writeText(path("unlabelled.csv"), "subject,target\nu,subject2/image.nii.gz\n");
    r = runTool(SINEW_COHORT, {"run", path("unlabelled.csv"), "--model", path("touching"), "-o", path("unlabelled"),
                               "--learn-collision-shares", "1"});
    QCOMPARE(r.code, 3);
    QVERIFY2(r.err.contains(path("unlabelled.csv")) && r.err.contains("no subject has a ground_truth"), qPrintable(r.err));
    QJsonObject scene = readJson(cohort + "/template.json");
    QJsonArray schedule = scene["schedule"].toArray();
    for (int i = 0; i < schedule.size(); ++i) {
      QJsonObject level = schedule[i].toObject(), forces = level["forces"].toObject();
      forces.remove("collision");
      level["forces"] = forces;
      schedule[i] = level;
    }
    scene["schedule"] = schedule;
    writeText(path("no-collisions.json"), QString::fromUtf8(QJsonDocument(scene).toJson()));
    r = runTool(SINEW_COHORT, {"run", path("learn.csv"), "--template", path("no-collisions.json"), "-o", path("refused"),
                               "--learn-collision-shares", "1"});
    QCOMPARE(r.code, 3);
    QVERIFY2(r.err.contains(path("no-collisions.json")) && r.err.contains("no collisions to share"), qPrintable(r.err));
  }

  void aSecondRunOnTheFolderIsRefused() {
    writeText(path("one.csv"), "subject,target\ns1,subject1/image.nii.gz\n");
    QProcess first;
    first.start(SINEW_COHORT, {"run", path("one.csv"), "--model", path("model"), "-o", path("locked"), "-q"});
    QVERIFY(first.waitForStarted());
    for (int i = 0; i < 200 && !QFile::exists(path("locked/subjects/s1/run.log")); ++i) QThread::msleep(50);
    const ToolResult second = runTool(SINEW_COHORT, {"run", "-o", path("locked")});
    QCOMPARE(second.code, 3);
    QVERIFY2(second.err.contains("another sinew-cohort run (process") && second.err.contains("is running this cohort"),
             qPrintable(second.err));
    QVERIFY(first.waitForFinished(300000));
    QCOMPARE(first.exitCode(), 0);
  }

  void badManifestsAreRefused() {
    const QList<QPair<QString, QString>> cases = {
        {"subject,target\na,x.nii.gz\na,y.nii.gz\n", "subject id 'a' appears twice"},
        {"subject,target\n../a,x.nii.gz\n", "subject id '../a'"},
        {"subject,image\na,x.nii.gz\n", "unknown column 'image'"},
        {"subject,target\na,x.nii.gz,extra\n", "line 2: 3 fields"},
        {"subject,target\n", "no subjects"},
    };
    for (const auto& [text, expected] : cases) {
      writeText(path("bad.csv"), text);
      const ToolResult r = runTool(SINEW_COHORT, {"run", path("bad.csv"), "--model", path("model"), "-o", path("bad")});
      QCOMPARE(r.code, 3);
      QVERIFY2(r.err.contains(path("bad.csv")) && r.err.contains(expected), qPrintable(r.err));
    }
    const ToolResult r = runTool(SINEW_COHORT, {"report", path("nothing")});
    QCOMPARE(r.code, 3);
    QVERIFY2(r.err.contains("not a cohort folder"), qPrintable(r.err));
  }

  void slurmScriptsHoldOnlyWhatIsMissing() {
    // The local cohort has s1, s2 and 'missing' done; only 'truncated' (index 3) is left.
    const ToolResult r = runTool(SINEW_COHORT, {"slurm", "-o", path("local"), "--no-submit", "--throttle", "3",
                                                "--gpus-per-task", "1", "--sbatch-option", "--qos=short"});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    const QString script = readText(path("local/slurm/array.sbatch"));
    QVERIFY2(script.contains("#SBATCH --array=3%3\n") && script.contains("#SBATCH --gres=gpu:1\n") &&
                 script.contains("#SBATCH --qos=short\n") && script.contains(" task '" + path("local") + "' --subject") && script.contains("subjects=('s1' 'missing' 's2' 'truncated')"),
             qPrintable(script));
  }

  // On Slurm without submitting: the learning subject's array and the follow-up job that runs the
  // same command again after it; nothing of the cohort's own yet.
  void slurmLearnsSharesFirst() {
    const QString cohort = path("slurm-learn-scripts");
    const ToolResult r = runTool(SINEW_COHORT, {"slurm", path("learn.csv"), "--model", path("touching"), "-o", cohort,
                                                "--learn-collision-shares", "1", "--no-submit"});
    QVERIFY2(r.code == 0, qPrintable(r.err + r.out));
    QVERIFY2(r.out.contains("1 of 1 labelled subjects to run"), qPrintable(r.out));
    QVERIFY(readText(cohort + "/learning/slurm/array.sbatch").contains("subjects=('s1')\n"));
    const QString followUp = readText(cohort + "/learning/slurm/follow-up.sbatch");
    QVERIFY2(followUp.contains("cd '" + QDir::currentPath() + "' || exit 1\n") && followUp.contains(" 'slurm' '" + path("learn.csv") + "'") &&
                 followUp.contains(" '--learn-collision-shares' '1' '--no-submit' '--after-learning'\n"),
             qPrintable(followUp));
    QVERIFY(!QFile::exists(cohort + "/slurm/array.sbatch") && !QFile::exists(cohort + "/cohort.json"));
  }

  void slurmJobArray() {
    const ToolResult start = runTool("bash", {SLURM_LOCAL, "start", path("slurm-daemons")});
    if (start.code == 77) QSKIP(qPrintable("no local Slurm: " + start.err.trimmed()));
    QVERIFY2(start.code == 0, qPrintable(start.err));
    slurmStarted_ = true;
    slurmDir_ = path("slurm-daemons");
    qputenv("SLURM_CONF", QFile::encodeName(slurmDir_ + "/slurm.conf"));

    const QString cohort = path("on-slurm");
    ToolResult r = runTool(SINEW_COHORT, {"slurm", path("cohort.csv"), "--model", path("model"), "-o", cohort,
                                          "--throttle", "2", "--cpus-per-task", "1", "--mem", "500M", "--time", "00:20:00",
                                          "--backend", "cpu"});
    QVERIFY2(r.code == 0, qPrintable(r.err + r.out));
    QVERIFY2(r.out.contains("submitted array job") && r.out.contains("submitted report job"), qPrintable(r.out));
    // The report job runs after every task, however they ended.
    const QString done = cohort + "/report/cohort_report.json";
    for (int i = 0; i < 600 && !QFile::exists(done); ++i) QThread::msleep(500);
    QVERIFY2(QFile::exists(done), qPrintable("no report after 300 s; logs in " + cohort + "/slurm/logs"));
    checkReport(cohort);
    // One log per array task, and the task of a broken subject said why it failed.
    const QStringList logs = QDir(cohort + "/slurm/logs").entryList({"task-*.log"});
    QCOMPARE(logs.size(), 4);
    bool named = false;
    for (const QString& l : logs) named = named || readText(cohort + "/slurm/logs/" + l).contains("subject missing: failed");
    QVERIFY(named);

    // Shares learned first: the learning array, its follow-up job (which learns, then submits the
    // cohort's array and report), the cohort's scenes with the shares.
    const QString learn = path("slurm-learn");
    r = runTool(SINEW_COHORT, {"slurm", path("learn.csv"), "--model", path("touching"), "-o", learn, "--learn-collision-shares", "1",
                               "--collision-shares-min-contacts", "10", "--cpus-per-task", "1", "--mem", "500M", "--backend", "cpu"});
    QVERIFY2(r.code == 0 && r.out.contains("submitted follow-up job"), qPrintable(r.err + r.out));
    const QString learnDone = learn + "/report/cohort_report.json";
    for (int i = 0; i < 600 && !QFile::exists(learnDone); ++i) QThread::msleep(500);
    QVERIFY2(QFile::exists(learnDone), qPrintable("no report after 300 s; logs in " + learn + "/learning/slurm/logs"));
    QCOMPARE(readJson(learnDone)["completed"].toInt(), 3);
    const QJsonArray shares = readJson(learn + "/learning/shares.json")["collision_shares"].toArray();
    QCOMPARE(shares.size(), 1);
    QCOMPARE(shares, readJson(path("learn/learning/shares.json"))["collision_shares"].toArray());  // as learned locally
    for (const QString id : {"u", "s1", "s2"})
      QCOMPARE(readJson(learn + "/subjects/" + id + "/scene.json")["collision_shares"].toArray(), shares);
  }

  void cleanupTestCase() {
    if (slurmStarted_) runTool("bash", {SLURM_LOCAL, "stop", slurmDir_});
  }
};

QTEST_GUILESS_MAIN(TestCohort)
#include "tst_cohort.moc"
