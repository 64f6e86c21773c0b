// Surface distances used for evaluation, checked against analytic answers.
#include "synthetic.h"

#include <QtTest>

using namespace sinew;
using namespace sinew::testing;

class TestSurfaceDistance : public QObject {
  Q_OBJECT
private slots:
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
};

QTEST_APPLESS_MAIN(TestSurfaceDistance)
#include "tst_surface_distance.moc"
