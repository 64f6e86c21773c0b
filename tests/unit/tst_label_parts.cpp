// Labels in parts on both sides (a parcel of both hemispheres, as in Harvard-Oxford's cortical
// atlas): split by side into two structures by sinew-make-scene --split-parts (atlas scenes) and by
// sinew-build-model --split-parts (models), a subject's ground truth split alike by sinew-make-scene
// and by sinew-cohort, each side scored against its own side.
#include "synthetic.h"
#include "sinew/core/registry.h"
// After the engine headers: a Qt macro (emit) breaks TBB headers included after it.
#include "run_tool.h"
#include "scene_json.h"

#include <QDir>
#include <QFile>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QTemporaryDir>
#include <QtTest>

#include <algorithm>

using namespace sinew;
using namespace sinew::testing;
namespace fs = std::filesystem;

namespace {

const QString kTemplates = "/usr/share/mricron/templates/";
const QString kHarvardOxford = kTemplates + "HarvardOxford-cort-maxprob-thr0-1mm.nii.gz";

using Result = ToolResult;

LabelVolume readLabels(const QString& file) { return builtinRegistry().imageIOFor(file.toStdString()).readLabels(file.toStdString()); }

// The two sides of a split truth: both there, the left one at larger world x (LPS), 20 mm or more
// off the midline on either side (Harvard-Oxford's insular cortex).
void checkSides(const QString& file, int left, int right) {
  const LabelVolume truth = readLabels(file);
  const ImageGeometry& g = truth.geometry();
  std::size_t voxels[2] = {0, 0};
  double sideX[2] = {0, 0};
  for (std::size_t i = 0; i < truth.voxels().size(); ++i) {
    const int v = truth.voxels()[i];
    if (v != left && v != right) continue;
    const Vec3 index(float(i % g.size[0]), float((i / g.size[0]) % g.size[1]), float(i / (std::size_t(g.size[0]) * g.size[1])));
    ++voxels[v == left ? 0 : 1];
    sideX[v == left ? 0 : 1] += truth.indexToWorld(index).x();
  }
  QVERIFY2(voxels[0] > 8000 && voxels[1] > 8000, qPrintable(QString("%1 %2").arg(voxels[0]).arg(voxels[1])));
  QVERIFY2(sideX[0] / voxels[0] > 20 && sideX[1] / voxels[1] < -20,
           qPrintable(QString("%1 %2").arg(sideX[0] / voxels[0]).arg(sideX[1] / voxels[1])));
}

// Each side scored against its own side: Dice above 0.8 for results [begin, end) (a model of one
// side scores about 0.6 against the whole label). The values are logged to show the margin.
void checkDice(const QJsonArray& results, int begin, int end) {
  for (int i = begin; i < end; ++i) {
    const QJsonObject s = results[i].toObject();
    qInfo("%s: Dice %.3f", qPrintable(s["name"].toString()), s["dice"].toDouble());
    QVERIFY2(s["dice"].toDouble() > 0.8, qPrintable(QString::number(s["dice"].toDouble())));
  }
}

}  // namespace

class TestLabelParts : public QObject {
  Q_OBJECT
  QTemporaryDir dir_;
  QString model_, subject_;

  QString path(const QString& name) const { return dir_.filePath(name); }

private slots:
  void initTestCase() {
    if (!QFile::exists(kHarvardOxford)) QSKIP("this mricron-data has no Harvard-Oxford atlas");
    // The frontal pole (label 1, one part across the midline) and the insular cortex (label 2, one
    // part in each hemisphere), at two levels to keep the test short.
    model_ = path("model");
    subject_ = path("subject");
    Result r = runTool(SINEW_BUILD_MODEL, {"--atlas", kHarvardOxford, "--training", kTemplates + "ch2better.nii.gz", "--structures",
                                           "1,2", "--levels", "2", "--split-parts", "-o", model_});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    QVERIFY2(r.err.contains("label 2 is in parts on both sides"), qPrintable(r.err));
    r = runTool(SINEW_MAKE_SUBJECT, {"--image", kTemplates + "ch2.nii.gz", "--labels", kHarvardOxford, "--seed", "17", "-o", subject_});
    QVERIFY2(r.code == 0, qPrintable(r.err));
  }

  void splitsALabelInParts() {
    // A model's structures are built already: nothing to split.
    Result r = runTool(SINEW_MAKE_SCENE, {"--model", model_, "--target", kTemplates + "ch2.nii.gz", "--split-parts", "-o",
                                          path("refused-split.json")});
    QCOMPARE(r.code, 3);
    QVERIFY2(r.err.contains("--split-parts goes with --atlas"), qPrintable(r.err));
    QVERIFY(!QFile::exists(path("refused-split.json")));

    const QString ho = kHarvardOxford;
    r = runTool(SINEW_MAKE_SCENE, {"--atlas", ho, "--training", kTemplates + "ch2better.nii.gz", "--target",
                                          kTemplates + "ch2.nii.gz", "--structures", "1,2", "--split-parts", "--iterations",
                                          "20,10,5", "-o", path("split.json")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    QVERIFY2(r.err.contains("label 2 is in parts on both sides"), qPrintable(r.err));
    const QJsonArray structures = readJson(path("split.json"))["structures"].toArray();
    QCOMPARE(structures.size(), 3);  // label 1 (the frontal pole) is one part across the midline
    QCOMPARE(structures[0].toObject()["name"].toString(), QString("label_1"));
    QCOMPARE(structures[1].toObject()["name"].toString(), QString("label_2_L"));
    QCOMPARE(structures[2].toObject()["name"].toString(), QString("label_2_R"));
    const int left = structures[1].toObject()["reference"].toObject()["label"].toInt();
    const int right = structures[2].toObject()["reference"].toObject()["label"].toInt();
    QVERIFY(left != right && left != 2 && right != 2);
    for (int i = 1; i < 3; ++i)  // the atlas is the truth: scored against the same side
      QCOMPARE(structures[i].toObject()["ground_truth"].toObject()["label"].toInt(), i == 1 ? left : right);
    QCOMPARE(structures[1].toObject()["label"].toInt(), 2);  // the output's value
    // The split map: label 2's voxels and no other changed, each side in its own hemisphere by
    // AAL's Insula_L (29) and Insula_R (30), looked up at the same world points.
    const fs::path parts = path("split.atlas-parts.nii.gz").toStdString();
    QCOMPARE(structures[0].toObject()["reference"].toObject()["label_map"].toString(), QString::fromStdString(parts.string()));
    const auto read = [&](const fs::path& file) { return readLabels(QString::fromStdString(file.string())); };
    const LabelVolume before = read(ho.toStdString()), after = read(parts), aal = read((kTemplates + "aal.nii.gz").toStdString());
    QCOMPARE(after.voxels().size(), before.voxels().size());
    const auto aalAt = [&](const Vec3& world) {
      const Vec3 k = aal.worldToIndex(world);
      const ImageGeometry& g = aal.geometry();
      const int x = int(std::lround(k.x())), y = int(std::lround(k.y())), z = int(std::lround(k.z()));
      if (x < 0 || y < 0 || z < 0 || x >= g.size[0] || y >= g.size[1] || z >= g.size[2]) return 0;
      return aal.voxels()[(std::size_t(z) * g.size[1] + y) * g.size[0] + x];
    };
    std::size_t voxels[2] = {0, 0}, changed = 0, inInsula[2][2] = {{0, 0}, {0, 0}};  // [side][Insula_L, Insula_R]
    const ImageGeometry& g = before.geometry();
    for (std::size_t i = 0; i < before.voxels().size(); ++i) {
      const int b = before.voxels()[i], a = after.voxels()[i];
      QVERIFY(b != left && b != right);  // new values, no label's before
      if (b != 2) {
        changed += a != b;
        continue;
      }
      QVERIFY(a == left || a == right);
      const int side = a == left ? 0 : 1;
      ++voxels[side];
      const Vec3 index(float(i % g.size[0]), float((i / g.size[0]) % g.size[1]), float(i / (std::size_t(g.size[0]) * g.size[1])));
      const int atlasLabel = aalAt(before.indexToWorld(index));
      inInsula[side][0] += atlasLabel == 29, inInsula[side][1] += atlasLabel == 30;
    }
    QCOMPARE(changed, std::size_t(0));
    QVERIFY2(voxels[0] > 12000 && voxels[1] > 12000, qPrintable(QString("%1 %2").arg(voxels[0]).arg(voxels[1])));
    QVERIFY2(inInsula[0][0] > 1000 && inInsula[0][1] == 0 && inInsula[1][1] > 1000 && inInsula[1][0] == 0,
             qPrintable(QString("%1 %2 %3 %4").arg(inInsula[0][0]).arg(inInsula[0][1]).arg(inInsula[1][0]).arg(inInsula[1][1])));

    r = runTool(SINEW_RUN, {path("split.json"), "-o", path("split"), "-q", "--backend", "cpu"});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    QVERIFY2(!r.err.contains("in parts apart"), qPrintable(r.err));  // each side's model is its whole part
    const QJsonArray results = readJson(path("split/report.json"))["structures"].toArray();
    QCOMPARE(results.size(), 3);
    // Each side scored against its own part (the unsplit label's model is one side, Dice 0.57
    // against the whole label on this scene).
    checkDice(results, 1, 3);
    const LabelVolume out = read(path("split/segmentation.nii.gz").toStdString());
    std::size_t two = 0, split = 0;
    for (const int v : out.voxels()) two += v == 2, split += v == left || v == right;
    QVERIFY(two > 20000);
    QCOMPARE(split, std::size_t(0));

    // A new subject's own labels split alike, each side at its world side.
    r = runTool(SINEW_MAKE_SCENE, {"--subject", "--atlas", ho, "--training", kTemplates + "ch2better.nii.gz", "--target",
                                   subject_ + "/image.nii.gz", "--ground-truth", subject_ + "/labels.nii.gz",
                                   "--structures", "2", "--split-parts", "-o", path("split-subject.json")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    const QJsonArray subjectParts = readJson(path("split-subject.json"))["structures"].toArray();
    QCOMPARE(subjectParts.size(), 2);
    for (int side = 0; side < 2; ++side)
      QCOMPARE(subjectParts[side].toObject()["ground_truth"].toObject()["label_map"].toString(),
               path("split-subject.truth-parts.nii.gz"));
    checkSides(path("split-subject.truth-parts.nii.gz"), subjectParts[0].toObject()["ground_truth"].toObject()["label"].toInt(),
               subjectParts[1].toObject()["ground_truth"].toObject()["label"].toInt());

    // A truth whose labels take the values the atlas's sides took: the truth's sides take values of
    // their own, above all of its labels.
    LabelVolume clash = read((subject_ + "/labels.nii.gz").toStdString());
    *std::find(clash.voxels().begin(), clash.voxels().end(), 1) = left;
    *std::find(clash.voxels().begin(), clash.voxels().end(), 1) = right;
    builtinRegistry().imageIOFor("clash.nii.gz").writeLabels(path("clash.nii.gz").toStdString(), clash);
    r = runTool(SINEW_MAKE_SCENE, {"--subject", "--atlas", ho, "--training", kTemplates + "ch2better.nii.gz", "--target",
                                   subject_ + "/image.nii.gz", "--ground-truth", path("clash.nii.gz"), "--structures",
                                   "2", "--split-parts", "-o", path("clash/scene.json")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    const QJsonArray clashParts = readJson(path("clash/scene.json"))["structures"].toArray();
    const int clashLeft = clashParts[0].toObject()["ground_truth"].toObject()["label"].toInt();
    const int clashRight = clashParts[1].toObject()["ground_truth"].toObject()["label"].toInt();
    QVERIFY2(clashLeft > std::max(left, right) && clashRight > std::max(left, right),
             qPrintable(QString("%1 %2").arg(clashLeft).arg(clashRight)));
    checkSides(path("clash/scene.truth-parts.nii.gz"), clashLeft, clashRight);

    // A head turned by up to 60 degrees: its labels split as the upright atlas's. Label 8 lies far
    // back; a plane along world x through the brain's centre put both its sides on one side.
    r = runTool(SINEW_MAKE_SUBJECT, {"--image", kTemplates + "ch2.nii.gz", "--labels", ho, "--seed", "41", "--max-rotation-deg",
                                     "60", "-o", path("turned")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    r = runTool(SINEW_MAKE_SCENE, {"--subject", "--atlas", ho, "--training", kTemplates + "ch2better.nii.gz", "--target",
                                   path("turned/image.nii.gz"), "--ground-truth", path("turned/labels.nii.gz"), "--structures",
                                   "2,8", "--split-parts", "-o", path("turned/scene.json")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    QCOMPARE(readJson(path("turned/scene.json"))["structures"].toArray().size(), 4);

    // A ground truth whose label is whole cannot be split as the atlas was: refused, nothing written.
    r = runTool(SINEW_MAKE_SCENE, {"--subject", "--atlas", ho, "--training", kTemplates + "ch2better.nii.gz", "--target",
                                   kTemplates + "ch2.nii.gz", "--ground-truth", kTemplates + "aal.nii.gz", "--structures", "2",
                                   "--split-parts", "-o", path("refused-truth/scene.json")});
    QCOMPARE(r.code, 3);
    QVERIFY2(r.err.contains("aal.nii.gz: label 2 is not in parts on both sides here"), qPrintable(r.err));
    QVERIFY(QDir(path("refused-truth")).entryList(QDir::Files | QDir::Hidden).isEmpty());

  }

  void modelOfSides() {
    // The model: label 1 whole, label 2 as its two sides, both keeping label 2 for the output.
    const QJsonArray built = readJson(model_ + "/model.json")["structures"].toArray();
    QCOMPARE(built.size(), 3);
    const char* names[] = {"label_1", "label_2_L", "label_2_R"};
    const char* sides[] = {"", "left", "right"};
    for (int i = 0; i < 3; ++i) {
      const QJsonObject s = built[i].toObject();
      QCOMPARE(s["name"].toString(), QString(names[i]));
      QCOMPARE(s["label"].toInt(), i == 0 ? 1 : 2);
      QCOMPARE(s["side"].toString(), QString(sides[i]));
    }
    // A scene of the model on the subject: the label's name takes both sides (a side named again
    // is taken once), the truth split beside the scene, each side scored against its own.
    Result r = runTool(SINEW_MAKE_SCENE, {"--model", model_, "--target", subject_ + "/image.nii.gz", "--ground-truth",
                                          subject_ + "/labels.nii.gz", "--structures", "label_2,label_2_L", "--iterations", "20,10", "-o",
                                          path("sides/scene.json")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    const QJsonArray structures = readJson(path("sides/scene.json"))["structures"].toArray();
    QCOMPARE(structures.size(), 2);
    int value[2];
    for (int i = 0; i < 2; ++i) {
      const QJsonObject s = structures[i].toObject(), truth = s["ground_truth"].toObject();
      QCOMPARE(s["name"].toString(), QString(names[i + 1]));
      QCOMPARE(s["label"].toInt(), 2);
      QCOMPARE(truth["label_map"].toString(), path("sides/scene.truth-parts.nii.gz"));
      value[i] = truth["label"].toInt();
    }
    QVERIFY(value[0] != value[1] && value[0] != 2 && value[1] != 2);
    checkSides(path("sides/scene.truth-parts.nii.gz"), value[0], value[1]);
    r = runTool(SINEW_RUN, {path("sides/scene.json"), "-o", path("sides/out"), "-q", "--backend", "cpu"});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    // Each side against its own side (the whole label's model scores about 0.6 against both).
    const QJsonArray results = readJson(path("sides/out/report.json"))["structures"].toArray();
    QCOMPARE(results.size(), 2);
    checkDice(results, 0, 2);

    // The same scene scored against the truth whole (as written by hand): sinew-run says so.
    QJsonObject whole = readJson(path("sides/scene.json"));
    QJsonArray wholeStructures = whole["structures"].toArray();
    for (int i = 0; i < 2; ++i) {
      QJsonObject s = wholeStructures[i].toObject();
      s["ground_truth"] = QJsonObject{{"label_map", subject_ + "/labels.nii.gz"}, {"label", 2}};
      wholeStructures[i] = s;
    }
    whole["structures"] = wholeStructures;
    withoutIterations(whole);
    writeJson(path("whole.json"), whole);
    r = runTool(SINEW_RUN, {path("whole.json"), "-o", path("whole"), "--backend", "cpu"});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    QVERIFY2(r.err.contains("note: structure 'label_2_L' is the left side of label 2 (sinew-build-model --split-parts), but its "
                            "ground truth is that label whole"),
             qPrintable(r.err));
    QVERIFY(r.err.contains("note: structure 'label_2_R' is the right side of label 2"));

    // One side by its name, the whole label by its own, both sides by the label's value.
    r = runTool(SINEW_MAKE_SCENE, {"--model", model_, "--target", subject_ + "/image.nii.gz", "--structures", "label_1,label_2_R",
                                   "-o", path("one-side.json")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    const QJsonArray oneSide = readJson(path("one-side.json"))["structures"].toArray();
    QCOMPARE(oneSide.size(), 2);
    QCOMPARE(oneSide[1].toObject()["name"].toString(), QString("label_2_R"));
    r = runTool(SINEW_MAKE_SCENE, {"--model", model_, "--target", subject_ + "/image.nii.gz", "--structures", "2", "-o",
                                   path("by-value.json")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    QCOMPARE(readJson(path("by-value.json"))["structures"].toArray().size(), 2);

    // A truth whose label is whole (AAL's label 2, Precentral_R) cannot be split alike: refused, nothing written.
    r = runTool(SINEW_MAKE_SCENE, {"--model", model_, "--target", subject_ + "/image.nii.gz", "--ground-truth",
                                   kTemplates + "aal.nii.gz", "-o", path("refused/scene.json")});
    QCOMPARE(r.code, 3);
    QVERIFY2(r.err.contains("aal.nii.gz: label 2 is not in parts on both sides here, as it is in the model"), qPrintable(r.err));
    QVERIFY(QDir(path("refused")).entryList(QDir::Files | QDir::Hidden).isEmpty());
  }

  void cohortOfSides() {
    // A cohort on the model: each subject's truth split alike in its own folder. Subject b's truth
    // has the label whole: it fails with the reason, the other runs.
    // The template made with a subject's truth: its sides' truth labels are that subject's values,
    // and each subject's split must not take them.
    Result r = runTool(SINEW_MAKE_SCENE, {"--model", model_, "--target", subject_ + "/image.nii.gz", "--ground-truth",
                                          subject_ + "/labels.nii.gz", "--iterations", "20,10", "-o", path("template.json")});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    QFile manifest(path("cohort.csv"));
    QVERIFY(manifest.open(QIODevice::WriteOnly));
    manifest.write(QString("subject,target,ground_truth\na,%1/image.nii.gz,%1/labels.nii.gz\nb,%1/image.nii.gz,%2aal.nii.gz\n")
                       .arg(subject_, kTemplates).toUtf8());
    manifest.close();
    r = runTool(SINEW_COHORT, {"run", path("cohort.csv"), "--template", path("template.json"), "-o", path("cohort"), "-j", "1"});
    QCOMPARE(r.code, 5);  // some failed
    const QString a = path("cohort/subjects/a/");
    const QJsonArray structures = readJson(a + "scene.json")["structures"].toArray();
    QCOMPARE(structures.size(), 3);
    for (int i = 0; i < 3; ++i)
      QCOMPARE(structures[i].toObject()["ground_truth"].toObject()["label_map"].toString(), a + "truth-parts.nii.gz");
    const int left = structures[1].toObject()["ground_truth"].toObject()["label"].toInt();
    const int right = structures[2].toObject()["ground_truth"].toObject()["label"].toInt();
    QCOMPARE(structures[0].toObject()["ground_truth"].toObject()["label"].toInt(), 1);
    checkSides(a + "truth-parts.nii.gz", left, right);
    const QJsonArray results = readJson(a + "out/report.json")["structures"].toArray();
    QCOMPARE(results.size(), 3);
    checkDice(results, 1, 3);
    const QJsonObject failed = readJson(path("cohort/subjects/b/status.json"));
    QCOMPARE(failed["status"].toString(), QString("failed"));
    QVERIFY2(failed["message"].toString().contains("aal.nii.gz: label 2 is not in parts on both sides here"),
             qPrintable(failed["message"].toString()));
    QVERIFY(!QFile::exists(path("cohort/subjects/b/truth-parts.nii.gz")));
    // Run again with a's split truth gone: a is done, its scene unchanged, and the split written again.
    QVERIFY(QFile::remove(a + "truth-parts.nii.gz"));
    r = runTool(SINEW_COHORT, {"run", path("cohort.csv"), "--template", path("template.json"), "-o", path("cohort"), "-j", "1"});
    QCOMPARE(r.code, 5);
    QVERIFY(QFile::exists(a + "truth-parts.nii.gz"));
    QCOMPARE(readJson(a + "status.json")["status"].toString(), QString("completed"));
  }
};

QTEST_GUILESS_MAIN(TestLabelParts)
#include "tst_label_parts.moc"
