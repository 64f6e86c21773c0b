// The collision force's full searches on a schedule (CPU): a full search every few steps separates
// and settles as every step does; how far a full search looks; between full searches a vertex meets
// the plane of its last deepest contact; the clearance skips searches without changing their
// result; a rollback makes the next step search in full.
#include "sinew/core/collision_tree.h"
#include "collision_scenes.h"

#include <QtTest>

#include <cmath>

using namespace sinew;
using namespace sinew::testing;

class TestCollisionSchedule : public QObject {
  Q_OBJECT
private slots:
  // A full search every 8 or 16 steps (sinew-make-scene writes 16 for up to 4 levels) (in between, each vertex meets
  // the plane of its deepest contact at the last full search) separates two overlapping spheres as
  // every step does, and they come to rest.
  void fullSearchEveryFewSteps() {
    for (int every : {1, 8, 16}) {
      auto sim = std::make_unique<Simulation>(forceRegistry(), 2);
      for (int i = 0; i < 2; ++i) {
        StructureSpec s = sphereStructure(i ? "b" : "a", 3, 10.0f, Vec3(15.0f * i, 0, 0));
        s.referencePositions = s.initialPositions;
        sim->addStructure(std::move(s));
      }
      sim->addForce("shape_prior");
      ParamTable& c = sim->addForce("collision");
      c.setAll("weight", 0.5);
      c.setAll("full_search_every", every);
      sim->setIntegrator("damped_verlet").set(0, "time_step", 0.5);
      sim->initialize();
      const double before = pairOverlap(*sim);
      sim->run(10);
      const double early = pairOverlap(*sim);
      const std::vector<double> steps = largestStepPerHundred(*sim, 3);
      qInfo("full search every %d: overlap %.1f -> %.2f after 10 steps -> %.2f mm^3; largest step in the last 100: %.4f mm",
            every, before, early, pairOverlap(*sim), steps.back());
      QVERIFY(early < 1.0);
      QVERIFY(pairOverlap(*sim) < 1.0);
      QVERIFY(steps.back() < 0.01);
    }
  }
  // full_search_first: a level's first steps search in full besides the schedule. Every 16 steps
  // with the first 4 in full runs those 4 as a search every step does; without them, steps 1-3 meet
  // step 0's planes and end elsewhere. Rollbacks do not count (CollisionForce::restored).
  void levelsFirstStepsSearchInFull() {
    const auto positionsAfter = [](int every, int first, int steps) {
      auto sim = collidingSpheres(15.0f, 0.5f);
      sim->forceParams("collision").setAll("full_search_every", every);
      sim->forceParams("collision").setAll("full_search_first", first);
      sim->run(steps);
      return std::vector<Vec3>(sim->store().positions().begin(), sim->store().positions().end());
    };
    const auto largestGap = [](const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
      double gap = 0.0;
      for (size_t i = 0; i < a.size(); ++i) gap = std::max(gap, double((a[i] - b[i]).norm()));
      return gap;
    };
    const auto everyStep = positionsAfter(1, 0, 4);
    const double first = largestGap(positionsAfter(16, 4, 4), everyStep);
    const double planes = largestGap(positionsAfter(16, 0, 4), everyStep);
    qInfo("after 4 steps, from a search every step: %.3g mm with the first 4 in full, %.3g mm without", first, planes);
    QVERIFY(first < 1e-6);
    QVERIFY(planes > 1e-3);
  }
  // How far a full search looks (collision::fullSearchBound): its last depth, the margin, the
  // reach and twice its last step, as every step; with full searches every few steps twice that
  // step again for each further step until the next one, but at most ahead_mm more (the trembling
  // light vertices' long steps would otherwise have them search several millimetres around).
  void fullSearchLooksAheadAtMostAheadMm() {
    collision::ContactSettings s;
    s.margin = 0.15f;
    s.reach = 0.25f;
    s.ahead = 0.5f;
    const collision::P3 previous{0, 0, 0}, slow{0.01f, 0, 0}, fast{1.0f, 0, 0};
    const auto radius = [&](int every, collision::P3 p) { return std::sqrt(collision::fullSearchBound(0.1f, s, every, p, previous)); };
    QVERIFY(std::abs(radius(1, fast) - (0.5f + 2.0f)) < 1e-5f);                // every step: no look ahead
    QVERIFY(std::abs(radius(16, slow) - (0.5f + 0.02f + 15 * 0.02f)) < 1e-5f);  // within the bound
    QVERIFY(std::abs(radius(16, fast) - (0.5f + 2.0f + 0.5f)) < 1e-5f);         // held to it
    QCOMPARE(collision::fullSearchBound(collision::kUnknownDepth, s, 16, fast, previous), 3.0e38f);
    // The force's settings carry the parameter (default 0.5 mm).
    auto sim = collidingSpheres(25.0f, 0.5f);
    ParamTable& t = sim->forceParams("collision");
    QCOMPARE(contactSettingsOf(t).ahead, 0.5f);
    t.setAll("ahead_mm", 0.25);
    QCOMPARE(contactSettingsOf(t).ahead, 0.25f);
  }
  // Between full searches a vertex meets the plane of its deepest contact at the last full search:
  // slid along that plane its pull stays the plane's (a new search would turn it with the sphere),
  // the plane moves with the other surface, and a full search's skip (the vertex clear of every
  // other structure) leaves it no plane.
  void betweenFullSearchesTheContactPlaneResponds() {
    auto sim = collidingSpheres(15.0f, 0.5f);
    MeshStore& store = sim->store();
    CollisionTree tree = CollisionTree::build(store);
    tree.refit(store.positions(), store.cellCentres(), store.executor());
    const collision::ContactSettings settings{0.25f, 0.0f, 0.25f, 0.25f};
    const collision::BvhView view = tree.view();
    const collision::P3* x = asP3(store.positions());
    const collision::P3* c = asP3(store.cellCentres());
    const collision::P3* normals = asP3(store.normals());
    Index v = 0;  // sphere a's vertex farthest into b, on the line of the centres
    for (Index i = 0; i < store.vertexCount(); ++i)
      if (store.meshOfVertex()[i] == 0 && x[i].x > x[v].x) v = i;
    float depth = collision::kUnknownDepth, slack = 0.0f;
    int hint = -1;
    collision::ContactPlane plane;
    collision::P3 first{0, 0, 0};
    collision::contactResponse(view, 0, x[v], x[v], normals[v], 1.0f, settings, true, 8, 0.0f, 0.0f, depth, hint, slack, plane,
                               x, c, first);
    QVERIFY(plane.share >= 0.0f && depth > 4.0f);  // 5 mm inside b
    const collision::Hit found = collision::contactHit(plane, x[v], x, c);
    QVERIFY(found.normal.x < -0.95f);  // b's surface there faces -x
    QVERIFY(std::abs(found.side + depth - settings.margin) < 1e-4f);  // the contact the search found
    const collision::P3 slid{x[v].x, x[v].y + 3.0f, x[v].z};  // 3 mm along the plane
    collision::P3 force{0, 0, 0};
    const float stiffness = collision::contactResponse(view, 0, slid, slid, normals[v], 1.0f, settings, false, 8, 0.0f, 0.0f,
                                                       depth, hint, slack, plane, x, c, force);
    const float side = found.side + 3.0f * found.normal.y;  // the plane's, not the sphere's
    const float pull = plane.share * (settings.margin - side);  // along the plane's normal
    QCOMPARE(stiffness, plane.share);
    QVERIFY(std::abs(force.x - pull * found.normal.x) < 1e-4f && std::abs(force.y - pull * found.normal.y) < 1e-4f &&
            std::abs(force.z - pull * found.normal.z) < 1e-4f);
    QVERIFY(std::abs(depth - (settings.margin - side)) < 1e-4f);
    // The plane moves with b: b moved 1 mm along -x, the same vertex is 1 mm deeper.
    const collision::P3 at = x[v];
    auto moving = store.positionsForWrite();
    for (Index i = 0; i < store.vertexCount(); ++i)
      if (store.meshOfVertex()[i] == 1) moving[i] += Vec3(-1.0f, 0.0f, 0.0f);
    const collision::Hit moved = collision::contactHit(plane, at, asP3(store.positions()), asP3(store.cellCentres()));
    QVERIFY(std::abs(moved.side - (found.side + found.normal.x)) < 1e-3f);
    // Clear of every structure (no depth, slack left): a full search's skip drops the plane, and
    // without it a step between full searches adds nothing.
    depth = 0.0f;
    slack = 10.0f;
    collision::P3 none{0, 0, 0};
    QCOMPARE(collision::contactResponse(view, 0, slid, slid, normals[v], 1.0f, settings, true, 8, 0.0f, 0.0f, depth, hint, slack,
                                        plane, x, c, none), 0.0f);
    QVERIFY(plane.share < 0.0f);
    QCOMPARE(collision::contactResponse(view, 0, slid, slid, normals[v], 1.0f, settings, false, 8, 0.0f, 0.0f, depth, hint, slack,
                                        plane, x, c, none), 0.0f);
    QVERIFY(none.x == 0.0f && none.y == 0.0f && none.z == 0.0f);
  }

  // The clearance (collision::clearOfContacts) skips searches without changing their result: two
  // spheres driven into each other (one 0.1 mm a step, the other wobbling), every vertex's response
  // with the clearance kept against the same response searching every step.
  void clearanceSkipsSearchesWithoutChangingTheirResult() {
    auto sim = collidingSpheres(21.0f, 1.0f);  // 1 mm apart
    MeshStore& store = sim->store();
    CollisionTree tree = CollisionTree::build(store);
    const collision::ContactSettings settings{0.25f, 0.0f, 0.25f, 0.25f};
    const Index n = store.vertexCount();
    const auto meshOf = store.meshOfVertex();
    std::vector<float> depthKept(n, collision::kUnknownDepth), depthEvery(n, collision::kUnknownDepth);
    std::vector<float> slack(n, 0.0f), moved(n, 0.0f);
    std::vector<int> hintKept(n, -1), hintEvery(n, -1);
    std::vector<collision::ContactPlane> planeKept(n), planeEvery(n);
    std::vector<Vec3> last(store.positions().begin(), store.positions().end());
    long skipped = 0, searched = 0, touching = 0;
    for (int step = 0; step < 40; ++step) {
      const auto x = store.positionsForWrite();
      for (Index v = 0; v < n; ++v)
        x[v] += meshOf[v] == 1 ? Vec3(-0.1f, 0.0f, 0.0f) : Vec3(0.0f, 0.03f * std::sin(0.7f * float(step + v)), 0.0f);
      tree.refit(store.positions(), store.cellCentres(), store.executor());
      float motion = 0.0f;
      for (Index v = 0; v < n; ++v) motion = std::max(motion, moved[v] = (store.positions()[v] - last[v]).norm());
      const collision::BvhView view = tree.view();
      const collision::P3* p = asP3(store.positions());
      const collision::P3* c = asP3(store.cellCentres());
      const collision::P3* normals = asP3(store.normals());
      for (Index v = 0; v < n; ++v) {
        float probe = slack[v];  // what contactResponse will decide, on a copy
        const bool clear = collision::clearOfContacts(depthKept[v], moved[v], motion, probe);
        collision::P3 kept{0, 0, 0}, every{0, 0, 0};
        const float kKept = collision::contactResponse(view, int(meshOf[v]), p[v], asP3(last[v]), normals[v], 1.0f, settings, true, 1,
                                                       moved[v], motion, depthKept[v], hintKept[v], slack[v], planeKept[v], p, c, kept);
        float never = -1.0f;  // no slack: searches every step
        const float kEvery = collision::contactResponse(view, int(meshOf[v]), p[v], asP3(last[v]), normals[v], 1.0f, settings, true,
                                                        1, moved[v], motion, depthEvery[v], hintEvery[v], never, planeEvery[v], p, c,
                                                        every);
        // The same contacts. Where triangles tie for the closest point (an edge, a corner), which one
        // gives the normal depends on the leaf a search starts from (the kept hint is older when a
        // search was skipped): 1e-3 mm covers that, and a wrong skip is off by a whole pull.
        QCOMPARE(kKept, kEvery);
        QVERIFY(std::abs(depthKept[v] - depthEvery[v]) <= 1e-3f);
        QVERIFY(std::abs(kept.x - every.x) <= 1e-3f && std::abs(kept.y - every.y) <= 1e-3f && std::abs(kept.z - every.z) <= 1e-3f);
        (clear ? skipped : searched) += 1;
        touching += kEvery > 0.0f;
      }
      std::copy(store.positions().begin(), store.positions().end(), last.begin());
    }
    qInfo("%ld of %ld responses skipped their search; %ld touching", skipped, skipped + searched, touching);
    QVERIFY(skipped > (skipped + searched) / 2);  // the spheres' far sides never search
    QVERIFY(touching > 1000);                     // and the driven contact was found all along
  }

  // After a guard's rollback (Simulation::recover) the collision's next step searches in full. b was
  // 5 mm away during the undone steps, so their full search (step 32) found no contact: kept, its
  // planes let a's pressed cap sink into b for 12 steps (0.43 mm, CollisionForce::restored undone).
  void rollbackSearchesInFullAtOnce() {
    auto sim = pressedCap(10.0f, Vec3(0, 0, 0), 10.0f, Vec3(17.0f, 0, 0), 0.1, 0);
    sim->forceParams("collision").setAll("full_search_every", 16);
    sim->forceParams("press").set(0, "weight", 0.5);
    sim->run(29);
    MeshStore& store = sim->store();
    const std::vector<Vec3> good(store.positions().begin(), store.positions().end());
    std::vector<Vec3> goodPrevious(store.previousPositions().begin(), store.previousPositions().end());
    const double before = deepestInside(*sim, 0, 1);
    for (Index v = store.range(1).vertexBegin; v < store.range(1).vertexEnd; ++v)
      for (Vec3* p : {&store.positionsForWrite()[v], &store.previousPositions()[v]}) *p += Vec3(5, 0, 0);
    sim->run(6);  // undone below, a full search among them
    sim->recover(good, goodPrevious, "a rollback", 0);
    double deepest = 0.0;
    for (int step = 0; step < 12; ++step) {
      sim->step();
      deepest = std::max(deepest, deepestInside(*sim, 0, 1));
    }
    qInfo("a's cap in b: %.3f mm before, at most %.3f mm in the 12 steps after the rollback", before, deepest);
    QVERIFY(deepest < before + 0.01);
  }
};

QTEST_GUILESS_MAIN(TestCollisionSchedule)
#include "tst_collision_schedule.moc"
