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

  // A triangle's samples (1 or 4) are the centroids of its sub-triangles (subTriangleCorners): the
  // whole triangle, or the four of its midpoint split, which tile it with equal areas.
  void subTrianglesTileTheTriangle() {
    const collision::P3 a{0, 0, 0}, b{3, 0, 0}, c{0, 3, 0};
    for (int count : {1, kSubTriangles}) {
      float area = 0;
      for (int q = 0; q < count; ++q) {
        collision::P3 k[3];
        subTriangleCorners(a, b, c, q, count, k);
        const collision::P3 p = subTriangleCentroid(a, b, c, q, count);
        QVERIFY(std::abs((k[0].x + k[1].x + k[2].x) / 3 - p.x) < 1e-5f && std::abs((k[0].y + k[1].y + k[2].y) / 3 - p.y) < 1e-5f);
        const float twice = (k[1].x - k[0].x) * (k[2].y - k[0].y) - (k[1].y - k[0].y) * (k[2].x - k[0].x);
        QVERIFY(std::abs(std::abs(twice) / 2 - 4.5f / float(count)) < 1e-5f);
        area += std::abs(twice) / 2;
      }
      QVERIFY(std::abs(area - 4.5f) < 1e-5f);
    }
  }

  // A spread sample's area is spread as a linear function's over a triangle: corners at 0, 0 and 1
  // put the share 1 - (1 - t)^2 at or below t, so the 95th percentile is 1 - sqrt(0.05) = 0.776,
  // where the point at its centroid (1/3) gave 1/3. Beside 19 points at 0 (95 % of the area), the
  // percentile stays in the first bin.
  void spreadSamplesTakeTheirAreasValues() {
    const float bin = SampledError::kBinMm;
    const std::vector<WeightedDistance> one{{1.0f / 3.0f, 1.0f}};
    const std::vector<DistanceSpread> spread{{0.0f, 0.0f, 1.0f}};
    QVERIFY(std::abs(summariseBinned(one, {}, bin).hd95 - 1.0 / 3.0) <= bin);
    const SurfaceDistanceStats s = summariseBinned(one, {}, bin, spread, 1.0f);
    QVERIFY2(std::abs(s.hd95 - (1.0 - std::sqrt(0.05))) <= bin, qPrintable(QString::number(s.hd95)));
    QCOMPARE(s.assd, double(1.0f / 3.0f));  // the mean is the sample's: spreading moves no area's mean
    std::vector<WeightedDistance> many(19, {0.0f, 1.0f});
    many.push_back({1.0f / 3.0f, 1.0f});
    std::vector<DistanceSpread> spreads(19, {0.0f, 0.0f, 0.0f});
    spreads.push_back({0.0f, 0.0f, 1.0f});
    QVERIFY(summariseBinned(many, {}, bin, spreads, 1.0f).hd95 <= bin);
    // Beyond the bracket around the points' percentile a spread is left a point.
    QVERIFY(std::abs(summariseBinned(one, {}, bin, std::vector<DistanceSpread>{{0.9f, 0.95f, 1.0f}}, 0.1f).hd95 - 1.0 / 3.0) <= bin);
  }

  // The curvature term on a sphere of radius 10: patches 1 mm outside it, each plane tangent at its
  // nearest point; the middle patch's operator fitted to the others is I / 10, and samples 0.5 mm
  // out and 0.5 mm in, 1.4 mm along, take their distances to within a few thousandths where the
  // plane alone is out by about u^2 / 2R (0.1 mm).
  void curvatureTermOnASphere() {
    const float radius = 10.0f;
    std::vector<trianglebvh::TangentPlane> planes;
    std::vector<collision::P3> centres;
    std::vector<int> others;
    for (int i = -2; i <= 2; ++i)
      for (int j = -2; j <= 2; ++j) {
        const Vec3 n = Vec3(float(i), float(j), radius).normalized();
        centres.push_back(asP3(Vec3((radius + 1.0f) * n)));
        planes.push_back({asP3(n), 1.0f});
        if (i != 0 || j != 0) others.push_back(int(planes.size()) - 1);
      }
    const CurvedPlane c = fitCurvature(planes, centres, 12, others);
    QVERIFY2(std::abs(c.s11 - 0.1f) < 0.01f && std::abs(c.s22 - 0.1f) < 0.01f && std::abs(c.s12) < 0.01f,
             qPrintable(QString("%1 %2 %3").arg(c.s11).arg(c.s12).arg(c.s22)));
    for (const float offset : {0.5f, -0.5f}) {
      const Vec3 s = (radius + offset) * Vec3(1.2f, -0.8f, radius).normalized();
      const float plain = std::abs(c.n.dot(s - c.q));
      QVERIFY(std::abs(plain - 0.5f) > 0.08f);
      QVERIFY2(std::abs(curvedDistance(c, s) - 0.5f) < 0.01f, qPrintable(QString::number(curvedDistance(c, s))));
    }
    // Fewer than two neighbours: the plane alone.
    const CurvedPlane flat = fitCurvature(planes, centres, 12, std::span<const int>(others).first(1));
    QVERIFY(flat.s11 == 0.0f && flat.s12 == 0.0f && flat.s22 == 0.0f);
    // A plane without a normal (a centre on a degenerate triangle) stays finite.
    planes[12].n = {0, 0, 0};
    const CurvedPlane none = fitCurvature(planes, centres, 12, others);
    QVERIFY(std::isfinite(curvedDistance(none, Vec3(1, 2, 3))));
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
