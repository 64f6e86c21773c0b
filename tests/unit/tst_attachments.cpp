// Attachments (paper 001 section 2.2): vertices that follow another structure's surface, merged
// vertex pairs that move together, fixed vertices (docs/attachments.md).
#include "sinew/core/attachments.h"
#include "synthetic.h"

#include <QtTest>

using namespace sinew;
using namespace sinew::testing;

namespace {
// Two spheres of radius 5 whose surfaces come within `gap` mm of each other along x; A noisy.
std::unique_ptr<Simulation> twoSpheres(float gap, std::vector<AttachmentSpec> attachments, float noise = 0.0f,
                                       const std::string& integrator = "damped_verlet", int levels = 1) {
  auto sim = std::make_unique<Simulation>(forceRegistry(), 2);
  StructureSpec a = sphereStructure("a", 3, 5.0f, Vec3::Zero(), levels);
  if (noise > 0.0f) a.initialPositions = withNoise(a.initialPositions, noise, 7);
  sim->addStructure(std::move(a));
  sim->addStructure(sphereStructure("b", 3, 5.0f, Vec3(10.0f + gap, 0, 0), levels));
  ParamTable& smoothing = sim->addForce("smoothing");
  smoothing.set(1, 0, 0.0);  // b has no force of its own
  sim->setIntegrator(integrator);
  sim->setAttachments(std::move(attachments));
  sim->initialize();
  return sim;
}

void translate(MeshStore& store, Index m, const Vec3& d) {
  auto x = store.positionsForWrite();
  auto prev = store.previousPositions();
  for (Index v = store.range(m).vertexBegin; v < store.range(m).vertexEnd; ++v) x[v] += d, prev[v] += d;
}
}  // namespace

class TestAttachments : public QObject {
  Q_OBJECT

private slots:
  // The vertices of a near b's surface follow it when it moves; the rest of a does not.
  void attachedVerticesFollowTheSurface() {
    auto sim = twoSpheres(0.3f, {{.kind = AttachmentSpec::Kind::Surface, .structure = 0, .other = 1, .distanceMm = 1.0f}});
    MeshStore& store = sim->store();
    QVERIFY(sim->attachments().attachedCount() > 0);
    QVERIFY(sim->attachments().attachedCount() < store.range(0).vertexCount() / 4);
    const std::vector<Vec3> before(store.positions().begin(), store.positions().end());
    const Vec3 d(0, 2, 0);
    translate(store, 1, d);
    sim->step();
    const auto x = store.positions();
    int followed = 0, stayed = 0;
    for (Index v = store.range(0).vertexBegin; v < store.range(0).vertexEnd; ++v) {
      const float moved = (x[v] - before[v] - d).norm();
      if (before[v].x() > 4.0f && moved < 0.05f) ++followed;       // near b: moved with it
      if (before[v].x() < 0.0f && (x[v] - before[v]).norm() < 0.05f) ++stayed;  // far side: still
    }
    qInfo("%d of a's %d vertices attached to b; %d of them followed b's 2 mm move, %d on the far side stayed", int(sim->attachments().attachedCount()),
          int(store.range(0).vertexCount()), followed, stayed);
    QCOMPARE(followed, int(sim->attachments().attachedCount()));
    QCOMPARE(stayed, int(std::count_if(before.begin() + store.range(0).vertexBegin, before.begin() + store.range(0).vertexEnd,
                                       [](const Vec3& p) { return p.x() < 0.0f; })));
  }

  // Merged pairs move as one: a's smoothing moves both vertices of each pair, though b has no
  // force of its own, and each pair keeps its offset, with both integrators and on a finer level
  // (where velocities carried from the coarser one differ within a pair).
  void mergedPairsMoveTogether_data() {
    QTest::addColumn<QString>("integrator");
    QTest::newRow("damped_verlet") << "damped_verlet";
    QTest::newRow("implicit_euler") << "implicit_euler";
  }
  void mergedPairsMoveTogether() {
    QFETCH(QString, integrator);
    auto sim = twoSpheres(0.0f, {{.kind = AttachmentSpec::Kind::Merge, .structure = 0, .other = 1, .distanceMm = 0.5f}}, 0.3f,
                          integrator.toStdString(), 2);
    MeshStore& store = sim->store();
    for (int level = 0; level < 2; ++level) {
      if (level == 1) QVERIFY(sim->advanceLevel());
      const auto pairs = sim->attachments().mergedPairs();
      QVERIFY(!pairs.empty());
      const std::vector<Vec3> before(store.positions().begin(), store.positions().end());
      sim->run(10);
      const auto x = store.positions();
      int moved = 0;
      for (const auto& [a, b] : pairs) {
        QVERIFY(((x[b] - x[a]) - (before[b] - before[a])).norm() < 1e-4f);  // the offset kept
        moved += (x[b] - before[b]).norm() > 1e-4f;                          // b moved, with a
      }
      qInfo("%s, level %d: %zu merged pairs, %d moved as one", qPrintable(integrator), level, pairs.size(), moved);
      QVERIFY(moved > int(pairs.size()) / 2);
      // b's other vertices have no force: they stay (at level 0; later they carry the velocities
      // the prolongation gave them).
      if (level == 0)
        for (Index u = store.range(1).vertexBegin; u < store.range(1).vertexEnd; ++u)
          if (std::none_of(pairs.begin(), pairs.end(), [&](const auto& p) { return p.second == u; }))
            QVERIFY((x[u] - before[u]).norm() < 1e-5f);
    }
  }

  void badSpecsAreRefused() {
    auto sim = std::make_unique<Simulation>(forceRegistry(), 2);
    sim->addStructure(sphereStructure("a", 2, 5.0f, Vec3::Zero()));
    sim->addForce("smoothing");
    sim->setIntegrator("damped_verlet");
    sim->setAttachments({{.kind = AttachmentSpec::Kind::Surface, .structure = 0, .other = 3}});
    QVERIFY_THROWS_EXCEPTION(InputError, sim->initialize());
  }

  // Fixed vertices keep their place exactly while the rest of the structure smooths.
  void fixedVerticesStay() {
    auto sim = twoSpheres(5.0f, {{.kind = AttachmentSpec::Kind::Fixed, .structure = 0, .centre = Vec3(5, 0, 0), .radiusMm = 3.0f}}, 0.3f);
    MeshStore& store = sim->store();
    QVERIFY(sim->attachments().fixedCount() > 0);
    const std::vector<Vec3> before(store.positions().begin(), store.positions().end());
    sim->run(20);
    const auto x = store.positions();
    int fixed = 0, moved = 0;
    for (Index v = store.range(0).vertexBegin; v < store.range(0).vertexEnd; ++v) {
      if ((before[v] - Vec3(5, 0, 0)).norm() <= 3.0f) {
        QCOMPARE(x[v], before[v]);
        ++fixed;
      } else {
        moved += (x[v] - before[v]).norm() > 1e-3f;
      }
    }
    qInfo("%d fixed vertices stayed, %d others moved", fixed, moved);
    QCOMPARE(fixed, int(sim->attachments().fixedCount()));
    QVERIFY(moved > store.range(0).vertexCount() / 2);
  }
};

QTEST_GUILESS_MAIN(TestAttachments)
#include "tst_attachments.moc"
