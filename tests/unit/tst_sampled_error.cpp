// The timeline's sampled error (sampled_error.h) against the exact evaluation, its oracle, on the
// Colin27 demo: at every report sample of a three-level run, per structure.
#include "sinew/core/sampled_error.h"
#include "sinew/core/scene.h"
#include "sinew/core/scene_runner.h"
#include "sinew/core/simulation.h"

#include "run_tool.h"
#include "synthetic.h"

#include <QFile>
#include <QTemporaryDir>
#include <QtTest>

#include <cmath>
#include <random>

using namespace sinew;

class TestSampledError : public QObject {
  Q_OBJECT
  QTemporaryDir dir_;

private slots:
  // The summary on cases with a known answer: every distance 0.5 mm in both directions (as for
  // concentric spheres 0.5 mm apart), so ASSD = HD95 = 0.5.
  void binnedSummaryOfConstantDistances() {
    std::vector<WeightedDistance> a(100, {0.5f, 0.3f}), b(50, {0.5f, 0.7f});
    const SurfaceDistanceStats s = summariseBinned(a, b, SampledError::kBinMm);
    QVERIFY(std::abs(s.assd - 0.5) < 1e-6);
    QVERIFY(std::abs(s.hd95 - 0.5) <= SampledError::kBinMm);
    // The 95th percentile by area, not by count: 96 % of the area at 0.1, the rest at 2.
    std::vector<WeightedDistance> c{{0.1f, 96.0f}, {2.0f, 4.0f}};
    QVERIFY(std::abs(summariseBinned(c, {}, SampledError::kBinMm).hd95 - 0.1) <= SampledError::kBinMm);
  }

  // The truth-to-mesh direction's first-order distances (trianglebvh::planeDistance): exact on a
  // flat surface, on either side of it and from a patch centre on it; on a sphere, within the stated
  // |s - c|^2 / 2R (R the radius of the distance's level set, plus the facets' sagitta) of the exact
  // distance.
  void tangentPlaneDistances() {
    TriangleMesh square;
    square.points = {{-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0}};
    square.triangles = {{0, 1, 2}, {0, 2, 3}};
    const TriangleBvh flat = TriangleBvh::build(square);
    struct Case {
      collision::P3 c, s;
      float expected;
    };
    for (const Case& k : {Case{{0.2f, 0.3f, 0.0f}, {0.5f, -0.4f, -0.7f}, 0.7f}, Case{{0.0f, 0.0f, 0.4f}, {0.3f, 0.2f, -0.5f}, 0.5f},
                          Case{{1.0f, -2.0f, -0.3f}, {1.6f, -1.5f, -1.1f}, 1.1f}}) {
      const trianglebvh::TangentPlane plane = trianglebvh::closestTangentPlane(flat.view(), 0, k.c);
      QVERIFY2(std::abs(trianglebvh::planeDistance(plane, k.c, k.s) - k.expected) < 1e-5f,
               qPrintable(QString::number(trianglebvh::planeDistance(plane, k.c, k.s))));
    }
    const float radius = 10.0f;
    const TriangleBvh sphere = TriangleBvh::build(testing::ellipsoidSurface(Vec3::Zero(), Vec3::Constant(radius), 5));
    std::mt19937 random(7);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    float worstExcess = -1.0f;
    for (int i = 0; i < 2000; ++i) {
      const Vec3 direction = Vec3(unit(random), unit(random), unit(random)).normalized();
      const Vec3 c = direction * (radius + 1.5f * unit(random));
      const Vec3 s = c + 0.9f * Vec3(unit(random), unit(random), unit(random));  // a 1.8 mm cube's reach
      const trianglebvh::TangentPlane plane = trianglebvh::closestTangentPlane(sphere.view(), 0, asP3(c));
      const float estimate = trianglebvh::planeDistance(plane, asP3(c), asP3(s));
      const float exact = std::sqrt(trianglebvh::closestSquaredDistance(sphere.view(), 0, asP3(s), 3.0e38f));
      // The level sets through s curve with radius |s| >= R - 1.5 - |s - c|; plus the facets' sagitta.
      const float bound = (s - c).squaredNorm() / (2.0f * (radius - 1.5f - (s - c).norm())) + 0.02f;
      worstExcess = std::max(worstExcess, std::abs(estimate - exact) - bound);
    }
    QVERIFY2(worstExcess <= 0.0f, qPrintable(QString::number(worstExcess)));
  }

  // A triangle's samples (1, 4 or 9) are the centroids of equal sub-triangles: inside it, apart
  // from each other, and centred on its centroid; the nine are a third of an edge apart, the
  // spacing of a split in thirds.
  void subTriangleCentroidsCoverTheTriangle() {
    const collision::P3 a{0, 0, 0}, b{3, 0, 0}, c{0, 3, 0};
    for (int count : {1, kSubTriangles, kFineSubTriangles}) {
      std::vector<collision::P3> p;
      for (int q = 0; q < count; ++q) p.push_back(subTriangleCentroid(a, b, c, q, count));
      float mx = 0, my = 0, closestPair = 1e9f;
      for (size_t i = 0; i < p.size(); ++i) {
        QVERIFY(p[i].x > 0 && p[i].y > 0 && p[i].x + p[i].y < 3 && p[i].z == 0);
        mx += p[i].x / float(count), my += p[i].y / float(count);
        for (size_t j = 0; j < i; ++j)
          closestPair = std::min(closestPair, std::hypot(p[i].x - p[j].x, p[i].y - p[j].y));
      }
      QVERIFY(std::abs(mx - 1) < 1e-5f && std::abs(my - 1) < 1e-5f);
      if (count == kFineSubTriangles) QVERIFY(std::abs(closestPair - std::sqrt(2.0f) / 3.0f) < 1e-5f);
    }
  }

  void agreesWithTheExactEvaluationOnColin27() {
    const QString t = "/usr/share/mricron/templates/";
    if (!QFile::exists(t + "aal.nii.gz")) QSKIP("Debian package mricron-data is not installed");
    const QString scenePath = dir_.filePath("colin.json");
    const auto r = testing::runTool(SINEW_MAKE_SCENE,
                                    {"--atlas", t + "aal.nii.gz", "--labels", t + "aal.nii.txt", "--training",
                                     t + "ch2better.nii.gz", "--target", t + "ch2.nii.gz", "--structures",
                                     "Hippocampus_L,Caudate_R,Pallidum_L,Thalamus_R", "--iterations", "60,40,20",
                                     "--seed", "5", "-o", scenePath});
    QVERIFY2(r.code == 0, qPrintable(r.err));
    SceneRunner* current = nullptr;
    std::vector<StructureResult> exact;  // at every sample, structure by structure
    std::vector<RunProgress> reports;
    RunOptions options;
    options.progress = [&](const RunProgress& p) {
      reports.push_back(p);
      for (Index i = 0; i < current->simulation().structureCount(); ++i) exact.push_back(current->evaluate(i, true));
    };
    SceneRunner runner(testing::builtinRegistry(), readScene(scenePath.toStdString()), options);
    current = &runner;
    runner.load();
    const RunReport report = runner.run();
    const size_t n = 4;
    QCOMPARE(report.timeline.size(), exact.size() + n);  // the first sample comes before any progress
    double worstAssd = 0, worstHd95 = 0;
    for (size_t k = 0; k < exact.size(); ++k) {
      const TimelineSample& s = report.timeline[k + n];
      QVERIFY(std::isfinite(s.assdMm) && std::isfinite(s.hd95Mm));
      worstAssd = std::max(worstAssd, std::abs(s.assdMm - exact[k].assdFinalMm));
      worstHd95 = std::max(worstHd95, std::abs(s.hd95Mm - exact[k].hd95Mm));
      QCOMPARE(s.dice, exact[k].dice);  // not sampled: the final result's Dice at the same positions
    }
    // Each progress report carries its sample's means; the last sample's are the end's, scored after.
    for (size_t g = 0; g + 1 < reports.size(); ++g) {
      double assd = 0.0, dice = 0.0;
      for (size_t i = 0; i < n; ++i) assd += report.timeline[(g + 1) * n + i].assdMm, dice += report.timeline[(g + 1) * n + i].dice;
      QCOMPARE(reports[g].meanAssdMm, assd / n);
      QCOMPARE(reports[g].meanDice, dice / n);
    }
    QVERIFY(std::isnan(reports.back().meanAssdMm) && std::isnan(reports.back().meanDice));
    qInfo("%zu samples: largest difference to the exact evaluation %.4f mm (ASSD), %.4f mm (HD95)", exact.size(), worstAssd,
          worstHd95);
    QVERIFY2(worstAssd <= 0.02, qPrintable(QString::number(worstAssd)));
    QVERIFY2(worstHd95 <= 0.05, qPrintable(QString::number(worstHd95)));
    // The first and the last sample are the exact evaluation's scores of the start and the end (the
    // run computes those anyway): the curve ends on the final table's values.
    for (size_t i = 0; i < n; ++i) {
      const StructureResult& r = report.structures[i];
      QCOMPARE(report.timeline[i].assdMm, r.assdInitialMm);
      QCOMPARE(report.timeline[i].dice, r.diceInitial);
      QCOMPARE(report.timeline[report.timeline.size() - n + i].dice, r.dice);
      QCOMPARE(report.timeline[report.timeline.size() - n + i].assdMm, r.assdFinalMm);
      QCOMPARE(report.timeline[report.timeline.size() - n + i].hd95Mm, r.hd95Mm);
      QCOMPARE(report.stages.back().assdMm[i], r.assdFinalMm);
    }
  }
};

QTEST_GUILESS_MAIN(TestSampledError)
#include "tst_sampled_error.moc"
