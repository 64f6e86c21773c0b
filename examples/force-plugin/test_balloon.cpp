// The balloon plugin's own tests, with Sinew's plugin test helpers: the plugin is loaded from its
// file exactly as sinew-run loads it.
#include <sinew/sdk/plugin_testing.h>

#include <QtTest>

using namespace sinew;

class TestBalloon : public QObject {
  Q_OBJECT
private Q_SLOTS:
  void loadsAsAForcePlugin() {
    testing::LoadedPlugin plugin(SINEW_PLUGIN_FILE);
    QCOMPARE(plugin.record.name, std::string("balloon"));
    QCOMPARE(plugin.record.kind, PluginKind::Force);
    QCOMPARE(plugin.registry.force("balloon").params[1].name, std::string("pressure"));
  }

  void pushesAlongTheOutwardNormal() {
    testing::LoadedPlugin plugin(SINEW_PLUGIN_FILE);
    testing::ForceProbe probe(plugin.registry, "balloon");
    probe.params().set(0, "pressure", 0.25);
    const std::vector<Vec3> f = probe.evaluate();
    const auto x = probe.store().positions();
    for (std::size_t v = 0; v < f.size(); ++v) {
      QVERIFY(std::abs(f[v].norm() - 0.25f) < 1e-5f);
      QVERIFY(f[v].dot(x[v].normalized()) > 0.24f);  // outward on a sphere about the origin
    }
  }

  void growsAndShrinksASphere() {
    testing::LoadedPlugin plugin(SINEW_PLUGIN_FILE);
    testing::ForceProbe grow(plugin.registry, "balloon");
    grow.advance(10, 0.5f);  // default pressure 0.5: 10 * 0.5 * 0.5 = 2.5 mm
    QVERIFY(std::abs(grow.meanRadius() - 12.5) < 0.05);
    testing::ForceProbe shrink(plugin.registry, "balloon");
    shrink.params().set(0, "pressure", -0.5);
    shrink.advance(10, 0.5f);
    QVERIFY(std::abs(shrink.meanRadius() - 7.5) < 0.05);
  }

  void zeroWeightDoesNothing() {
    testing::LoadedPlugin plugin(SINEW_PLUGIN_FILE);
    testing::ForceProbe probe(plugin.registry, "balloon");
    probe.params().set(0, "weight", 0.0);
    for (const Vec3& f : probe.evaluate()) QCOMPARE(f, Vec3::Zero().eval());
  }
};

QTEST_GUILESS_MAIN(TestBalloon)
#include "test_balloon.moc"
