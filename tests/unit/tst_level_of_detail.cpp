// Levels of detail: 1-to-4 refinement of the dual triangle mesh and the prolongation that carries
// per-vertex quantities between levels.
#include "synthetic.h"

#include <QtTest>

using namespace sinew;
using namespace sinew::testing;

class TestLevelOfDetail : public QObject {
  Q_OBJECT
private slots:
  void verticesMultiplyByFourAndStayValid() {
    const SimplexMesh coarse = SimplexMesh::sphere(1);
    const LevelHierarchy h = LevelHierarchy::build(coarse.topology, 4);
    QCOMPARE(h.levelCount(), 4);
    for (int l = 1; l < 4; ++l) {
      const SimplexTopology& t = h.levels[l];
      QCOMPARE(t.vertexCount(), 4 * h.levels[l - 1].vertexCount());
      QCOMPARE(t.eulerCharacteristic(), 2);
      for (Index v = 0; v < t.vertexCount(); ++v) {
        const auto& n = t.neighbours[v];
        QVERIFY(n[0] != n[1] && n[1] != n[2] && n[0] != n[2]);
      }
      // The refined topology is itself a valid dual: its dual triangles form a closed surface.
      const std::vector<Vec3> x = h.carry(coarse.positions, 0, l);
      const TriangleMesh tess = tessellate(t, x);
      validateClosedManifold(tess);
      QVERIFY(tess.volume() > 0.0);
    }
  }

  // Refined cells are numbered in the order of their least vertex (passes over the cells then
  // gather from nearby vertices), and each vertex's cells still contain it.
  void refinedCellsFollowTheirLeastVertex() {
    const LevelHierarchy h = LevelHierarchy::build(SimplexMesh::sphere(1).topology, 3);
    for (int l = 1; l < 3; ++l) {
      const SimplexTopology& t = h.levels[l];
      Index previous = -1;
      for (Index c = 0; c < t.cellCount(); ++c) {
        const auto begin = t.cellVertices.begin() + t.cellOffsets[c], end = t.cellVertices.begin() + t.cellOffsets[c + 1];
        QVERIFY(end - begin >= 3);
        const Index least = *std::min_element(begin, end);
        QVERIFY(least >= previous);
        previous = least;
      }
      for (Index v = 0; v < t.vertexCount(); ++v)
        for (int k = 0; k < 3; ++k) {
          const Index c = t.vertexCells[v][k];
          QVERIFY(std::count(t.cellVertices.begin() + t.cellOffsets[c], t.cellVertices.begin() + t.cellOffsets[c + 1], v) == 1);
        }
    }
  }

  void prolongationRowsArePartitionsOfUnity() {
    const RefinedTopology r = refine(SimplexMesh::sphere(2).topology);
    for (Index i = 0; i < r.prolongation.fineCount(); ++i) {
      float sum = 0;
      for (Index k = r.prolongation.rowOffsets[i]; k < r.prolongation.rowOffsets[i + 1]; ++k) {
        QVERIFY(r.prolongation.weight[k] > 0.0f);
        sum += r.prolongation.weight[k];
      }
      QVERIFY(std::abs(sum - 1.0f) < 1e-6f);
    }
  }

  void prolongationCommutesWithAffineMaps() {
    // Positions, velocities and forces are carried by the same fixed linear combination, so
    // carrying an affinely transformed field equals transforming the carried field.
    const SimplexMesh coarse = SimplexMesh::sphere(2, 4.0f);
    const RefinedTopology r = refine(coarse.topology);
    Eigen::Matrix3f A;
    A << 1.2f, 0.3f, -0.1f, 0.0f, 0.8f, 0.2f, 0.1f, -0.4f, 1.1f;
    const Vec3 b(5, -2, 7);
    std::vector<Vec3> mapped;
    for (const Vec3& p : coarse.positions) mapped.push_back(A * p + b);
    const auto fineOfMapped = r.prolongation.apply(mapped);
    const auto fine = r.prolongation.apply(coarse.positions);
    for (size_t i = 0; i < fine.size(); ++i) QVERIFY(((A * fine[i] + b) - fineOfMapped[i]).norm() < 1e-4f);
  }

  void centreChildSitsOnItsParent() {
    const SimplexMesh coarse = SimplexMesh::sphere(2, 4.0f);
    const RefinedTopology r = refine(coarse.topology);
    const auto fine = r.prolongation.apply(coarse.positions);
    for (Index t = 0; t < coarse.topology.vertexCount(); ++t) QCOMPARE(fine[4 * t], coarse.positions[t]);
  }

  void refinedSphereStaysNearTheSphere() {
    const float R = 10.0f;
    const SimplexMesh coarse = SimplexMesh::sphere(2, R);
    const LevelHierarchy h = LevelHierarchy::build(coarse.topology, 3);
    const auto fine = h.carry(coarse.positions, 0, 2);
    for (const Vec3& p : fine) QVERIFY(std::abs(p.norm() - R) < 0.03f * R);
  }

  void simulationCarriesPositionsAndVelocities() {
    StructureSpec spec = sphereStructure("ball", 1, 5.0f, Vec3::Zero(), 2);
    Simulation sim(forceRegistry(), 1);
    sim.addStructure(spec);
    sim.addForce("smoothing");
    sim.setIntegrator("damped_verlet");
    sim.initialize();
    // Give every vertex a velocity along x by shifting the previous positions.
    auto prev = sim.store().previousPositions();
    for (Vec3& p : prev) p -= Vec3(0.1f, 0, 0);
    const std::vector<Vec3> coarseX(sim.store().positions().begin(), sim.store().positions().end());
    const std::vector<Vec3> coarsePrev(prev.begin(), prev.end());
    QVERIFY(sim.advanceLevel());
    QCOMPARE(sim.level(), 1);
    QCOMPARE(sim.store().vertexCount(), Index(4 * coarseX.size()));
    const auto x = sim.store().positions();
    const auto xp = sim.store().previousPositions();
    const auto expectX = spec.levels.prolongations[0].apply(coarseX);
    for (size_t i = 0; i < expectX.size(); ++i) {
      QVERIFY((x[i] - expectX[i]).norm() < 1e-5f);
      QVERIFY(((x[i] - xp[i]) - Vec3(0.1f, 0, 0)).norm() < 1e-5f);
    }
    QVERIFY(!sim.advanceLevel());
  }
};

QTEST_APPLESS_MAIN(TestLevelOfDetail)
#include "tst_level_of_detail.moc"
