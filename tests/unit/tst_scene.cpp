// Scene files: every error names the file and the JSON path.
#include "sinew/core/scene.h"

#include <QDir>
#include <QTemporaryDir>
#include <QtTest>

using namespace sinew;

namespace {
const char* kValid = R"({
  "version": 1,
  "images": {"target": "t.nii.gz"},
  "structures": [
    {"name": "a", "label": 3, "reference": {"label_map": "l.nii.gz", "label": 3},
     "initial": {"rotation_axis": [0, 0, 1], "rotation_deg": 5, "translation_mm": [1, 2, 3], "scale": 1.05},
     "forces": {"smoothing": {"weight": 0.5}}, "attraction_points_mm": [[1.5, -2, 30]],
     "include_points_mm": [[1, 2, 3]], "exclude_points_mm": [[4, 5, 6], [7, 8, 9]]}
  ],
  "forces": {"smoothing": {"weight": 0.1}, "shape_prior": {}, "attraction_points": {}},
  "integrator": {"name": "damped_verlet", "time_step": 0.4},
  "schedule": [{"iterations": 10}, {"iterations": 5, "forces": {"smoothing": {"weight": 0.2}}}]
})";

QString errorOf(const std::string& text) {
  try {
    parseScene(text, "/data/scene.json");
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("test text not found: " + from);
  return text.replace(at, from.size(), to);
}
}  // namespace

class TestScene : public QObject {
  Q_OBJECT
private slots:
  void parsesAValidScene() {
    const SceneDesc s = parseScene(kValid, "/data/scene.json");
    QCOMPARE(s.structures.size(), size_t(1));
    QCOMPARE(s.targetImage, std::filesystem::path("/data/t.nii.gz"));  // relative to the scene
    QCOMPARE(s.structures[0].reference.label->label, 3);
    QCOMPARE(s.structures[0].initial.scale, 1.05);
    QCOMPARE(s.forces.size(), size_t(3));
    QCOMPARE(s.structures[0].includePointsMm.size(), size_t(1));
    QCOMPARE(s.structures[0].excludePointsMm.size(), size_t(2));
    QCOMPARE(s.structures[0].excludePointsMm[1][2], 9.0);
    QCOMPARE(s.forces[0].first, std::string("smoothing"));  // file order kept
    QCOMPARE(s.schedule.size(), size_t(2));
    QCOMPARE(s.integratorParams.front().second, 0.4);
  }

  void errorsNameTheJsonPath_data() {
    QTest::addColumn<QString>("from");
    QTest::addColumn<QString>("to");
    QTest::addColumn<QString>("expected");
    QTest::newRow("unknown key") << R"("scale": 1.05)" << R"("scale": 1.05, "sclae": 2)"
                                 << "/data/scene.json: /structures/0/initial/sclae: unknown key";
    QTest::newRow("wrong type") << R"("iterations": 10)" << R"("iterations": "10")"
                                << "/schedule/0/iterations: expected an integer, got a string";
    QTest::newRow("integer out of range") << R"("iterations": 10)" << R"("iterations": 4294967306)"
                                          << "/schedule/0/iterations: the integer 4294967306 is out of range";
    QTest::newRow("missing key") << R"("images": {"target": "t.nii.gz"})" << R"("images": {})"
                                 << "/images: missing required key 'target'";
    QTest::newRow("version") << R"("version": 1)" << R"("version": 7)" << "/version: scene version 7 is not supported";
    QTest::newRow("force not listed") << R"({"smoothing": {"weight": 0.5}})" << R"({"gradient": {"weight": 0.5}})"
                                      << "/structures/0/forces/gradient: force 'gradient' is not listed";
    QTest::newRow("parameter type") << R"("weight": 0.1)" << R"("weight": true)"
                                    << "/forces/smoothing/weight: expected a number";
    QTest::newRow("reference twice") << R"("label_map": "l.nii.gz", "label": 3})"
                                     << R"("label_map": "l.nii.gz", "label": 3, "mesh": "m.vtp"})"
                                     << "/structures/0/reference: give either";
    QTest::newRow("attraction point") << R"([[1.5, -2, 30]])" << R"([[1.5, -2]])"
                                      << "/structures/0/attraction_points_mm/0: expected 3 numbers, got 2";
    QTest::newRow("include point") << R"([[1, 2, 3]])" << R"([[1, 2, 3, 4]])"
                                   << "/structures/0/include_points_mm/0: expected 3 numbers, got 4";
    QTest::newRow("points without their force") << R"(, "attraction_points": {}})" << R"(})"
                                                << "/structures/0/attraction_points_mm: placed points need the force";
    QTest::newRow("contact pairs without their force") << R"("version": 1,)" << R"("version": 1, "contact_pairs": [["a", "a"]],)"
                                                       << "/contact_pairs: contact pairs need the force";
    QTest::newRow("contact pair unknown") << R"("attraction_points": {}})" << R"("attraction_points": {}, "contacts": {}}, "contact_pairs": [["a", "b"]])"
                                          << "/contact_pairs/0/1: no structure is named 'b'";
    QTest::newRow("contact pair self") << R"("attraction_points": {}})" << R"("attraction_points": {}, "contacts": {}}, "contact_pairs": [["a", "a"]])"
                                       << "/contact_pairs/0: a structure cannot be in contact with itself";
    QTest::newRow("collision shares without their force") << R"("version": 1,)"
                                                          << R"("version": 1, "collision_shares": [{"pair": ["a", "a"], "shares": [1, 0]}],)"
                                                          << "/collision_shares: shares by pair need the collision force";
    QTest::newRow("collision share unknown") << R"("attraction_points": {}})"
                                             << R"("attraction_points": {}, "collision": {}}, "collision_shares": [{"pair": ["a", "b"], "shares": [1, 0]}])"
                                             << "/collision_shares/0/pair/1: no structure is named 'b'";
    QTest::newRow("collision share above 1") << R"("attraction_points": {}})"
                                             << R"("attraction_points": {}, "collision": {}}, "collision_shares": [{"pair": ["a", "a"], "shares": [1.5, 0]}])"
                                             << "/collision_shares/0/shares: a share is the part of a correction a side takes";
    QTest::newRow("collision share self") << R"("attraction_points": {}})"
                                          << R"("attraction_points": {}, "collision": {}}, "collision_shares": [{"pair": ["a", "a"], "shares": [1, 0]}])"
                                          << "/collision_shares/0/pair: a structure cannot collide with itself";
    QTest::newRow("attachment unknown") << R"("version": 1,)" << R"("version": 1, "attachments": [{"structure": "a", "to": "b"}],)"
                                        << "/attachments/0/to: no structure is named 'b'";
    QTest::newRow("attachment to itself") << R"("version": 1,)" << R"("version": 1, "attachments": [{"structure": "a", "merge": "a"}],)"
                                          << "/attachments/0/merge: a structure cannot be attached to itself";
    QTest::newRow("attachment two kinds") << R"("version": 1,)"
                                          << R"("version": 1, "attachments": [{"structure": "a", "to": "a", "fixed_within_mm": {"centre": [0, 0, 0], "radius": 2}}],)"
                                          << "/attachments/0: expected exactly one of";
    QTest::newRow("fixed with a distance") << R"("version": 1,)"
                                           << R"("version": 1, "attachments": [{"structure": "a", "fixed_within_mm": {"centre": [0, 0, 0], "radius": 2}, "distance_mm": 1}],)"
                                           << "/attachments/0/distance_mm: a fixed region has no distance";
    QTest::newRow("fixed radius") << R"("version": 1,)"
                                  << R"("version": 1, "attachments": [{"structure": "a", "fixed_within_mm": {"centre": [0, 0, 0], "radius": -1}}],)"
                                  << "/attachments/0/fixed_within_mm/radius: must be in (0, 1000] mm";
    QTest::newRow("shape limit") << R"("version": 1,)" << R"("version": 1, "stability": {"min_volume_ratio": 1.5},)"
                                 << "/stability/min_volume_ratio: must be in [0, 1)";
    QTest::newRow("outside band") << R"("version": 1,)" << R"("version": 1, "stability": {"outside_band_mm": -1},)"
                                  << "/stability/outside_band_mm: must be in [0, 1000] mm";
    QTest::newRow("not json") << R"("version": 1,)" << R"("version": 1,,)" << "/data/scene.json: not valid JSON";
    QTest::newRow("mass floor") << R"("scale": 1.05})" << R"("scale": 1.05}, "mass_floor": 1.5)"
                                << "/structures/0/mass_floor: the mass floor must be between 0 and 1";
  }
  void errorsNameTheJsonPath() {
    QFETCH(QString, from);
    QFETCH(QString, to);
    QFETCH(QString, expected);
    const QString msg = errorOf(replaced(kValid, from.toStdString(), to.toStdString()));
    QVERIFY2(msg.contains(expected), qPrintable("got: " + msg));
  }

  // What the workstation saves reads back the same (paths made absolute against the scene's folder).
  void writtenSceneReadsBack() {
    const SceneDesc a = parseScene(kValid, "/data/scene.json");
    QCOMPARE(a.structures[0].attractionPointsMm.size(), size_t(1));
    QTemporaryDir dir;
    const std::filesystem::path file = dir.filePath("saved.json").toStdString();
    writeScene(a, file);
    const SceneDesc b = readScene(file);
    QCOMPARE(b.targetImage, std::filesystem::path("/data/t.nii.gz"));
    QCOMPARE(b.structures.size(), a.structures.size());
    const StructureDesc &x = a.structures[0], &y = b.structures[0];
    QCOMPARE(y.name, x.name);
    QCOMPARE(y.label, x.label);
    QCOMPARE(y.reference.label->labelMap, std::filesystem::path("/data/l.nii.gz"));
    QCOMPARE(y.initial.rotationDeg, x.initial.rotationDeg);
    QVERIFY(y.initial.translationMm == x.initial.translationMm);
    QCOMPARE(y.initial.scale, x.initial.scale);
    QVERIFY(y.forces == x.forces);
    QVERIFY(y.attractionPointsMm == x.attractionPointsMm);
    QVERIFY(y.includePointsMm == x.includePointsMm);
    QVERIFY(y.excludePointsMm == x.excludePointsMm);
    QVERIFY(b.forces == a.forces);
    QCOMPARE(b.integrator, a.integrator);
    QCOMPARE(y.massFloor, 0.0);  // off unless asked for
    // Attachments, the thickness output, a shape limit and a mass floor too.
    SceneDesc c = parseScene(replaced(replaced(kValid, R"("version": 1,)",
                                               R"("version": 1, "outputs": {"thickness": true}, "stability": {"outside_band_mm": 3.5}, "attachments": [{"structure": "a", "fixed_within_mm": {"centre": [1, 2, 3], "radius": 4}}],)"),
                                      R"("scale": 1.05})", R"("scale": 1.05}, "mass_floor": 0.3)"),
                             "/data/scene.json");
    writeScene(c, file);
    const SceneDesc d = readScene(file);
    QVERIFY(d.thickness);
    QCOMPARE(d.stability.shape.outsideBandMm, 3.5);
    QCOMPARE(d.structures[0].massFloor, 0.3);
    QCOMPARE(d.attachments.size(), std::size_t(1));
    QCOMPARE(d.attachments[0].kind, std::string("fixed"));
    QVERIFY((d.attachments[0].centreMm == std::array<double, 3>{1, 2, 3}));
    QCOMPARE(d.attachments[0].radiusMm, 4.0);
    QVERIFY(b.integratorParams == a.integratorParams);
    QCOMPARE(b.schedule.size(), a.schedule.size());
    QVERIFY(b.schedule[1].forces == a.schedule[1].forces);
    QCOMPARE(b.schedule[1].iterations, a.schedule[1].iterations);
    QCOMPARE(QDir(dir.path()).entryList(QDir::Files), QStringList{"saved.json"});  // no temporary left
  }

  // Shares by pair read back, each side's share with its structure.
  void collisionSharesReadBack() {
    const std::string twoStructures =
        replaced(replaced(kValid, R"([7, 8, 9]]})", R"([7, 8, 9]]}, {"name": "b", "label": 4, "reference": {"label_map": "l.nii.gz", "label": 4}})"),
                 R"("attraction_points": {}})",
                 R"("attraction_points": {}, "collision": {}}, "collision_shares": [{"pair": ["b", "a"], "shares": [1, 0.25]}])");
    const SceneDesc a = parseScene(twoStructures, "/data/scene.json");
    QCOMPARE(a.collisionShares.size(), std::size_t(1));
    QTemporaryDir dir;
    const std::filesystem::path file = dir.filePath("saved.json").toStdString();
    writeScene(a, file);
    const SceneDesc b = readScene(file);
    QCOMPARE(b.collisionShares.size(), std::size_t(1));
    QVERIFY((b.collisionShares[0].pair == std::array<std::string, 2>{"b", "a"}));
    QVERIFY((b.collisionShares[0].shares == std::array<double, 2>{1.0, 0.25}));
    const QString twice = errorOf(replaced(twoStructures, R"(0.25]}])", R"(0.25]}, {"pair": ["a", "b"], "shares": [0, 1]}])"));
    QVERIFY2(twice.contains("/collision_shares/1/pair: the pair is listed twice"), qPrintable("got: " + twice));
  }

  void missingFileIsNamed() {
    try {
      readScene("/nonexistent/scene.json");
      QFAIL("accepted");
    } catch (const InputError& e) {
      QVERIFY(QString(e.what()).contains("/nonexistent/scene.json"));
    }
  }
};

QTEST_APPLESS_MAIN(TestScene)
#include "tst_scene.moc"
