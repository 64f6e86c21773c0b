// Surface distances and overlap volumes used for evaluation, checked against analytic answers.
#include "sinew/core/voxelize.h"
#include "synthetic.h"

#include <QtTest>

#include <algorithm>
#include <cmath>
#include <random>

using namespace sinew;
using namespace sinew::testing;

class TestSurfaceDistance : public QObject {
  Q_OBJECT
private slots:
  // The HD95's selection against accumulating the areas of the sorted distances, on distances with
  // many ties (a coarse grid of values) and on distinct ones, at several quantiles.
  void weightedQuantileMatchesTheSortedAccumulation() {
    std::mt19937 random(3);
    for (int round = 0; round < 200; ++round) {
      const int n = 1 + int(random() % 500);
      const bool ties = round % 2 == 0;
      std::vector<WeightedDistance> all(n);
      for (WeightedDistance& w : all)
        w = {ties ? float(random() % 7) * 0.25f : float(random() % 100000) * 1e-4f, float(1 + random() % 9) * 0.125f};
      double total = 0;
      for (const WeightedDistance& w : all) total += w.w;
      for (double share : {0.0, 0.3, 0.95, 1.0}) {
        std::vector<WeightedDistance> sorted = all;
        std::sort(sorted.begin(), sorted.end(), [](const WeightedDistance& a, const WeightedDistance& b) { return a.d < b.d; });
        float expected = sorted.back().d;
        double acc = 0;
        for (const WeightedDistance& w : sorted)
          if ((acc += w.w) >= share * total) {
            expected = w.d;
            break;
          }
        std::vector<WeightedDistance> copy = all;
        QCOMPARE(weightedQuantile(copy, share * total), expected);
      }
    }
  }

  void pointToSurfaceIsExact() {
    const TriangleMesh cube = [] {
      TriangleMesh m;
      m.points = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
      m.triangles = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                     {2, 3, 7}, {2, 7, 6}, {1, 2, 6}, {1, 6, 5}, {0, 4, 7}, {0, 7, 3}};
      return m;
    }();
    const SurfaceDistanceQuery q(cube);
    QVERIFY(std::abs(q.distance(Vec3(0.5f, 0.5f, 3.0f)) - 2.0f) < 1e-6f);
    QVERIFY(std::abs(q.distance(Vec3(0.5f, 0.5f, 0.4f)) - 0.4f) < 1e-6f);
    QVERIFY(std::abs(q.distance(Vec3(2, 2, 2)) - std::sqrt(3.0f)) < 1e-6f);
    QVERIFY(std::abs(q.distance(Vec3(2, 0.5f, 2)) - std::sqrt(2.0f)) < 1e-6f);
    // Among the faces facing a direction (a thin part's far side): over the middle of a slab 10 mm
    // wide and 1 mm thick, the closest face facing down is the bottom, 1 mm below the top; facing
    // up, the top itself; a plain search finds the top. Within 1 mm nothing faces down.
    TriangleMesh slabMesh = cube;
    for (Vec3& p : slabMesh.points) p = Vec3(10 * p.x(), 10 * p.y(), p.z());
    const SurfaceDistanceQuery slab(slabMesh);
    const Vec3 above(5, 5, 1.2f);
    QVERIFY(std::abs(slab.closest(above).point.z() - 1.0f) < 1e-6f);
    QVERIFY(std::abs(slab.closestFacing(above, Vec3(0, 0, 1), 10.0f).point.z() - 1.0f) < 1e-6f);
    const SurfaceDistanceQuery::Closest down = slab.closestFacing(above, Vec3(0, 0, -1), 10.0f);
    QVERIFY(std::abs(down.point.z()) < 1e-6f && std::abs(down.distance - 1.2f) < 1e-5f);
    QVERIFY(std::isinf(slab.closestFacing(above, Vec3(0, 0, -1), 1.0f).distance));
  }

  // The hierarchy's search (surface-area-heuristic splits) against every triangle, on a smooth
  // surface and on 300 copies of one triangle (every split costs the same there: splits that took
  // one triangle off at a time would make a tree 300 deep, beyond the search's stack).
  void searchEqualsEveryTriangle() {
    TriangleMesh copies;
    copies.points = {{0, 0, 0}, {4, 0, 0}, {0, 4, 1}};
    for (int i = 0; i < 300; ++i) copies.triangles.push_back({0, 1, 2});
    std::mt19937 random(5);
    for (const TriangleMesh& mesh : {ellipsoidSurface(Vec3(1, 2, 3), Vec3(10, 6, 4), 4), copies}) {
      const SurfaceDistanceQuery query(mesh);
      const auto& nodes = query.bvh().nodes;
      std::vector<int> depth(nodes.size(), 0);
      int deepest = 0;
      for (size_t k = 0; k < nodes.size(); ++k)  // children come after their parents
        if (nodes[k].left >= 0) {
          depth[nodes[k].left] = depth[nodes[k].right] = depth[k] + 1;
          deepest = std::max(deepest, depth[k] + 1);
        }
      QVERIFY2(deepest < trianglebvh::kStackDepth - 1, qPrintable(QString("tree %1 deep").arg(deepest)));
      std::uniform_real_distribution<float> coordinate(-12.0f, 12.0f);
      for (int k = 0; k < 2000; ++k) {
        const Vec3 p(coordinate(random), coordinate(random), coordinate(random));
        float expected = 3.0e38f;
        for (const auto& t : mesh.triangles) {
          const collision::P3 q = collision::closestOnTriangle(asP3(p), asP3(mesh.points[t[0]]), asP3(mesh.points[t[1]]),
                                                               asP3(mesh.points[t[2]]));
          const collision::P3 d = collision::sub(asP3(p), q);
          expected = std::min(expected, collision::dot3(d, d));
        }
        QCOMPARE(query.distance(p), std::sqrt(expected));
      }
    }
  }

  // The host's wide walk (triangle_bvh_wide.h) against the binary one the device runs, over several
  // trees appended into one, then moved (refit): the same distances up to the rounding of triangles
  // equally near, from every root, and the closest point at that distance. Twice: the wide tree
  // made over every root after appending, and appended with each tree's. Also the wide tree's depth
  // against its walk's stack.
  void wideWalkEqualsTheBinaryOneAfterAppendAndRefit_data() {
    QTest::addColumn<bool>("appendWide");
    QTest::newRow("made after appending") << false;
    QTest::newRow("appended") << true;
  }
  void wideWalkEqualsTheBinaryOneAfterAppendAndRefit() {
    QFETCH(bool, appendWide);
    TriangleMesh copies;
    copies.points = {{0, 0, 0}, {4, 0, 0}, {0, 4, 1}};
    for (int i = 0; i < 300; ++i) copies.triangles.push_back({0, 1, 2});
    TriangleMesh small;  // a root that is a leaf: three triangles
    small.points = {{5, 5, 5}, {7, 5, 5}, {5, 7, 5}, {5, 5, 7}};
    small.triangles = {{0, 1, 2}, {0, 1, 3}, {0, 2, 3}};
    const std::vector<TriangleMesh> meshes = {ellipsoidSurface(Vec3(1, 2, 3), Vec3(10, 6, 4), 4), copies, small,
                                              icosphere(4, 5.0f, Vec3(-8, 0, 2))};
    std::vector<TriangleBvh> trees;
    for (const TriangleMesh& m : meshes) {
      trees.push_back(TriangleBvh::build(m));
      if (appendWide) trees.back().requireWide();
    }
    TriangleBvh all;
    all.reserveFor(trees);
    std::vector<int> roots;
    std::vector<Vec3> points;
    for (size_t i = 0; i < meshes.size(); ++i) {
      roots.push_back(all.append(trees[i], Index(points.size())));
      points.insert(points.end(), meshes[i].points.begin(), meshes[i].points.end());
    }
    QCOMPARE(all.hasWide(), appendWide);
    all.requireWide();
    std::mt19937 random(11);
    std::uniform_real_distribution<float> jitter(-0.3f, 0.3f), coordinate(-14.0f, 14.0f);
    for (Vec3& p : points) p = 1.1f * p + Vec3(jitter(random), jitter(random), jitter(random));
    all.refit(points, Executor(1));
    std::vector<int> depth(all.wide.size(), 1);  // children come after their parents: one pass
    int deepest = 1;
    for (size_t w = 0; w < all.wide.size(); ++w)
      for (int c : all.wide[w].child)
        if (c > 0) deepest = std::max(deepest, depth[size_t(c)] = depth[w] + 1);
    QVERIFY2(3 * deepest + 4 < trianglebvh::kWideStackDepth, qPrintable(QString("wide tree %1 deep").arg(deepest)));
    std::vector<size_t> firstTriangle = {0};
    for (const TriangleBvh& t : trees) firstTriangle.push_back(firstTriangle.back() + t.triangles.size());
    int differentPicks = 0;
    for (size_t m = 0; m < roots.size(); ++m)
      for (int k = 0; k < 1000; ++k) {
        const int root = roots[m];
        const collision::P3 p = asP3(Vec3(coordinate(random), coordinate(random), coordinate(random)));
        collision::P3 qb{}, qw{};
        int tb = -1, tw = -1;
        const float binary = trianglebvh::closestSquaredDistance(all.view(), root, p, 3.0e38f, &qb, &tb);
        const float wide = trianglebvh::closestSquaredDistance(all.wideView(), all.wideRoot(root), p, 3.0e38f, &qw, &tw);
        QVERIFY2(std::abs(wide - binary) <= 1e-6f * std::max(binary, 1.0f),
                 qPrintable(QString("root %1: %2 against %3").arg(root).arg(wide).arg(binary)));
        const collision::P3 d = collision::sub(p, qw);
        QVERIFY(std::abs(collision::dot3(d, d) - wide) <= 1e-5f * std::max(wide, 1.0f));
        QVERIFY(size_t(tw) >= firstTriangle[m] && size_t(tw) < firstTriangle[m + 1]);  // this root's mesh
        differentPicks += tb != tw;
      }
    qInfo("triangles picked differently (equally near): %d of %d searches", differentPicks, int(roots.size()) * 1000);
  }

  void concentricSpheres() {
    // ASSD between spheres of radius 10 and 11 is 1 (both directions), up to tessellation error.
    const TriangleMesh a = icosphere(5, 10.0f), b = icosphere(5, 11.0f);
    const SurfaceDistanceStats s = surfaceDistance(a, b, 0.5f);
    QVERIFY2(std::abs(s.assd - 1.0) < 0.01, qPrintable(QString::number(s.assd)));
    QVERIFY(std::abs(s.hd95 - 1.0) < 0.02);
    const SurfaceDistanceStats same = surfaceDistance(a, a, 0.5f);
    QVERIFY(same.assd < 1e-5);
  }

  void shiftedSpheresAreAsymmetricallyFar() {
    // Shifting a sphere of radius R by d: the mean distance is between d/2 and d for d << R.
    const TriangleMesh a = icosphere(5, 10.0f), b = icosphere(5, 10.0f, Vec3(1, 0, 0));
    const SurfaceDistanceStats s = surfaceDistance(a, b, 0.5f);
    QVERIFY(s.assd > 0.45 && s.assd < 0.55);  // exact: d/2 for a sphere, by symmetry of |cos|
    QVERIFY(s.hd95 > 0.9 && s.hd95 <= 1.0);
  }

  // Two spheres of radius 10 mm, centres 10 mm apart: the lens between them has volume
  // pi (4R + d)(2R - d)^2 / 12 = 1309 mm^3; the rasterised measure (0.5 mm grid) comes within 3 %.
  void overlapOfTwoSpheres() {
    const TriangleMesh a = icosphere(5, 10.0f), b = icosphere(5, 10.0f, Vec3(10, 0, 0)), far = icosphere(5, 10.0f, Vec3(25, 0, 0));
    const double lens = M_PI * (40.0 + 10.0) * 100.0 / 12.0;
    const double v = overlapVolume(a, b, 0.5);
    qInfo("overlap of two spheres: %.1f mm^3, exact %.1f", v, lens);
    QVERIFY(std::abs(v - lens) < 0.03 * lens);
    QCOMPARE(overlapVolume(a, far, 0.5), 0.0);
    const auto pairs = pairwiseOverlaps({&a, &b, &far}, 0.5);
    QCOMPARE(pairs.size(), size_t(2));  // a-b, b-far
    QVERIFY(pairs[0].a == 0 && pairs[0].b == 1 && pairs[1].a == 1 && pairs[1].b == 2);
  }

  // Dice straight from the mesh's inside runs equals Dice of the two masks, and both match the
  // volumes: spheres of radius 10 and 8 mm, concentric, on a 0.5 mm grid: 2 * 8^3 / (10^3 + 8^3).
  void diceOfMeshMatchesTheMasks() {
    ImageGeometry grid;
    grid.size = {50, 50, 50};
    grid.spacing = Eigen::Vector3d::Constant(0.5);
    grid.origin = Eigen::Vector3d::Constant(-12.25);
    const std::vector<std::uint8_t> truth = voxelize(icosphere(5, 10.0f), grid);
    LabelVolume labels(grid, 0);  // label 7 inside the truth, 3 elsewhere
    std::size_t count = 0;
    for (size_t v = 0; v < truth.size(); ++v) count += truth[v], labels.voxels()[v] = truth[v] ? 7 : 3;
    const TriangleMesh inner = icosphere(5, 8.0f);
    const double fromMasks = dice(voxelize(inner, grid), truth), fromMesh = diceOfMesh(inner, labels, 7, count);
    QCOMPARE(fromMesh, fromMasks);
    QVERIFY(std::abs(fromMesh - 2.0 * 512.0 / 1512.0) < 0.01);
    QCOMPARE(diceOfMesh(icosphere(5, 10.0f), labels, 7, count), 1.0);
    // Vertices off the numbers (a run that blew up, sampled before it stops): their triangles count
    // as absent, as if the surface had a hole there (a cap of the sphere here), and nothing else.
    TriangleMesh broken = inner, holed = inner;
    std::erase_if(holed.triangles, [&](const auto& t) {
      return inner.points[t[0]].z() > 6.0f || inner.points[t[1]].z() > 6.0f || inner.points[t[2]].z() > 6.0f;
    });
    for (Vec3& p : broken.points)
      if (p.z() > 6.0f) p = Vec3::Constant(std::nanf(""));
    const double withHole = diceOfMesh(broken, labels, 7, count);
    QVERIFY(std::isfinite(withHole) && withHole < fromMesh);
    QCOMPARE(withHole, diceOfMesh(holed, labels, 7, count));
  }
};

QTEST_APPLESS_MAIN(TestSurfaceDistance)
#include "tst_surface_distance.moc"
