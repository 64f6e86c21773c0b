// The collision force on the CPU and CUDA backends (label gpu): the hierarchies refitted on the
// device, the full searches' response and the contact planes between them, against the CPU's
// plugin running the same code (core/collision_bvh.h). Skips without a GPU. (The contact planes
// in the profile's pass: tst_cuda_profile; deforming contacts beside collisions: tst_cuda_parity.)
#include "collision_scenes.h"
#include "parity_scene.h"
#include "sinew/core/types.h"
#include "sinew/cuda/cuda_engine.h"
#include "synthetic.h"

#include <QtTest>

#include <functional>
#include <tuple>

using namespace sinew;
using namespace sinew::testing;

class TestCudaCollision : public QObject {
  Q_OBJECT
private slots:
  void initTestCase() {
    const cuda::DeviceStatus st = cuda::probeDevice();
    if (!st.usable) QSKIP(qPrintable("GPU collision tests need an NVIDIA GPU: " + QString::fromStdString(st.reason)));
    qInfo("device: %s", st.description.c_str());
  }

  // Collisions: the hierarchies refitted on the device and the contact response, on two
  // overlapping spheres held by the shape prior, with both integrators. The same code runs on both
  // sides (core/collision_bvh.h), but the device computes the cell centres and masses in its own
  // order, so the parity is a tolerance: 1e-3 mm after 100 steps (Verlet), 1e-2 mm after 20
  // (implicit Euler, whose solve sums in another order). Run to run the device repeats itself.
  // With full_search_every 8 (what sinew-make-scene writes), seven steps in eight meet only the
  // last full search's contact plane (collision::contactHit).
  void collisionMatchesTheCpu_data() {
    QTest::addColumn<QString>("integrator");
    QTest::addColumn<int>("steps");
    QTest::addColumn<int>("every");
    QTest::addColumn<float>("gap");   // between the spheres' centres (radius 10 mm)
    QTest::addColumn<float>("hold");  // hold_mm: 0 holds touching vertices on their contact planes after each step
    QTest::addColumn<int>("subdivisions");  // of each sphere: 3 gives 1,280 vertices, 6 gives 81,920
    QTest::addColumn<int>("structures");    // spheres in rows of 6, each `gap` from the next
    QTest::addColumn<float>("radius");      // of every second sphere: unequal sizes share contacts unequally
    QTest::addColumn<float>("holdStep");    // hold_step: the hold's most a step, in the vertex's spacings (0: none)
    QTest::addColumn<float>("reaction");    // reaction: the other side pushed back (collision::reactionPush; 0: none)
    QTest::newRow("damped_verlet") << "damped_verlet" << 100 << 1 << 15.0f << 0.0f << 3 << 2 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("damped_verlet, no hold") << "damped_verlet" << 100 << 1 << 15.0f << -1.0f << 3 << 2 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("implicit_euler") << "implicit_euler" << 20 << 1 << 15.0f << 0.0f << 3 << 2 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("implicit_euler, every 8") << "implicit_euler" << 20 << 8 << 15.0f << 0.0f << 3 << 2 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("damped_verlet, full search every 8") << "damped_verlet" << 100 << 8 << 15.0f << 0.0f << 3 << 2 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("damped_verlet, radii 10 and 6 (size_share)") << "damped_verlet" << 100 << 1 << 13.0f << 0.0f << 3 << 2 << 6.0f << 0.0f << 0.0f;
    QTest::newRow("damped_verlet, radii 10 and 6, every 8") << "damped_verlet" << 100 << 8 << 13.0f << 0.0f << 3 << 2 << 6.0f << 0.0f << 0.0f;
    // Without a hold the step ends in its own kernel (advance): the largest move is reset there too.
    QTest::newRow("damped_verlet, no hold, full search every 8") << "damped_verlet" << 100 << 8 << 15.0f << -1.0f << 3 << 2 << 10.0f << 0.0f << 0.0f;
    // 163,840 vertices: the refit's climb from the leaves and 4 lanes a vertex from 131,072.
    QTest::newRow("damped_verlet, 163,840 vertices") << "damped_verlet" << 100 << 1 << 15.0f << 0.0f << 6 << 2 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("damped_verlet, 163,840 vertices, every 8") << "damped_verlet" << 100 << 8 << 15.0f << 0.0f << 6 << 2 << 10.0f << 0.0f << 0.0f;
    // Centres 8 mm apart: the vertices inside the other sphere have its far side as their contact
    // and retreat (collision::respondTo), by the full search and by the contact planes between. Not
    // with implicit Euler: there the solver's float differences (1e-5 mm) meet the jumps of a deep
    // vertex's nearest point across the other sphere's middle, and the backends were 0.15-0.25 mm
    // apart after 20 steps (H200, 2026-11-26; docs/collisions.md).
    QTest::newRow("damped_verlet, past the middle") << "damped_verlet" << 100 << 1 << 8.0f << 0.0f << 3 << 2 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("damped_verlet, past the middle, every 8") << "damped_verlet" << 100 << 8 << 8.0f << 0.0f << 3 << 2 << 10.0f << 0.0f << 0.0f;
    // More structures than one round of a vertex's lanes: 16 lanes a vertex in two rounds (30,720
    // vertices), and from 131,072 vertices one lane a vertex taking them in turn (133,120).
    QTest::newRow("damped_verlet, 24 structures") << "damped_verlet" << 100 << 1 << 15.0f << 0.0f << 3 << 24 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("damped_verlet, 26 structures, 133,120 vertices") << "damped_verlet" << 100 << 1 << 15.0f << 0.0f << 4 << 26 << 10.0f << 0.0f << 0.0f;
    QTest::newRow("damped_verlet, 26 structures, every 8") << "damped_verlet" << 100 << 8 << 15.0f << 0.0f << 4 << 26 << 10.0f << 0.0f << 0.0f;
    // The hold moving a vertex at most 0.05 of its spacing (the square root of its area) a step, by
    // the full search and by the contact planes between; at 163,840 vertices (spacing about 0.12 mm)
    // also through the climb's refit and 4 lanes a vertex.
    QTest::newRow("damped_verlet, hold_step 0.05") << "damped_verlet" << 100 << 1 << 15.0f << 0.0f << 3 << 2 << 10.0f << 0.05f << 0.0f;
    QTest::newRow("damped_verlet, 163,840 vertices, hold_step 0.05, every 8") << "damped_verlet" << 100 << 8 << 15.0f << 0.0f << 6 << 2 << 10.0f << 0.05f << 0.0f;
    // The reaction (sinew-make-scene's 2): the smaller sphere takes its share by size, and the larger
    // one's contact triangles are pushed back by the rest, summed in fixed point on the device, in
    // vertex order on the CPU; by the full search and by the contact planes between, also through
    // the climb's refit and 4 lanes a vertex (163,840 vertices, radii 10 and 7). On the CPU the
    // reaction moves the first three rows' scene by 0.24-0.76 mm, far beyond the tolerances
    // (tst_collision::deviceRowsSceneReacts): a device without it fails them.
    QTest::newRow("damped_verlet, radii 10 and 6, reaction 2") << "damped_verlet" << 100 << 1 << 13.0f << 0.0f << 3 << 2 << 6.0f << 0.0f << 2.0f;
    QTest::newRow("damped_verlet, radii 10 and 6, reaction 2, every 8") << "damped_verlet" << 100 << 8 << 13.0f << 0.0f << 3 << 2 << 6.0f << 0.0f << 2.0f;
    QTest::newRow("implicit_euler, radii 10 and 6, reaction 2") << "implicit_euler" << 20 << 1 << 13.0f << 0.0f << 3 << 2 << 6.0f << 0.0f << 2.0f;
    QTest::newRow("damped_verlet, 163,840 vertices, radii 10 and 7, reaction 2, every 8") << "damped_verlet" << 100 << 8 << 14.0f << 0.0f << 6 << 2 << 7.0f << 0.05f << 2.0f;
  }

  void collisionMatchesTheCpu() {
    QFETCH(QString, integrator);
    QFETCH(int, steps);
    QFETCH(int, every);
    QFETCH(float, gap);
    QFETCH(float, hold);
    QFETCH(int, subdivisions);
    QFETCH(int, structures);
    QFETCH(float, radius);
    QFETCH(float, holdStep);
    QFETCH(float, reaction);
    auto make = [&](int count, float weight) {
      auto sim = std::make_unique<Simulation>(forceRegistry(), 0);
      for (int i = 0; i < count; ++i) {
        std::string name(1, char('a' + i % 26));
        if (i >= 26) name += std::to_string(i / 26);
        StructureSpec s = sphereStructure(name, subdivisions, i % 2 ? radius : 10.0f, Vec3(gap * float(i % 6), gap * float(i / 6), 0));
        s.referencePositions = s.initialPositions;
        sim->addStructure(std::move(s));
      }
      sim->addForce("shape_prior");
      ParamTable& collision = sim->addForce("collision");
      collision.setAll("weight", weight);
      collision.setAll("full_search_every", every);
      collision.setAll("hold_mm", hold);
      collision.setAll("hold_step", holdStep);
      collision.setAll("reaction", reaction);
      sim->setIntegrator(integrator.toStdString()).set(0, "time_step", integrator == "implicit_euler" ? 2.0 : 0.5);
      sim->initialize();
      return sim;
    };
    const ParityRun r = runOnBoth([&] { return make(structures, 0.5f); }, steps);
    qInfo("collision, %s, %d structures, centres %g mm apart, hold %g, reaction %g: max CPU-CUDA difference %.3g mm "
          "after %d steps (vertices pushed up to %.3g mm)", qPrintable(integrator), structures, double(gap), double(hold),
          double(reaction), r.cpuCuda, steps, r.moved);
    QVERIFY(r.moved > 1.0);
    QVERIFY2(r.cpuCuda < (integrator == "implicit_euler" ? 1e-2 : 1e-3), qPrintable(QString::number(r.cpuCuda)));
    QCOMPARE(r.deviceRepeat, 0.0);
    // The hierarchies exist only where there is something to collide with.
    auto bytesAfter = [](Simulation& sim) {
      cuda::CudaEngine e(sim);
      e.run(2);
      return e.deviceBytes();
    };
    // Nested by design (ignore_enclosed): a small sphere inside the first, with a third sphere
    // touching the first from outside, so that contacts still act; both sides leave the nested pair out.
    auto nested = [&] {
      auto sim = std::make_unique<Simulation>(forceRegistry(), 0);
      for (const auto& [name, radius, centre] : {std::tuple{"outer", 10.0f, Vec3(0, 0, 0)}, std::tuple{"inner", 4.0f, Vec3(2, 0, 0)},
                                                 std::tuple{"beside", 10.0f, Vec3(-15, 0, 0)}}) {
        StructureSpec s = sphereStructure(name, 3, radius, centre);
        s.referencePositions = s.initialPositions;
        sim->addStructure(std::move(s));
      }
      sim->addForce("shape_prior");
      ParamTable& t = sim->addForce("collision");
      t.setAll("weight", 0.5);
      t.setAll("ignore_enclosed", 1.0);
      sim->setIntegrator(integrator.toStdString()).set(0, "time_step", integrator == "implicit_euler" ? 2.0 : 0.5);
      sim->initialize();
      return sim;
    };
    // Without ignore_enclosed the device refuses the nested pair as the CPU does, naming both.
    {
      auto refused = nested();
      refused->forceParams("collision").setAll("ignore_enclosed", 0.0);
      cuda::CudaEngine e(*refused);
      try {
        e.run(1);
        QFAIL("a structure inside another was not refused on the device");
      } catch (const NumericalError& error) {
        QVERIFY(QString(error.what()).contains("structure 'inner' lies inside structure 'outer'"));
      }
    }
    auto nestedCpu = nested(), nestedGpu = nested(), nestedInit = nested();
    nestedCpu->setStabilityGuard(noGuard());
    nestedCpu->run(steps);
    cuda::CudaEngine nestedEngine(*nestedGpu);
    nestedEngine.run(steps);
    nestedEngine.download();
    const double nestedDiff = maxDifference(nestedCpu->store(), nestedGpu->store());
    const double nestedMoved = maxDifference(nestedCpu->store(), nestedInit->store());
    qInfo("nested pair left out, %s: max CPU-CUDA difference %.3g mm (vertices pushed up to %.3g mm)",
          qPrintable(integrator), nestedDiff, nestedMoved);
    QVERIFY(nestedMoved > 1.0);
    QVERIFY2(nestedDiff < (integrator == "implicit_euler" ? 1e-2 : 1e-3), qPrintable(QString::number(nestedDiff)));
    auto one = make(1, 0.5f), oneOff = make(1, 0.0f), two = make(2, 0.5f), twoOff = make(2, 0.0f);
    QCOMPARE(bytesAfter(*one), bytesAfter(*oneOff));
    QVERIFY(bytesAfter(*two) > bytesAfter(*twoOff));
  }

  // full_search_first on the device (DeviceCollision::searchesAt): two overlapping spheres, a full
  // search every 16 steps and at the first 6, 40 steps in batches of 32 and 8, captured per schedule
  // (DeviceCollision::schedule: the first batch's with the first steps, the second's without).
  void levelsFirstStepsSearchInFull() {
    const ParityRun r = runOnBoth(
        [] {
          auto sim = collidingSpheres(15.0f, 0.5f);
          sim->forceParams("collision").setAll("full_search_every", 16);
          sim->forceParams("collision").setAll("full_search_first", 6);
          return sim;
        },
        40);
    qInfo("every 16 steps and the first 6: max CPU-CUDA difference %.3g mm after 40 steps (vertices pushed up to %.3g mm)",
          r.cpuCuda, r.moved);
    QVERIFY(r.moved > 1.0);
    QVERIFY2(r.cpuCuda < 1e-3, qPrintable(QString::number(r.cpuCuda)));
    QCOMPARE(r.deviceRepeat, 0.0);
  }

  // After a guard's rollback on the device (Simulation::recover, then CudaEngine::restoreState, as
  // SceneRunner does) the next step searches in full, as the CPU's force does
  // (tst_collision_schedule::rollbackSearchesInFullAtOnce). Structure a must include a point 2 mm
  // inside b; the include point wins over the collision (a's cap ends about 2.25 mm past b's
  // surface), so the two stay in contact throughout. During the undone steps, whose full search
  // (step 32) sees them, the point is off. A device that kept that search's planes after the
  // rollback ended 0.092 mm from the CPU, which searches in full at once (H200, 2026-11-29).
  void rollbackSearchesInFullAtOnce() {
    auto make = [] {
      auto sim = std::make_unique<Simulation>(forceRegistry(), 0);
      addSpherePair(*sim, 21.0f);
      sim->addForce("shape_prior");
      sim->addForce("attraction_points");
      ParamTable& collision = sim->addForce("collision");
      collision.setAll("weight", 0.5);
      collision.setAll("full_search_every", 16);
      sim->scene().constraintPoints()[0] = {{Vec3(13, 0, 0), true}};
      sim->setIntegrator("damped_verlet").set(0, "time_step", 0.5);
      StabilityGuard guard = noGuard();  // the CPU takes the device's steps; recover halves the step once
      guard.maxRetries = 1;
      sim->setStabilityGuard(guard);
      sim->initialize();
      return sim;
    };
    // 28 steps, 7 undone with the point off, then 40: through `run` (the CPU, or the engine) and
    // `restore` (the engine's upload after the rollback).
    const auto rollBack = [](Simulation& sim, const std::function<void(int)>& run, const std::function<void()>& sync,
                             const std::function<void()>& restore) {
      run(28);
      sync();
      const std::vector<Vec3> good(sim.store().positions().begin(), sim.store().positions().end());
      std::vector<Vec3> goodPrevious(sim.store().previousPositions().begin(), sim.store().previousPositions().end());
      sim.forceParams("attraction_points").setAll("weight", 0.0);
      run(7);
      sim.forceParams("attraction_points").setAll("weight", 1.0);
      sim.recover(good, goodPrevious, "a rollback", 0);
      restore();
      run(40);
      sync();
    };
    auto cpu = make(), gpu = make();
    rollBack(*cpu, [&](int n) { cpu->run(n); }, [] {}, [] {});
    cuda::CudaEngine engine(*gpu);
    rollBack(*gpu, [&](int n) { engine.run(n); }, [&] { engine.download(); }, [&] { engine.restoreState(); });
    float front = -1e9f;  // a's cap along +x; b's surface is at x = 11 mm there
    for (Index v = gpu->store().range(0).vertexBegin; v < gpu->store().range(0).vertexEnd; ++v)
      front = std::max(front, gpu->store().positions()[v].x());
    const double cpuCuda = maxDifference(cpu->store(), gpu->store());
    qInfo("after a rollback: %.3g mm between the device and the CPU (a's cap at x = %.2f mm)", cpuCuda, double(front));
    QVERIFY(front > 10.5f);  // in contact with b
    QVERIFY2(cpuCuda < 1e-3, qPrintable(QString::number(cpuCuda)));
  }
};

QTEST_APPLESS_MAIN(TestCudaCollision)
#include "tst_cuda_collision.moc"
