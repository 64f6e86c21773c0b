// The collision force (CPU): two overlapping spheres are pushed apart and come to rest without
// gaining energy, a one-structure scene is left alone and allocates nothing for it, a sphere half
// inside another is pushed out, and a sphere inside another (or on it) stops the run with the reason;
// a vertex pressed into another structure is held out by the hold; a contact is shared by the
// structures' sizes, unless the other side has no vertex in it, and with the reaction the other side
// is pushed back by the rest; deforming contacts keep the
// reference proximity. The full searches' schedule: tst_collision_schedule.
#include "sinew/core/shape_guard.h"
#include "sinew/core/collision_tree.h"
#include "sinew/core/contact_links.h"
#include "sinew/core/voxelize.h"
#include "collision_scenes.h"

#include <QtTest>

using namespace sinew;
using namespace sinew::testing;

class TestCollision : public QObject {
  Q_OBJECT
private slots:
  // The union of boxes, either of which may be empty: the device's refit unites partial unions,
  // some of them empty. (Extending a box by an empty one's corners, +-3e38, made every structure's
  // root box infinite on the device: the same contacts, twice the search time.)
  void boxUnionKeepsEmptyBoxesNeutral() {
    const collision::Box a{{-1.0f, 2.0f, 3.0f}, {4.0f, 5.0f, 6.5f}}, b{{0.5f, -7.0f, 3.5f}, {8.0f, 1.0f, 4.0f}};
    const collision::Box empty = collision::emptyBox();
    auto same = [](const collision::Box& x, const collision::Box& y) {
      return x.lo.x == y.lo.x && x.lo.y == y.lo.y && x.lo.z == y.lo.z && x.hi.x == y.hi.x && x.hi.y == y.hi.y && x.hi.z == y.hi.z;
    };
    QVERIFY(same(collision::merge(a, empty), a));
    QVERIFY(same(collision::merge(empty, a), a));
    QVERIFY(same(collision::merge(empty, empty), empty));
    const collision::Box u = collision::merge(a, b);
    QVERIFY(same(u, collision::Box{{-1.0f, -7.0f, 3.0f}, {8.0f, 5.0f, 6.5f}}));
    QVERIFY(same(collision::merge(b, a), u));
  }
  void overlappingSpheresSeparateAndRest() {
    auto with = collidingSpheres(15.0f, 0.5f), without = collidingSpheres(15.0f, 0.0f);
    const double before = pairOverlap(*with);
    // The largest per-step motion over each block of 100 steps: the push apart, then what remains.
    const std::vector<double> blocks = largestStepPerHundred(*with, 6);
    without->run(600);
    const double after = pairOverlap(*with), control = pairOverlap(*without);
    qInfo("two spheres: overlap %.1f -> %.2f mm^3 (without the force %.1f); largest step per 100 steps: %.3g %.3g %.3g "
          "%.3g %.3g %.3g mm", before, after, control, blocks[0], blocks[1], blocks[2], blocks[3], blocks[4], blocks[5]);
    QVERIFY(before > 300.0 && control > 0.9 * before);
    QVERIFY(after < 0.01 * before);
    // No energy is gained: after the push the motion stays a small fraction of it, below 0.015 mm a
    // step (contacts switching on and off leave a tremble of some micrometres; docs/collisions.md).
    for (size_t b = 2; b < blocks.size(); ++b) QVERIFY2(blocks[b] < 0.015 && blocks[b] < 0.05 * blocks[0], qPrintable(QString::number(blocks[b])));
  }

  void oneStructureIsLeftAlone() {
    auto make = [](bool collision) {
      auto sim = std::make_unique<Simulation>(forceRegistry(), 2);
      StructureSpec s = sphereStructure("a", 3, 10.0f, Vec3(0, 0, 0));
      s.referencePositions = withNoise(s.initialPositions, 0.3f, 2);
      sim->addStructure(std::move(s));
      sim->addForce("shape_prior");
      if (collision) sim->addForce("collision");
      sim->setIntegrator("damped_verlet");
      sim->initialize();
      sim->run(20);
      return sim;
    };
    auto sim = make(true), plain = make(false);
    for (Index v = 0; v < sim->store().vertexCount(); ++v)
      QCOMPARE(sim->store().positions()[v], plain->store().positions()[v]);
  }

  // A small sphere inside a large one, and two copies of one sphere: no contact response can
  // separate them, so the first step stops with the reason, naming both, and moves nothing.
  void enclosedOrCoincidentStructuresStopWithTheReason() {
    for (const auto& [gap, radius, label] : {std::tuple{2.0f, 4.0f, "inside"}, std::tuple{0.0f, 10.0f, "coincident"}}) {
      auto sim = collidingSpheres(gap, 0.5f, radius);
      const std::vector<Vec3> before(sim->store().positions().begin(), sim->store().positions().end());
      try {
        sim->step();
        QFAIL(qPrintable(QString("%1: no stop").arg(label)));
      } catch (const NumericalError& e) {
        qInfo("%s: %s", label, e.what());
        const QString what(e.what());
        QVERIFY(what.contains("structure 'b' lies inside structure 'a'") || what.contains("structure 'a' lies inside structure 'b'"));
        QVERIFY(what.contains("427 of 427 of its vertices"));  // every third of 1,280
        QVERIFY(what.contains("ignore_enclosed"));
      }
      for (Index v = 0; v < sim->store().vertexCount(); ++v) QCOMPARE(sim->store().positions()[v], before[v]);
    }
  }

  // Nested by design (ignore_enclosed 1): the pair is left out of the collisions, nothing stops,
  // and the small sphere stays where it is inside the large one.
  void enclosedStructuresCanBeLeftOut() {
    auto sim = collidingSpheres(2.0f, 0.5f, 4.0f);
    sim->forceParams("collision").setAll("ignore_enclosed", 1.0);
    const double before = pairOverlap(*sim);
    sim->run(100);
    for (const Vec3& p : sim->store().positions()) QVERIFY(p.allFinite());
    const double after = pairOverlap(*sim);
    qInfo("nested spheres left out of collisions: overlap %.1f -> %.1f mm^3", before, after);
    QVERIFY(before > 200.0);
    QVERIFY(std::abs(after - before) < 0.05 * before);
  }

  // The stability suite's collision cases: stiff contacts (weight 1) with the default step, with a
  // step four times as long, and with implicit Euler at a long step. Each ends finite with the
  // overlap resolved, or stops cleanly through the stability guard; the default step and implicit
  // Euler also come to rest. The explicit long step does not here: after the step guard halves it
  // once, the contact and the shape prior together overshoot and keep the surfaces swinging by a
  // millimetre or two a step. Through sinew-run the shape guard's swing check sees that and halves
  // the step again (swingingContactsHalveTheStepUntilTheyRest, below).
  void stiffContactsAndLongStepsConvergeOrStopCleanly_data() {
    QTest::addColumn<QString>("integrator");
    QTest::addColumn<double>("timeStep");
    QTest::addColumn<bool>("comesToRest");
    QTest::newRow("verlet, dt 0.5") << "damped_verlet" << 0.5 << true;
    QTest::newRow("verlet, dt 2") << "damped_verlet" << 2.0 << false;
    QTest::newRow("implicit Euler, dt 5") << "implicit_euler" << 5.0 << true;
  }
  void stiffContactsAndLongStepsConvergeOrStopCleanly() {
    QFETCH(QString, integrator);
    QFETCH(double, timeStep);
    QFETCH(bool, comesToRest);
    auto sim = collidingSpheres(15.0f, 1.0f, 10.0f, integrator.toStdString(), timeStep);
    const double before = pairOverlap(*sim);
    try {
      const std::vector<double> blocks = largestStepPerHundred(*sim, 6);
      for (const Vec3& p : sim->store().positions()) QVERIFY(p.allFinite());
      const double after = pairOverlap(*sim);
      qInfo("%s, dt %g: ran 600 steps; overlap %.1f -> %.2f mm^3, largest step in the last 100 steps %.3g mm, %d "
            "stability events", qPrintable(integrator), timeStep, before, after, blocks.back(),
            int(sim->stabilityEvents().size()));
      QVERIFY(after < 0.01 * before);
      if (comesToRest) QVERIFY(blocks.back() < 0.015);
    } catch (const NumericalError& e) {
      for (const Vec3& p : sim->store().positions()) QVERIFY(p.allFinite());
      qInfo("%s, dt %g: stopped cleanly: %s", qPrintable(integrator), timeStep, e.what());
    }
  }

  // The dt 2 case above under the runner's shape guard (SceneRunner::runShapeGuarded: chunks of 10
  // steps, each checked and, on a violation, undone with the step halved): with a full search every
  // step the swing check sees the surfaces swinging; with a full search every 8 steps (contact planes
  // between) the shape check sees cells turned over first. Either way the halved step lets them
  // come to rest.
  void swingingContactsHalveTheStepUntilTheyRest_data() {
    QTest::addColumn<int>("every");
    QTest::newRow("full search every step") << 1;
    QTest::newRow("every 8 steps") << 8;
    QTest::newRow("every 16 steps (sinew-make-scene's)") << 16;
  }
  void swingingContactsHalveTheStepUntilTheyRest() {
    QFETCH(int, every);
    auto sim = collidingSpheres(15.0f, 1.0f, 10.0f, "damped_verlet", 2.0);
    sim->forceParams("collision").setAll("full_search_every", every);
    const double before = pairOverlap(*sim);
    ImageGeometry image;
    image.size = {200, 200, 200};
    image.origin = Eigen::Vector3d(-100, -100, -100);
    ShapeGuard guard;
    guard.capture(sim->store(), image);
    const std::vector<std::string> names{"a", "b"};
    int swings = 0;
    double largest = 0.0;
    for (int chunk = 0; chunk < 100; ++chunk) {
      const std::vector<Vec3> start(sim->store().positions().begin(), sim->store().positions().end());
      std::vector<Vec3> startPrevious(sim->store().previousPositions().begin(), sim->store().previousPositions().end());
      for (int attempt = 0;; ++attempt) {
        largest = 0.0;
        for (int i = 0; i < 10; ++i) {
          sim->step();
          largest = std::max(largest, largestStep(*sim));
        }
        const std::string problem = guard.check(sim->store(), image, ShapeLimits{}, names, start);
        if (problem.empty()) break;
        QVERIFY2(problem.find("swings") != std::string::npos || (every > 1 && problem.find("turned over") != std::string::npos),
                 problem.c_str());
        ++swings;
        sim->recover(start, startPrevious, problem, attempt);
      }
    }
    for (const Vec3& p : sim->store().positions()) QVERIFY(p.allFinite());
    const double after = pairOverlap(*sim);
    qInfo("verlet, dt 2, a full search every %d: %d violations seen, time step %g at the end, overlap %.1f -> %.2f mm^3, "
          "largest step in the last 10 steps %.3g mm", every, swings, sim->stabilityEvents().back().timeStep, before, after, largest);
    QVERIFY(swings >= 1);
    QVERIFY(after < 0.01 * before);
    QVERIFY(largest < 0.015);
  }

  // Half of a small sphere inside a large one: it is pushed out and comes to rest against it. (Only
  // the shape prior holds the spheres, and it keeps no size: pressed long enough, with no image
  // force to hold it, the small one shrinks until its light vertices tremble; docs/collisions.md.)
  void sphereHalfInsideAnotherIsPushedOut() {
    auto sim = collidingSpheres(10.0f, 0.5f, 4.0f);
    const double before = pairOverlap(*sim);
    const std::vector<double> blocks = largestStepPerHundred(*sim, 8);
    for (const Vec3& p : sim->store().positions()) QVERIFY(p.allFinite());
    const double after = pairOverlap(*sim);
    qInfo("sphere half inside another: overlap %.1f -> %.2f mm^3; largest step per 100 steps: %.3g %.3g %.3g %.3g %.3g "
          "%.3g %.3g %.3g mm", before, after, blocks[0], blocks[1], blocks[2], blocks[3], blocks[4], blocks[5], blocks[6],
          blocks[7]);
    QVERIFY(before > 50.0);
    QVERIFY(after < 0.02 * before);
    for (size_t b = 2; b < blocks.size(); ++b) QVERIFY2(blocks[b] < 0.015 && blocks[b] < 0.05 * blocks[0], qPrintable(QString::number(blocks[b])));
    QVERIFY(sim->stabilityEvents().empty());
  }

  // Two spheres overlapping by more than half their radius (centres 8 mm apart, radius 10): every
  // vertex inside the other sphere has that sphere's far side as its nearest surface, whose normal
  // faces the way of its own. Pulled to that nearest point, each sphere's cap is pushed on through
  // the other: the overlap grows (as Caudate_L/Putamen_L on demo seed 6, docs/collisions.md).
  // Moving back into their own structure instead, the caps separate.
  void deepOverlapRetreatsInsteadOfPassingThrough() {
    auto sim = collidingSpheres(8.0f, 1.0f);
    const double before = pairOverlap(*sim);
    const std::vector<double> blocks = largestStepPerHundred(*sim, 6);
    for (const Vec3& p : sim->store().positions()) QVERIFY(p.allFinite());
    const double after = pairOverlap(*sim);
    qInfo("deep overlap: %.1f -> %.2f mm^3; largest step per 100 steps: %.3g %.3g %.3g %.3g %.3g %.3g mm", before, after,
          blocks[0], blocks[1], blocks[2], blocks[3], blocks[4], blocks[5]);
    QVERIFY(before > 1500.0);
    QVERIFY(after < 0.01 * before);
    QVERIFY(sim->stabilityEvents().empty());
  }

  // The cap of sphere a pressed into sphere b (which does not respond: weight 0) by a constant force,
  // as an image force can hold a boundary inside another structure. The contact's pull is a spring,
  // so without the hold the cap settles where the spring balances the press, inside b; with it
  // (hold_mm 0; the default holds 0.1 mm out) every touching vertex is moved back to its contact's
  // plane after each step, and the overlap is gone.
  void holdKeepsPressedVerticesOut() {
    const auto run = [](double hold) {
      auto sim = pressedCap(10.0f, Vec3(0, 0, 0), 10.0f, Vec3(20.5f, 0, 0), hold);
      for (const Vec3& p : sim->store().positions()) [&] { QVERIFY(p.allFinite()); }();
      return std::pair{pairOverlap(*sim), deepestInside(*sim, 0, 1)};
    };
    const auto [withoutOverlap, withoutDepth] = run(-1.0);
    const auto [heldOverlap, heldDepth] = run(0.0);
    qInfo("pressed spheres: without the hold %.2f mm^3, deepest vertex %.3f mm inside; with it %.2f mm^3, %.3f mm",
          withoutOverlap, withoutDepth, heldOverlap, heldDepth);
    // What the hold leaves is the faces' sag between held vertices (the cell centres of a cap lying
    // on a sphere fall inside it), not vertices.
    QVERIFY(withoutDepth > 0.1);
    QVERIFY(heldDepth < 0.01);
    QVERIFY(heldOverlap < 0.5 * withoutOverlap);
  }

  // hold_step: the hold moves a vertex at most hold_step times its spacing (the square root of its
  // area) in one step, so that a deep contact is left over several steps (at 1.3 M vertices the
  // jumps folded surfaces into themselves; docs/collisions.md, "The hold's step").
  void holdStepLimitsEachStepsHold() {
    // The plane and the hold themselves: 1 mm inside, held to 0.1 mm outside, 0.2 of a spacing of 0.5.
    collision::ContactSettings s;
    s.margin = 0.15f;
    s.hold = 0.1f;
    const collision::Hit inside{1.0f, {0, 0, 0}, {1, 0, 0}, -1.0f, -1, -1};
    const collision::P3 p{-1, 0, 0}, ownNormal{-1, 0, 0};
    const auto heldTo = [&](float holdStep) {
      s.holdStep = holdStep;
      float deepest = 0.0f;
      collision::P3 force{0, 0, 0}, x = p, previous = p;
      collision::HoldPlane plane;
      collision::respondTo(inside, p, p, ownNormal, 1.0f, s, deepest, force, &plane, 1.0f);
      const float area = 0.25f;  // a spacing of 0.5
      collision::holdOut(plane, x, previous, collision::holdLimit(s, &area, 0));
      return x.x;
    };
    QCOMPARE(heldTo(3.0e38f), 0.1f);  // no limit: onto the plane at once
    QCOMPARE(heldTo(0.2f), -0.9f);    // 0.2 x 0.5 mm
    // In a step of two spheres 5 mm into each other: each vertex ends at most 0.05 of its spacing
    // from where the same step without the hold leaves it, and some at that limit; without the
    // limit the hold moves vertices over ten times as far.
    const auto stepWith = [](double hold, double holdStep) {
      auto sim = collidingSpheres(15.0f, 0.5f);
      sim->forceParams("collision").setAll("hold_mm", hold);
      sim->forceParams("collision").setAll("hold_step", holdStep);
      sim->step();
      return sim;
    };
    auto start = collidingSpheres(15.0f, 0.5f);
    const std::vector<float> area(start->store().areas().begin(), start->store().areas().end());
    auto free = stepWith(-1.0, 0.0), limited = stepWith(0.0, 0.05), unlimited = stepWith(0.0, 0.0);
    double limitedMost = 0.0, unlimitedMost = 0.0;
    for (Index v = 0; v < free->store().vertexCount(); ++v) {
      const double spacing = std::sqrt(double(area[v]));
      const Vec3 x = free->store().positions()[v];
      limitedMost = std::max(limitedMost, double((limited->store().positions()[v] - x).norm()) / spacing);
      unlimitedMost = std::max(unlimitedMost, double((unlimited->store().positions()[v] - x).norm()) / spacing);
    }
    qInfo("the hold's largest move in a step, in spacings: %.4f with hold_step 0.05, %.3f without", limitedMost, unlimitedMost);
    QVERIFY(limitedMost <= 0.05 * (1.0 + 1e-3));
    QVERIFY(limitedMost > 0.045);
    QVERIFY(unlimitedMost > 0.5);
  }

  // size_share: a sphere of radius 5 mm overlapping one of 10 mm by 1 mm. With the default (2) the
  // small one takes min(1, 2 / (1 + 16)) of each contact's correction and the large one all of it,
  // so the large one gives way more; with 0 both take all, and the small one moves more. How far
  // each gives way: how far its nearest vertex to the other retreats along x. Either way they part.
  void largerStructureGivesWayMore() {
    const auto run = [](double share) {
      auto sim = collidingSpheres(14.0f, 0.5f, 5.0f, "damped_verlet", 0.5, share);
      const auto facing = [&](Index m, float sign) { return reachAlongX(*sim, m, sign); };
      const double before = pairOverlap(*sim), a0 = facing(0, 1.0f), b0 = facing(1, -1.0f);
      sim->run(300);
      for (const Vec3& p : sim->store().positions()) [&] { QVERIFY(p.allFinite()); }();
      return std::tuple{before, pairOverlap(*sim), a0 - facing(0, 1.0f), b0 - facing(1, -1.0f)};
    };
    const auto [before, sharedAfter, sharedLarge, sharedSmall] = run(2.0);
    const auto [before0, equalAfter, equalLarge, equalSmall] = run(0.0);
    qInfo("10 and 5 mm spheres overlapping by %.1f mm^3: size_share 2 -> %.2f mm^3, the large one gave way %.3f mm, "
          "the small one %.3f; size_share 0 -> %.2f mm^3, %.3f and %.3f mm",
          before, sharedAfter, sharedLarge, sharedSmall, equalAfter, equalLarge, equalSmall);
    QVERIFY(before > 5.0);
    QVERIFY(sharedAfter < 0.05 * before && equalAfter < 0.05 * before);
    // Measured: 0.70 / 0.24 mm with the share, 0.30 / 0.74 mm without (the shape priors pull each
    // dent back, so the small one still gives a little way against the large one's push).
    QVERIFY(sharedSmall < 0.6 * sharedLarge);
    QVERIFY(equalSmall > 1.5 * equalLarge);
  }

  // A small sphere's cap pressed into a large one that does not respond (weight 0), as in
  // holdKeepsPressedVerticesOut: the small one then takes all of each correction, not its share by
  // size (2/17), and the hold keeps its vertices out.
  void structureThatDoesNotRespondLeavesAllToTheOther() {
    auto sim = pressedCap(5.0f, Vec3(3.5f, 0, 0), 10.0f, Vec3(18.4f, 0, 0), 0.1);
    for (const Vec3& p : sim->store().positions()) [&] { QVERIFY(p.allFinite()); }();
    const double depth = deepestInside(*sim, 0, 1);
    qInfo("small sphere pressed into a large one weighted 0: deepest vertex %.3f mm inside", depth);
    QVERIFY(depth < 0.01);
  }

  // A contact on one side only: a small sphere's cap pressed into the middle of a cell of a large,
  // coarse one. None of the large one's vertices touches the small one, so the large one does not
  // give way; by size the small one takes 2 x 5^4 / (5^4 + 30^4) of each correction (0.1 %) and
  // would rest deep inside. collision::shareAt gives it all of the correction there.
  // The same with the reaction (reaction 2, sinew-make-scene's): the rule for one-sided contacts
  // holds with it. (Without that rule, the share by size and the reaction alone, the small one
  // rested 0.407 mm inside: the coarse cell's push spread over its far vertices, held by its shape.)
  void oneSidedContactIsTakenWhole() {
    for (double reaction : {0.0, 2.0}) {
      auto sim = pressedIntoCell(400, reaction);
      for (const Vec3& p : sim->store().positions()) [&] { QVERIFY(p.allFinite()); }();
      const double depth = deepestInside(*sim, 0, 1);
      qInfo("small sphere pressed into a cell of a large, coarse one, reaction %g: deepest vertex %.3f mm inside", reaction,
            depth);
      QVERIFY(depth < 0.01);
    }
  }

  // Between those two: the other side's vertices are inside too, but less deep than this vertex.
  // The pair parts by this vertex's share of its depth plus what the other side takes of its own, so
  // the vertex takes at least the rest (collision::shareAt). Structure 0 takes 0.1 against
  // structure 1, which takes all; triangle 0 of structure 1 has vertices 0 and 1; the margin is
  // 0.15 mm, so a depth below it of 0.15 is on the surface. The vertex is 0.8 mm inside.
  void shareCoversWhatTheOtherSideDoesNotTake() {
    const float share[4] = {1.0f, 0.1f, 1.0f, 1.0f};
    const collision::Tri tris[1] = {{0, 1, 0}};
    float depths[2] = {0.0f, 0.0f};
    collision::BvhView v;
    v.meshes = 2, v.share = share, v.tris = tris, v.lastDepth = depths;
    const auto at = [&](float a, float b, float side = -0.8f, int own = 0) {
      depths[0] = a, depths[1] = b;
      return double(collision::shareAt(v, own, 1 - own, 0, side, 0.15f));
    };
    const auto near = [](double a, double b) { return std::abs(a - b) < 1e-6; };
    QCOMPARE(at(0.0f, 0.0f), 1.0);                 // one-sided: all of it
    QCOMPARE(at(0.1f, 0.15f), 1.0);                // theirs within the margin, none inside: the same
    QVERIFY(near(at(0.95f, 0.95f), 0.1));          // as deep as this vertex: its share by size
    QVERIFY(near(at(3.0f, 2.0f), 0.1));            // deeper: no less than that share
    QVERIFY(near(at(0.35f, 0.35f), 0.75));         // a quarter as deep inside: the other three quarters
    QVERIFY(near(at(0.55f, 0.15f), 0.75));         // by their mean
    QCOMPARE(at(0.0f, 0.0f, 0.05f), 1.0);          // one-sided, this vertex within the margin: all of it
    QVERIFY(near(at(0.1f, 0.15f, 0.05f), 0.1));    // theirs touching, this one within the margin: by size
    QCOMPARE(at(0.0f, 0.0f, -0.8f, 1), 1.0);       // the larger structure takes all anyway
    v.reacts = true;                               // the reaction moves the other side where it touched:
    QCOMPARE(at(0.0f, 0.0f), 1.0);                 //   one-sided, still all of it
    QVERIFY(near(at(0.35f, 0.35f), 0.1));          //   otherwise by size
    v.reacts = false;
    v.lastDepth = nullptr;                         // without the depths: by size
    QVERIFY(near(at(0.0f, 0.0f), 0.1));
  }

  // The reaction's push (collision::reactionPush): a vertex 0.5 mm inside a triangle in the plane
  // z = 0 (outward normal +z), margin 0.15 mm, taking a tenth of the correction, gain 2: the
  // triangle's vertices are pushed the other way by 2 x 0.9 of the way to the margin, split by
  // the contact point's weights (reactionPart sums to 1). None where the vertex is outside, takes
  // all of it, or faces the way of the contact (the retreat), or with no gain.
  void reactionPushesTheContactTriangleBack() {
    const collision::P3 x[2] = {{1, 0, 0}, {0, 1, 0}}, centres[1] = {{0, 0, 0}};
    const collision::ContactPlane k{{0, 0, 1}, {0, 1, 0}, 0.2f, 0.3f, 0.1f};
    collision::ContactSettings settings;
    settings.margin = 0.15f;
    settings.reaction = 2.0f;
    const collision::P3 down{0, 0, -1}, up{0, 0, 1};
    collision::P3 push{0, 0, 0};
    QVERIFY(collision::reactionPush(k, {0.2f, 0.3f, -0.5f}, down, settings, x[0], x[1], centres[0], push));
    QVERIFY(std::abs(push.x) < 1e-6f && std::abs(push.y) < 1e-6f && std::abs(push.z + 2.0f * 0.9f * 0.65f) < 1e-5f);
    QVERIFY(!collision::reactionPush(k, {0.2f, 0.3f, 0.1f}, down, settings, x[0], x[1], centres[0], push));  // within the margin, outside
    QVERIFY(!collision::reactionPush(k, {0.2f, 0.3f, -0.5f}, up, settings, x[0], x[1], centres[0], push));   // facing: the retreat
    collision::ContactPlane all = k;
    all.share = 1.0f;
    QVERIFY(!collision::reactionPush(all, {0.2f, 0.3f, -0.5f}, down, settings, x[0], x[1], centres[0], push));
    settings.reaction = 0.0f;
    QVERIFY(!collision::reactionPush(k, {0.2f, 0.3f, -0.5f}, down, settings, x[0], x[1], centres[0], push));
    for (int size : {5, 6, 7}) {
      double sum = 0.0;
      for (int j = 0; j < 2 + size; ++j) sum += collision::reactionPart(k, j, size);
      QVERIFY(std::abs(sum - 1.0) < 1e-6);
    }
    QCOMPARE(collision::reactionPart(k, 0, 6), 0.2f);
    QCOMPARE(collision::reactionPart(k, 1, 6), 0.3f);
  }

  // The same two spheres as largerStructureGivesWayMore with the reaction (sinew-make-scene's 2):
  // the small one takes its share by size (2/17), and its contacts push the large one back by the
  // rest, so the large one gives way a little more than without the reaction and the small one less.
  // Stiff cases with the largest gain (8) converge or stop cleanly.
  void reactionMovesTheOtherSideBack() {
    const auto run = [](double reaction, const std::string& integrator = "damped_verlet", double dt = 0.5) {
      auto sim = collidingSpheres(14.0f, 0.5f, 5.0f, integrator, dt, 2.0, reaction);
      const auto facing = [&](Index m, float sign) { return reachAlongX(*sim, m, sign); };
      const double before = pairOverlap(*sim), a0 = facing(0, 1.0f), b0 = facing(1, -1.0f);
      double last = 0.0;
      for (int i = 0; i < 300; ++i) {
        sim->step();
        last = largestStep(*sim);
      }
      for (const Vec3& p : sim->store().positions()) [&] { QVERIFY(p.allFinite()); }();
      return std::tuple{before, pairOverlap(*sim), a0 - facing(0, 1.0f), b0 - facing(1, -1.0f), last};
    };
    const auto [before, after, large, small, lastStep] = run(2.0);
    const auto [before0, after0, large0, small0, lastStep0] = run(0.0);
    qInfo("10 and 5 mm spheres overlapping by %.1f mm^3: reaction 2 -> %.2f mm^3, the large one gave way %.3f mm, the "
          "small one %.3f; without -> %.2f mm^3, %.3f and %.3f mm", before, after, large, small, after0, large0, small0);
    QVERIFY(before > 5.0);
    QVERIFY(after < 0.05 * before);
    // Measured: 0.717 / 0.223 mm with the reaction, 0.697 / 0.244 without. The large one's vertices
    // inside the small one take all of their own correction anyway; only the small one's push more.
    QVERIFY(large > large0 + 0.01);
    QVERIFY(small < small0 - 0.01);
    for (const auto& [integrator, dt] : {std::pair{std::string("implicit_euler"), 5.0}, std::pair{std::string("damped_verlet"), 0.5}}) {
      try {
        auto sim = collidingSpheres(14.0f, 1.0f, 5.0f, integrator, dt, 2.0, 8.0);
        const std::vector<double> blocks = largestStepPerHundred(*sim, 4);
        for (const Vec3& p : sim->store().positions()) QVERIFY(p.allFinite());
        qInfo("reaction 8, %s, dt %g: overlap %.2f mm^3, largest step in the last 100 steps %.3g mm", integrator.c_str(), dt,
              pairOverlap(*sim), blocks.back());
        QVERIFY(pairOverlap(*sim) < 0.05 * before);
        QVERIFY(blocks.back() < 0.015);
      } catch (const NumericalError& e) {
        qInfo("reaction 8, %s, dt %g: stopped cleanly: %s", integrator.c_str(), dt, e.what());
      }
    }
  }

  // tst_cuda_collision's "reaction 2" rows hold the device to the CPU within 1e-3 mm (Verlet) and
  // 1e-2 mm (implicit Euler). Those rows test the device's reaction only if the reaction moves that
  // scene by more than that: radii 10 and 6 mm, centres 13 mm apart, 1,280 vertices each, the same
  // parameters. Here on the CPU, reaction 2 against 0, after the rows' steps.
  void deviceRowsSceneReacts_data() {
    QTest::addColumn<QString>("integrator");
    QTest::addColumn<int>("steps");
    QTest::addColumn<int>("every");
    QTest::addColumn<double>("tolerance");  // the device row's
    QTest::newRow("damped_verlet") << "damped_verlet" << 100 << 1 << 1e-3;
    QTest::newRow("damped_verlet, every 8") << "damped_verlet" << 100 << 8 << 1e-3;
    QTest::newRow("implicit_euler") << "implicit_euler" << 20 << 1 << 1e-2;
  }
  void deviceRowsSceneReacts() {
    QFETCH(QString, integrator);
    QFETCH(int, steps);
    QFETCH(int, every);
    QFETCH(double, tolerance);
    const auto run = [&](double reaction) {
      auto sim = std::make_unique<Simulation>(forceRegistry(), 0);
      addSpherePair(*sim, 13.0f, 6.0f);
      sim->addForce("shape_prior");
      ParamTable& collision = sim->addForce("collision");
      collision.setAll("weight", 0.5);
      collision.setAll("full_search_every", every);
      collision.setAll("hold_mm", 0.0);
      collision.setAll("reaction", reaction);
      sim->setIntegrator(integrator.toStdString()).set(0, "time_step", integrator == "implicit_euler" ? 2.0 : 0.5);
      sim->initialize();
      StabilityGuard off;  // as the device rows' CPU runs (runOnBoth): the device has no guard
      off.enabled = false;
      off.maxRetries = 0;
      sim->setStabilityGuard(off);
      sim->run(steps);
      const auto x = sim->store().positions();
      return std::vector<Vec3>(x.begin(), x.end());
    };
    const std::vector<Vec3> with = run(2.0), without = run(0.0);
    double most = 0.0;
    for (size_t v = 0; v < with.size(); ++v) most = std::max(most, double((with[v] - without[v]).norm()));
    qInfo("%s, every %d: the reaction moved a vertex by up to %.3g mm in %d steps (the device rows allow %g)",
          qPrintable(integrator), every, most, steps, tolerance);
    QVERIFY(most > 10.0 * tolerance);
  }

  // Deforming contacts (paper 001 section 2.2): two spheres 1 mm apart in their reference; the
  // second starts 3 mm further away. Springs between the vertices within distance_mm of the other
  // structure in the reference bring the gap back to about 1 mm on both integrators, where without
  // them it stays. A pair far apart links nothing.
  void deformingContactsKeepTheReferenceProximity() {
    const auto run = [](bool contacts, const std::string& integrator, double timeStep, Index* linked = nullptr) {
      auto sim = std::make_unique<Simulation>(forceRegistry(), 2);
      StructureSpec a = sphereStructure("a", 3, 10.0f, Vec3::Zero());
      a.referencePositions = a.initialPositions;
      StructureSpec b = sphereStructure("b", 3, 10.0f, Vec3(21, 0, 0));
      b.referencePositions = b.initialPositions;
      for (Vec3& p : b.initialPositions) p.x() += 3.0f;
      sim->addStructure(std::move(a));
      sim->addStructure(std::move(b));
      sim->addForce("shape_prior");
      if (contacts) sim->addForce("contacts").setAll("distance_mm", 2.0);
      sim->scene().contactPairs().push_back({0, 1});
      sim->setIntegrator(integrator).set(0, "time_step", timeStep);
      sim->initialize();
      if (linked) *linked = findContactLinks(sim->store(), sim->scene().contactPairs(), 2.0f).linked;
      sim->run(400);
      return sim;
    };
    const auto gap = [](Simulation& sim) {
      const auto x = sim.store().positions();
      float best = 1e9f;
      for (Index i = sim.store().range(0).vertexBegin; i < sim.store().range(0).vertexEnd; ++i)
        for (Index j = sim.store().range(1).vertexBegin; j < sim.store().range(1).vertexEnd; ++j)
          best = std::min(best, (x[i] - x[j]).norm());
      return best;
    };
    Index linked = 0;
    auto verlet = run(true, "damped_verlet", 0.5, &linked);
    auto implicit = run(true, "implicit_euler", 5.0);
    auto without = run(false, "damped_verlet", 0.5);
    qInfo("linked %d vertices; closest vertices after 400 steps: Verlet %.3f, implicit Euler %.3f, without %.3f mm",
          int(linked), gap(*verlet), gap(*implicit), gap(*without));
    QVERIFY(linked > 0 && linked < verlet->store().vertexCount() / 4);  // only near the contact
    QVERIFY(std::abs(gap(*verlet) - 1.0f) < 0.2f);
    QVERIFY(std::abs(gap(*implicit) - 1.0f) < 0.2f);
    QVERIFY(gap(*without) > 3.5f);
    for (Simulation* s : {verlet.get(), implicit.get()})
      for (const Vec3& p : s->store().positions()) QVERIFY(p.allFinite());
    // Far apart in the reference: no link.
    MeshStore& store = without->store();
    auto ref = store.referencePositionsForWrite();
    for (Index v = store.range(1).vertexBegin; v < store.range(1).vertexEnd; ++v) ref[v].x() += 10.0f;
    QCOMPARE(findContactLinks(store, without->scene().contactPairs(), 2.0f).linked, Index(0));
  }

  // Every pair of a scene may be declared (sinew-make-scene declares them all): the links are still
  // exactly those of a search of every vertex of every partner, the nearest within the distance.
  // Two spheres 1.5 mm apart (their facing vertices lie outside each other's box, within its reach)
  // and a third far away, declared with both.
  void contactLinksOfEveryPairMatchASearchOfEveryVertex() {
    Simulation sim(forceRegistry(), 2);
    const Vec3 centres[3] = {Vec3::Zero(), Vec3(21.5f, 0, 0), Vec3(0, 60, 0)};
    for (int k = 0; k < 3; ++k) {
      StructureSpec s = sphereStructure(std::string(1, char('a' + k)), 3, 10.0f, centres[k]);
      s.referencePositions = s.initialPositions;
      sim.addStructure(std::move(s));
    }
    sim.addForce("shape_prior");
    sim.scene().contactPairs() = {{0, 1}, {0, 2}, {1, 2}};
    sim.setIntegrator("damped_verlet");
    sim.initialize();
    const MeshStore& store = sim.store();
    const float distance = 2.0f;
    const ContactLinks links = findContactLinks(store, sim.scene().contactPairs(), distance);
    const auto ref = store.referencePositions();
    const auto meshOf = store.meshOfVertex();
    Index expected = 0;
    for (Index v = 0; v < store.vertexCount(); ++v) {
      float best = distance * distance;
      bool any = false;
      for (const auto& pair : sim.scene().contactPairs()) {
        if (pair[0] != meshOf[v] && pair[1] != meshOf[v]) continue;
        const Index other = pair[0] == meshOf[v] ? pair[1] : pair[0];
        for (Index j = store.range(other).vertexBegin; j < store.range(other).vertexEnd; ++j)
          if ((ref[v] - ref[j]).squaredNorm() < best) best = (ref[v] - ref[j]).squaredNorm(), any = true;
      }
      expected += any;
      QCOMPARE(links.partner[v] >= 0, any);
      if (any) QCOMPARE((ref[v] - ref[links.partner[v]]).squaredNorm(), best);
    }
    qInfo("%d of %d vertices linked", int(links.linked), int(store.vertexCount()));
    QVERIFY(expected > 0);
    QCOMPARE(links.linked, expected);
  }

  // The hierarchy is the same on one thread or on many (from 8,192 vertices a node's two halves are
  // split side by side), and every split is a split: a node's vertices are its children's, and each
  // vertex of its first child lies at or below each of its second along one axis.
  void treeIsTheSameOnOneThreadOrMany() {
    auto treeOn = [](int threads) {
      Simulation sim(forceRegistry(), threads);
      for (const auto& [name, centre] : {std::pair{"a", Vec3(0, 0, 0)}, std::pair{"b", Vec3(15, 0, 0)}}) {
        StructureSpec s = sphereStructure(name, 5, 10.0f, centre);  // 20,480 vertices
        s.referencePositions = s.initialPositions;
        sim.addStructure(std::move(s));
      }
      sim.addForce("collision");
      sim.setIntegrator("damped_verlet");
      sim.initialize();
      return std::pair{CollisionTree::build(sim.store()), std::vector<Vec3>(sim.store().positions().begin(), sim.store().positions().end())};
    };
    const auto [one, x] = treeOn(1);
    const auto [many, unused] = treeOn(4);
    QCOMPARE(one.nodes.size(), many.nodes.size());
    for (size_t i = 0; i < one.nodes.size(); ++i) {
      const collision::Node &p = one.nodes[i], &q = many.nodes[i];
      QVERIFY2(p.left == q.left && p.right == q.right && p.parent == q.parent && p.first == q.first && p.count == q.count,
               qPrintable(QString("node %1").arg(i)));
      const collision::Box &a = one.boxes[i], &b = many.boxes[i];
      QVERIFY(a.lo.x == b.lo.x && a.lo.y == b.lo.y && a.lo.z == b.lo.z && a.hi.x == b.hi.x && a.hi.y == b.hi.y && a.hi.z == b.hi.z);
    }
    QVERIFY(one.order == many.order && one.leaves == many.leaves && one.roots == many.roots);
    QCOMPARE(one.tris.size(), many.tris.size());
    for (size_t i = 0; i < one.tris.size(); ++i)
      QVERIFY(one.tris[i].a == many.tris[i].a && one.tris[i].b == many.tris[i].b && one.tris[i].cell == many.tris[i].cell);
    QCOMPARE(one.roots.size(), size_t(2));
    QCOMPARE(one.leaves.size(), size_t(2 * 20480 / collision::kLeafVertices));
    for (const collision::Node& n : one.nodes) {
      if (n.left < 0) {
        QVERIFY(n.count <= collision::kLeafVertices);
        continue;
      }
      const collision::Node &l = one.nodes[n.left], &r = one.nodes[n.right];
      QVERIFY(l.first == n.first && r.first == l.first + l.count && l.count + r.count == n.count);
      bool separated = false;
      for (int axis = 0; axis < 3 && !separated; ++axis) {
        float leftMost = -3e38f, rightLeast = 3e38f;
        for (int i = l.first; i < l.first + l.count; ++i) leftMost = std::max(leftMost, x[one.order[i]][axis]);
        for (int i = r.first; i < r.first + r.count; ++i) rightLeast = std::min(rightLeast, x[one.order[i]][axis]);
        separated = leftMost <= rightLeast;
      }
      QVERIFY2(separated, qPrintable(QString("node of %1 vertices from %2").arg(n.count).arg(n.first)));
    }
  }

  // The contact regions a view shows: the vertices inside the other sphere (or within the margin)
  // and no others; none once the spheres are apart.
  void contactMaskMarksTheOverlap() {
    auto sim = collidingSpheres(15.0f, 0.0f);
    MeshStore& s = sim->store();
    const auto mask = contactMask(s, sim->scene(), 0.25f);
    Index marked = 0;
    for (Index v = 0; v < s.vertexCount(); ++v) {
      const Vec3 p = s.positions()[v];
      const Vec3 otherCentre = s.meshOfVertex()[v] == 0 ? Vec3(15, 0, 0) : Vec3(0, 0, 0);
      const float depth = 10.0f - (p - otherCentre).norm();  // > 0: inside the other sphere
      if (depth > 0.5f) QVERIFY2(mask[v], qPrintable(QString("vertex %1, %2 mm inside, not marked").arg(v).arg(depth)));
      if (depth < -0.75f) QVERIFY2(!mask[v], qPrintable(QString("vertex %1, %2 mm outside, marked").arg(v).arg(-depth)));
      marked += mask[v];
    }
    QVERIFY(marked > 0);
    auto apart = collidingSpheres(25.0f, 0.0f);
    const auto none = contactMask(apart->store(), apart->scene(), 0.25f);
    QCOMPARE(Index(std::count(none.begin(), none.end(), 1)), Index(0));
  }
};

QTEST_GUILESS_MAIN(TestCollision)
#include "tst_collision.moc"
