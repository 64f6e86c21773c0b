// The mesh store and the simulation around it: concatenated layout, allocation on demand,
// per-structure weights and the skipping of forces that are off everywhere.
#include "synthetic.h"

#include <QtTest>

using namespace sinew;
using namespace sinew::testing;

namespace {
std::shared_ptr<Image3D> smallImage() {
  EllipsoidImageSpec spec;
  spec.size = 32;
  spec.centre = Vec3(16, 16, 16);
  spec.radii = Vec3(8, 7, 6);
  return std::make_shared<Image3D>(ellipsoidImage(spec));
}

std::unique_ptr<Simulation> twoSpheres(const std::vector<std::string>& forces) {
  auto sim = std::make_unique<Simulation>(forceRegistry(), 1);
  for (int i = 0; i < 2; ++i) {
    StructureSpec s = sphereStructure("s" + std::to_string(i), 2, 5.0f, Vec3(16 + i, 16, 16));
    s.referencePositions = s.initialPositions;
    sim->addStructure(std::move(s));
  }
  for (const auto& f : forces) sim->addForce(f);
  sim->setIntegrator("damped_verlet");
  sim->scene().setTargetImage(smallImage());
  return sim;
}
}  // namespace

class TestMeshStore : public QObject {
  Q_OBJECT
private slots:
  void concatenatesMeshesWithGlobalIndices() {
    const SimplexMesh a = SimplexMesh::sphere(1), b = SimplexMesh::sphere(2);
    MeshStore s(std::vector<const SimplexTopology*>{&a.topology, &b.topology});
    QCOMPARE(s.meshCount(), 2);
    QCOMPARE(s.vertexCount(), a.topology.vertexCount() + b.topology.vertexCount());
    QCOMPARE(s.range(1).vertexBegin, a.topology.vertexCount());
    QCOMPARE(s.range(1).cellBegin, a.topology.cellCount());
    for (Index m = 0; m < 2; ++m) {
      const MeshRange& r = s.range(m);
      for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) {
        QCOMPARE(s.meshOfVertex()[v], m);
        for (Index n : s.neighbours()[v]) QVERIFY(n >= r.vertexBegin && n < r.vertexEnd);
        for (Index c : s.vertexCells()[v]) QVERIFY(c >= r.cellBegin && c < r.cellEnd);
      }
    }
    // Local topology round-trips.
    const SimplexTopology back = s.topologyOf(1);
    QCOMPARE(back.neighbours, b.topology.neighbours);
    QCOMPARE(back.cellVertices, b.topology.cellVertices);
  }

  void onlyRequiredAttributesAreAllocated() {
    const SimplexMesh a = SimplexMesh::sphere(2);
    MeshStore s(std::vector<const SimplexTopology*>{&a.topology});
    QVERIFY(s.has(Attribute::Position));
    for (Attribute x : {Attribute::PreviousPosition, Attribute::Force, Attribute::ReferencePosition,
                        Attribute::Normal, Attribute::SimplexParams, Attribute::Area, Attribute::Mass})
      QVERIFY(!s.has(x));
    QCOMPARE(s.bytes(MemoryCategory::Geometry), size_t(0));
    QCOMPARE(s.bytes(MemoryCategory::State), a.positions.size() * sizeof(Vec3));
  }

  void smoothingOnlySceneAllocatesNoImageDerivedData() {
    auto sim = twoSpheres({"smoothing"});
    sim->initialize();
    sim->run(5);
    QCOMPARE(sim->store().bytes(MemoryCategory::ImageDerived), size_t(0));
    QCOMPARE(sim->scene().imageDerivedBytes(), size_t(0));
    QVERIFY(!sim->store().has(Attribute::ReferencePosition));
    QVERIFY(!sim->store().has(Attribute::SimplexParams));
    qInfo("smoothing-only: state %zu B, geometry %zu B, image-derived %zu B",
          sim->store().bytes(MemoryCategory::State), sim->store().bytes(MemoryCategory::Geometry),
          sim->store().bytes(MemoryCategory::ImageDerived) + sim->scene().imageDerivedBytes());
  }

  void imageForcesAllocateWhatTheyDeclare() {
    auto sim = twoSpheres({"smoothing", "gradient", "intensity_profile", "shape_prior"});
    sim->initialize();
    sim->run(2);
    const size_t profileBytes = sim->store().bytes(MemoryCategory::ImageDerived);
    QCOMPARE(profileBytes, size_t(sim->store().vertexCount()) * 30 * sizeof(float));
    QCOMPARE(sim->scene().imageDerivedBytes(), size_t(32 * 32 * 32) * sizeof(Vec3));
    QVERIFY(sim->store().has(Attribute::ReferenceParams));
  }

  void forceWeightedZeroEverywhereIsNotEvaluated() {
    auto sim = twoSpheres({"smoothing", "gradient"});
    sim->forceParams("gradient").setAll("weight", 0.0);
    sim->initialize();
    sim->run(10);
    QCOMPARE(sim->evaluations("gradient"), 0L);
    QCOMPARE(sim->evaluations("smoothing"), 10L);
    QCOMPARE(sim->scene().imageDerivedBytes(), size_t(0));  // never asked for the gradient
    // On for one structure only: evaluated, and only that structure feels it.
    auto reference = twoSpheres({"smoothing"});
    reference->initialize();
    reference->run(10);
    sim->forceParams("gradient").set(1, "weight", 1.0);
    reference->run(5);
    sim->run(5);
    QCOMPARE(sim->evaluations("gradient"), 5L);
    const MeshRange r0 = sim->store().range(0), r1 = sim->store().range(1);
    for (Index v = r0.vertexBegin; v < r0.vertexEnd; ++v)
      QCOMPARE(sim->store().positions()[v], reference->store().positions()[v]);
    float moved = 0;
    for (Index v = r1.vertexBegin; v < r1.vertexEnd; ++v)
      moved = std::max(moved, (sim->store().positions()[v] - reference->store().positions()[v]).norm());
    QVERIFY(moved > 1e-3f);
  }

  void badParametersAndNamesAreRefused() {
    Simulation sim(forceRegistry(), 1);
    sim.addStructure(sphereStructure("a", 1, 1.0f, Vec3::Zero()));
    QVERIFY_THROWS_EXCEPTION(InputError, sim.addForce("no_such_force"));
    ParamTable& p = sim.addForce("smoothing");
    QVERIFY_THROWS_EXCEPTION(InputError, p.set(0, "weight", 1.5));
    QVERIFY_THROWS_EXCEPTION(InputError, p.set(0, "no_such_param", 0.5));
    try {
      sim.addForce("shape_prior");
      sim.setIntegrator("damped_verlet");
      sim.initialize();
      QFAIL("a shape prior without a reference shape was accepted");
    } catch (const InputError& e) {
      QVERIFY(QString(e.what()).contains("reference shape"));
    }
  }

  void everyParameterIsDeclaredCompletely() {
    for (const auto& f : forceRegistry().forces()) {
      QVERIFY(!f.summary.empty());
      QCOMPARE(f.params.front().name, std::string("weight"));
      for (const auto& d : f.params) {
        QVERIFY2(!d.help.empty(), d.name.c_str());
        QVERIFY(d.min <= d.defaultValue && d.defaultValue <= d.max);
      }
    }
    QVERIFY(!forceRegistry().integrators().empty());
  }
};

QTEST_APPLESS_MAIN(TestMeshStore)
#include "tst_mesh_store.moc"
