// The collision's shares by pair (scene key `collision_shares`, docs/collisions.md "Shares by
// pair"): they replace the sharing by size for their pairs in the table that both backends read
// (CollisionTree::setShares; the device uploads the same table). And the shares learned from
// labelled segmentations: which side of a pair reaches into the other's truth.
#include "sinew/core/collision_tree.h"
#include "sinew/core/contact_sides.h"
#include "collision_scenes.h"

#include <QtTest>

#include <cmath>
#include <tuple>

using namespace sinew;
using namespace sinew::testing;

namespace {
std::vector<float> shareTable(Simulation& sim) {
  CollisionTree tree = CollisionTree::build(sim.store());
  tree.setShares(sim.store(), sim.scene(), sim.forceParams("collision"));
  return tree.share;
}
}  // namespace

class TestCollisionShares : public QObject {
  Q_OBJECT
private slots:
  // Spheres of radius 10 and 5 mm (surface areas 4 : 1), size_share 2: by size the small one takes
  // 2 / 17 of a correction, the large one all. A pair's shares replace both; against a structure
  // that does not respond a vertex still takes all; with size_share 0 the table holds the pair's
  // shares and 1 elsewhere, and without shares by pair there is no table.
  void pairSharesReplaceTheSizes() {
    auto sim = collidingSpheres(14.0f, 0.5f, 5.0f);
    const std::vector<float> bySize = shareTable(*sim);
    QCOMPARE(bySize.size(), std::size_t(4));
    QCOMPARE(bySize[0 * 2 + 1], 1.0f);
    QVERIFY(std::abs(bySize[1 * 2 + 0] - 2.0f / 17.0f) < 1e-4f);
    sim->scene().collisionShares().push_back({0, 1, 0.25f, 0.75f});
    std::vector<float> given = shareTable(*sim);
    QCOMPARE(given[0 * 2 + 1], 0.25f);
    QCOMPARE(given[1 * 2 + 0], 0.75f);
    ParamTable& collision = sim->forceParams("collision");
    collision.set(1, "weight", 0.0);
    given = shareTable(*sim);
    QCOMPARE(given[0 * 2 + 1], 1.0f);  // against the sphere that does not respond: all
    QCOMPARE(given[1 * 2 + 0], 0.75f);
    collision.set(1, "weight", 0.5);
    collision.setAll("size_share", 0.0);
    given = shareTable(*sim);
    QCOMPARE(given.size(), std::size_t(4));
    QCOMPARE(given[0 * 2 + 1], 0.25f);
    QCOMPARE(given[0 * 2 + 0], 1.0f);
    sim->scene().collisionShares().clear();
    QVERIFY(shareTable(*sim).empty());
  }

  // The same spheres pushed together: by size the large one gives way more; with the pair's shares
  // turned round (the large one taking 2 / 17, the small one all) the small one does, and the
  // overlap is resolved either way.
  void pairSharesDecideWhichSideGivesWay() {
    const auto run = [](bool turned) {
      auto sim = collidingSpheres(14.0f, 0.5f, 5.0f);
      if (turned) sim->scene().collisionShares().push_back({0, 1, 2.0f / 17.0f, 1.0f});
      const auto facing = [&](Index m, float sign) { return reachAlongX(*sim, m, sign); };
      const double before = pairOverlap(*sim), large0 = facing(0, 1.0f), small0 = facing(1, -1.0f);
      sim->run(300);
      for (const Vec3& p : sim->store().positions()) [&] { QVERIFY(p.allFinite()); }();
      return std::tuple{before, pairOverlap(*sim), large0 - facing(0, 1.0f), small0 - facing(1, -1.0f)};
    };
    const auto [before, sizeAfter, sizeLarge, sizeSmall] = run(false);
    const auto [before2, turnedAfter, turnedLarge, turnedSmall] = run(true);
    qInfo("10 and 5 mm spheres overlapping by %.1f mm^3: by size -> %.2f mm^3, the large one gave way %.3f mm, the small "
          "one %.3f; the pair's shares turned round -> %.2f mm^3, %.3f and %.3f mm",
          before, sizeAfter, sizeLarge, sizeSmall, turnedAfter, turnedLarge, turnedSmall);
    QVERIFY(before > 5.0 && before2 == before);
    QVERIFY(sizeAfter < 0.05 * before && turnedAfter < 0.05 * before);
    QVERIFY(sizeSmall < 0.6 * sizeLarge);
    QVERIFY(turnedSmall > 1.5 * turnedLarge);
  }

  // Two structures' surface points against a truth split at x = 2.5 voxels (label 1 below, 2 from
  // there; 1 mm voxels from -2 mm): a's two points near b lie one in b's truth, b's three near a
  // two in a's. So b reaches over more and gives way: a takes min(1, 2 x 0.5^2 / (0.5^2 +
  // (2/3)^2)) = 0.72 of a correction, b all of it. A point beyond reach, a structure without a
  // truth and too few contacts count for nothing.
  void contactSidesGiveTheShares() {
    ImageGeometry g;
    g.size = {10, 10, 10};
    g.origin = Eigen::Vector3d(-2, -2, -2);
    LabelVolume truth(g, 0);
    for (int k = 0; k < 10; ++k)
      for (int j = 0; j < 10; ++j)
        for (int i = 0; i < 10; ++i) truth.at(i, j, k) = i <= 2 ? 1 : 2;
    const std::vector<std::vector<Vec3>> points = {{Vec3(0, 0, 0), Vec3(0.7f, 0, 0), Vec3(5, 5, 5)},
                                                   {Vec3(1.2f, 0, 0), Vec3(0.4f, 0.3f, 0), Vec3(0.3f, -0.3f, 0)},
                                                   {Vec3(0.5f, 0, 0)}};
    const std::vector<const LabelVolume*> truths = {&truth, &truth, nullptr};
    const std::vector<int> labels = {1, 2, 3};
    const std::vector<ContactSide> c = countContactSides(points, truths, labels, 1.0f);
    QCOMPARE(c.size(), std::size_t(9));
    QCOMPARE(c[0 * 3 + 1].contact, Index(2));
    QCOMPARE(c[0 * 3 + 1].inOtherTruth, Index(1));
    QCOMPARE(c[1 * 3 + 0].contact, Index(3));
    QCOMPARE(c[1 * 3 + 0].inOtherTruth, Index(2));
    QCOMPARE(c[0 * 3 + 2].contact, Index(0));  // no truth: left out
    QCOMPARE(c[2 * 3 + 0].contact, Index(0));
    const std::vector<PairShares> s = sharesFromContactSides(c, 3, 2);
    QCOMPARE(s.size(), std::size_t(1));
    QCOMPARE(s[0].a, Index(0));
    QCOMPARE(s[0].b, Index(1));
    QVERIFY(std::abs(s[0].aShare - 2.0 * 0.25 / (0.25 + 4.0 / 9.0)) < 1e-9);
    QCOMPARE(s[0].bShare, 1.0);
    QVERIFY(sharesFromContactSides(c, 3, 3).empty());                       // a has two contacts only
    QCOMPARE(countContactSides(points, truths, labels, 0.3f)[0 * 3 + 1].contact, Index(0));  // beyond reach
  }
};

QTEST_GUILESS_MAIN(TestCollisionShares)
#include "tst_collision_shares.moc"
