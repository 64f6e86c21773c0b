// The pieces of the new-subject path that need no image: landmark maps (thin-plate spline and
// affine fit, and the landmark checks), a registration's B-spline map and its inverse, the affine
// regularisation of image forces, the scene keys of the initialisation, and the model files
// (written, read back exactly, damage refused).
#include "sinew/core/model_builder.h"
#include "sinew/core/model_file.h"
#include "sinew/core/scene.h"
#include "sinew/core/spatial_map.h"
#include "synthetic.h"

#include <QTemporaryDir>
#include <QtTest>

#include <fstream>
#include <random>

using namespace sinew;
using namespace sinew::testing;
namespace fs = std::filesystem;

namespace {

Eigen::Matrix4d someAffine() {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix() *
                            Eigen::Vector3d(1.05, 0.95, 1.02).asDiagonal();
  m.topRightCorner<3, 1>() << 3.0, -2.0, 1.5;
  return m;
}

std::vector<LandmarkPair> pairsUnder(const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& f, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-40.0, 40.0);
  std::vector<LandmarkPair> out;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const Eigen::Vector3d q = f(p);
    out.push_back({{p.x(), p.y(), p.z()}, {q.x(), q.y(), q.z()}});
  }
  return out;
}

void expectError(const std::function<void()>& f, const QString& fragment) {
  try {
    f();
  } catch (const InputError& e) {
    QVERIFY2(QString(e.what()).contains(fragment), e.what());
    return;
  }
  QFAIL(qPrintable("no error containing '" + fragment + "'"));
}

// A force that pretends to be driven by the image: it adds a fixed field, so the regularisation's
// output can be compared with a least-squares fit computed here.
struct FieldForce final : Force {
  std::vector<Vec3> field;
  Requirements requirements() const override { return {{}, false, false, true}; }
  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    forActiveVertices(ctx, [&](Index v, float alpha) { forces[v] += alpha * field[v]; });
  }
};

}  // namespace

class TestInitialisation : public QObject {
  Q_OBJECT

private slots:
  void affineFitRecoversAnAffineMap() {
    const Eigen::Matrix4d m = someAffine();
    const auto pairs = pairsUnder([&](const Eigen::Vector3d& p) { return (m * p.homogeneous()).head<3>(); }, 6, 1);
    const SpatialMap fit = SpatialMap::fitAffine(pairs);
    QVERIFY((fit.affinePart() - m).norm() < 1e-9);
    QVERIFY(!fit.hasSpline());
  }

  void thinPlateSplineInterpolatesAndKeepsAffineMapsExactly() {
    const Eigen::Matrix4d m = someAffine();
    // An affine map: the spline's non-affine part vanishes and every point maps exactly.
    const auto pairs = pairsUnder([&](const Eigen::Vector3d& p) { return (m * p.homogeneous()).head<3>(); }, 10, 2);
    const SpatialMap tps = SpatialMap::fitThinPlateSpline(pairs);
    const Eigen::Vector3d probe(5, -7, 11);
    QVERIFY((tps.apply(probe) - (m * probe.homogeneous()).head<3>()).norm() < 1e-6);
    // A bent map: the landmarks are hit exactly, and points between them move smoothly.
    auto bend = [](const Eigen::Vector3d& p) { return Eigen::Vector3d(p.x() + 0.002 * p.y() * p.y(), p.y(), p.z() + 3.0); };
    const auto bent = pairsUnder(bend, 10, 3);
    const SpatialMap spline = SpatialMap::fitThinPlateSpline(bent);
    QVERIFY(spline.hasSpline());
    for (const auto& p : bent) {
      const Eigen::Vector3d at = spline.apply(Eigen::Vector3d(p.model[0], p.model[1], p.model[2]));
      QVERIFY((at - Eigen::Vector3d(p.target[0], p.target[1], p.target[2])).norm() < 1e-6);
    }
    QVERIFY((spline.apply(Eigen::Vector3d(0, 0, 0)) - bend(Eigen::Vector3d(0, 0, 0))).norm() < 2.0);
  }

  // A spline map sampled on a grid (what a registration's B-spline map becomes) is its spline to
  // within the grid's interpolation error inside the grid, and the spline itself outside it.
  void sampledMapFollowsItsSpline() {
    const auto warp = [](const Eigen::Vector3d& p) {
      return Eigen::Vector3d(p + 4.0 * std::exp(-p.squaredNorm() / (2.0 * 25.0 * 25.0)) * Eigen::Vector3d(1.0, -0.5, 0.3));
    };
    const SpatialMap spline = SpatialMap::fitThinPlateSpline(pairsUnder(warp, 300, 7));
    const SpatialMap sampled = spline.sampledOn(Eigen::Vector3d::Constant(-30.0), Eigen::Vector3d::Constant(30.0), 2.0);
    QVERIFY(sampled.hasSpline());
    QVERIFY(sampled.describe().find("sampled every 2 mm") != std::string::npos);
    std::mt19937 rng(8);
    std::uniform_real_distribution<double> u(-30.0, 30.0);
    double largest = 0.0, moved = 0.0;
    for (int i = 0; i < 2000; ++i) {
      const Eigen::Vector3d p(u(rng), u(rng), u(rng));
      largest = std::max(largest, (sampled.apply(p) - spline.apply(p)).norm());
      moved = std::max(moved, (spline.apply(p) - p).norm());
    }
    qInfo("largest difference inside the grid %.4f mm, largest displacement %.2f mm", largest, moved);
    QVERIFY2(moved > 3.0, "the spline must move points for the comparison to mean anything");
    QVERIFY2(largest < 0.02, qPrintable(QString::number(largest)));
    const Eigen::Vector3d outside(45.0, -40.0, 35.0);
    QCOMPARE(sampled.apply(outside), spline.apply(outside));
  }

  // A registration's B-spline in core (BSplineWarp, SpatialMap::warpThenAffine). Cubic B-splines
  // reproduce a linear field: coefficients M p (p a control point's position) give d(x) = M x and
  // the Jacobian M inside the grid's valid region, and past it the nearest point's. With random
  // coefficients added, the map's inverse (Newton) must undo it, and the sampled inverse stay near
  // the exact one.
  void bsplineWarpAndItsInverse() {
    BSplineWarp w;
    w.size = {7, 8, 6};
    w.spacing = Eigen::Vector3d(30.0, 25.0, 35.0);
    w.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, -0.4).normalized()).toRotationMatrix();
    w.origin = Eigen::Vector3d(-80.0, -95.0, -70.0);
    Eigen::Matrix3d m;
    m << 0.04, -0.02, 0.01, 0.03, 0.05, -0.03, -0.01, 0.02, -0.04;
    const auto controlPoint = [&](int i, int j, int k) -> Eigen::Vector3d {
      return w.origin + w.direction * w.spacing.cwiseProduct(Eigen::Vector3d(i, j, k));
    };
    for (int k = 0; k < w.size[2]; ++k)
      for (int j = 0; j < w.size[1]; ++j)
        for (int i = 0; i < w.size[0]; ++i) w.coefficients.push_back(m * controlPoint(i, j, k));
    QVERIFY(w.valid());
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const auto atIndex = [&](double a, double b, double c) -> Eigen::Vector3d {
      return controlPoint(0, 0, 0) + w.direction * w.spacing.cwiseProduct(Eigen::Vector3d(a, b, c));
    };
    double largest = 0.0;
    for (int n = 0; n < 500; ++n) {  // inside: index in [1, size - 2)
      const Eigen::Vector3d x = atIndex(1.0 + u(rng) * 3.99, 1.0 + u(rng) * 4.99, 1.0 + u(rng) * 2.99);
      Eigen::Matrix3d jac;
      largest = std::max(largest, (w.displacement(x, &jac) - m * x).norm());
      largest = std::max(largest, (jac - m).norm());
    }
    QVERIFY2(largest < 1e-9, qPrintable(QString::number(largest)));
    // Past the valid region (index 5, 6, 4 at its far ends): the displacement at its nearest point,
    // constant along each axis it is past (ITK gives zero there: the map would jump at the edge).
    Eigen::Matrix3d past;
    QVERIFY((w.displacement(atIndex(0.9, 2.0, 2.0), &past) - m * atIndex(1.0, 2.0, 2.0)).norm() < 1e-9);
    QVERIFY((past * w.direction.col(0)).norm() < 1e-12);
    QVERIFY((past * w.direction.col(1) - m * w.direction.col(1)).norm() < 1e-9);
    QVERIFY((w.displacement(atIndex(2.0, 6.01, 2.0)) - m * atIndex(2.0, 6.0, 2.0)).norm() < 1e-9);
    QVERIFY((w.displacement(atIndex(-3.0, 9.0, 7.5)) - m * atIndex(1.0, 6.0, 4.0)).norm() < 1e-9);

    std::uniform_real_distribution<double> c(-5.0, 5.0);
    for (Eigen::Vector3d& v : w.coefficients) v += Eigen::Vector3d(c(rng), c(rng), c(rng));
    const SpatialMap forward = SpatialMap::warpThenAffine(w, someAffine());
    const SpatialMap inverse = forward.inverse();
    QVERIFY(inverse.describe().find("inverse of B-spline (7x8x6 control points), then affine") == 0);
    QVERIFY((inverse.affinePart() - someAffine().inverse()).norm() < 1e-12);  // the model -> target map's
    const SpatialMap twice = inverse.inverse();
    double roundTrip = 0.0, moved = 0.0;
    // Half a cell in from the valid region's edge, and across it: a structure that reaches past the
    // target's field of view (where, with ITK's zero outside, Newton's method found no preimage).
    for (int n = 0; n < 500; ++n) {
      const Eigen::Vector3d x = n % 5 == 0 ? atIndex(-1.0 + 3.0 * u(rng), 3.0, 3.0 + 2.5 * u(rng))
                                           : atIndex(1.5 + u(rng) * 2.99, 1.5 + u(rng) * 3.99, 1.5 + u(rng) * 1.99);
      roundTrip = std::max(roundTrip, (inverse.apply(forward.apply(x)) - x).norm());
      roundTrip = std::max(roundTrip, (twice.apply(x) - forward.apply(x)).norm());
      moved = std::max(moved, w.displacement(x).norm());
    }
    qInfo("largest displacement %.2f mm; largest round trip error %.3g mm", moved, roundTrip);
    QVERIFY(moved > 3.0);
    QVERIFY2(roundTrip < 1e-6, qPrintable(QString::number(roundTrip)));
    const Eigen::Vector3d lo = atIndex(2.0, 2.0, 2.0).cwiseMin(atIndex(4.0, 5.0, 3.0));
    const Eigen::Vector3d hi = atIndex(2.0, 2.0, 2.0).cwiseMax(atIndex(4.0, 5.0, 3.0));
    const SpatialMap sampled = inverse.sampledOn(lo, hi, 2.0);
    double sampling = 0.0;
    for (int n = 0; n < 500; ++n) {
      const Eigen::Vector3d y = lo + (hi - lo).cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng)));
      sampling = std::max(sampling, (sampled.apply(y) - inverse.apply(y)).norm());
    }
    qInfo("largest sampling error %.4f mm", sampling);
    QVERIFY2(sampling < 0.02, qPrintable(QString::number(sampling)));
    BSplineWarp broken = w;
    broken.coefficients[17].y() = std::numeric_limits<double>::quiet_NaN();
    expectError([&] { SpatialMap::warpThenAffine(broken, someAffine()); }, "not finite");
  }

  void badLandmarksAreRefused() {
    auto id = [](const Eigen::Vector3d& p) { return p; };
    auto three = pairsUnder(id, 3, 4);
    expectError([&] { SpatialMap::fitThinPlateSpline(three); }, "at least 4");
    auto same = pairsUnder(id, 5, 5);
    same[3].model = same[1].model;
    expectError([&] { SpatialMap::fitAffine(same); }, "landmarks 1 and 3 have the same model point");
    auto flat = pairsUnder(id, 6, 6);
    for (auto& p : flat) p.target[2] = 7.0;  // every target point on the plane z = 7
    expectError([&] { SpatialMap::fitThinPlateSpline(flat); }, "target landmarks are coplanar");
  }

  void sceneKeysAreReadAndChecked() {
    const std::string base = R"({"version": 1, "images": {"target": "t.nii.gz"},
      "structures": [{"name": "a", "label": 1}], "forces": {"smoothing": {}},
      "schedule": [{"iterations": 5, "affine_regularisation": 0.5}], "model": "m/", )";
    const SceneDesc s = parseScene(base + R"("initialise": {"registration": "rigid", "levels": 3, "samples": 20000}})", "/d/s.json");
    QVERIFY(s.model && *s.model == fs::path("/d/m/"));
    QCOMPARE(s.schedule[0].affineRegularisation, 0.5);
    QVERIFY(s.initialise.method == InitialiseDesc::Method::Registration);
    QVERIFY(!s.initialise.affine);
    QCOMPARE(s.initialise.levels, 3);
    QCOMPARE(s.initialise.samples, 20000);
    // Written and read back, it is the same scene.
    const SceneDesc again = parseScene(sceneToJson(s), "/d/s.json");
    QVERIFY(again.initialise.method == InitialiseDesc::Method::Registration && !again.initialise.affine);
    QCOMPARE(again.initialise.samples, 20000);
    QCOMPARE(again.schedule[0].affineRegularisation, 0.5);
    expectError([&] { parseScene(base + R"("initialise": {"registration": "affine", "transform": "x.tfm"}})", "s.json"); },
                "/initialise: give exactly one of");
    expectError([&] { parseScene(base + R"("initialise": {"landmarks": [{"model": [0,0,0], "target": [0,0,0]}]}})", "s.json"); },
                "/initialise/landmarks: landmark pairs: 1 landmark pairs; at least 4");
    expectError([&] { parseScene(base + R"("initialise": {"transform": "x.tfm", "levels": 2}})", "s.json"); },
                "/initialise/levels: goes with 'registration'");
    expectError([&] { parseScene(base + R"("initialise": {"registration": "affine", "samples": 100}})", "s.json"); },
                "/initialise/samples: must be in [1000, 100000000]");
    // "bspline": rigid, affine, then a B-spline of kDefaultBSplineCells unless "bspline_cells" says;
    // written back so.
    const SceneDesc b = parseScene(base + R"("initialise": {"registration": "bspline"}})", "/d/s.json");
    QVERIFY(b.initialise.affine);
    QCOMPARE(b.initialise.bsplineCells, kDefaultBSplineCells);
    const SceneDesc b3 = parseScene(base + R"("initialise": {"registration": "bspline", "bspline_cells": 3}})", "/d/s.json");
    QCOMPARE(b3.initialise.bsplineCells, 3);
    QCOMPARE(parseScene(sceneToJson(b3), "/d/s.json").initialise.bsplineCells, 3);
    QCOMPARE(parseScene(sceneToJson(s), "/d/s.json").initialise.bsplineCells, 0);
    expectError([&] { parseScene(base + R"("initialise": {"registration": "affine", "bspline_cells": 3}})", "s.json"); },
                "/initialise/bspline_cells: goes with \"registration\": \"bspline\"");
    expectError([&] { parseScene(base + R"("initialise": {"registration": "bspline", "bspline_cells": 0}})", "s.json"); },
                "/initialise/bspline_cells: must be in [1, 16]");
    expectError([&] { parseScene(base + R"("initialise": {"registration": "elastic"}})", "s.json"); },
                "expected \"rigid\", \"affine\" or \"bspline\"");
    std::string noModel = base;
    noModel.replace(noModel.find(R"("model": "m/", )"), 15, "");
    expectError([&] { parseScene(noModel + R"("report": {}})", "s.json"); }, "missing required key 'reference'");
  }

  // With share 1 the image forces become their least-squares affine field (here computed apart
  // with Eigen); an affine field is left as it is at any share; other forces are not touched.
  void affineRegularisationBlendsTheClosestAffineField() {
    Registry registry;
    registerBuiltinForces(registry);
    auto* field = new FieldForce;
    registry.addForce({"field", "test", {}, [field] { return std::unique_ptr<Force>(field); }});
    Simulation sim(registry, 2);
    sim.addStructure(sphereStructure("s", 2, 10.0f, Vec3(1, 2, 3)));
    sim.addForce("field");
    sim.setIntegrator("damped_verlet");
    sim.initialize();
    const auto x = sim.store().positions();
    const Index n = sim.store().vertexCount();
    std::mt19937 rng(7);
    std::normal_distribution<float> g(0.0f, 1.0f);
    field->field.resize(n);
    for (Index v = 0; v < n; ++v) field->field[v] = Vec3(0.1f * x[v].y(), 1.0f, -0.05f * x[v].z()) + Vec3(g(rng), g(rng), g(rng));

    // The least-squares affine field of the image forces at the positions the step starts from.
    auto affineFit = [&] {
      const auto x0 = sim.store().positions();
      Eigen::MatrixXd A(n, 4), B(n, 3);
      for (Index v = 0; v < n; ++v) {
        A.row(v) << x0[v].x(), x0[v].y(), x0[v].z(), 1.0;
        B.row(v) = field->field[v].cast<double>().transpose();
      }
      return Eigen::MatrixXd(A * A.colPivHouseholderQr().solve(B));
    };
    auto forcesWith = [&](float share) {
      sim.setAffineRegularisation(share);
      sim.step();
      return std::vector<Vec3>(sim.store().forces().begin(), sim.store().forces().end());
    };
    const auto none = forcesWith(0.0f);
    for (Index v = 0; v < n; ++v) QVERIFY((none[v] - field->field[v]).norm() < 1e-5f);
    const Eigen::MatrixXd fit = affineFit();
    const auto full = forcesWith(1.0f);
    double worst = 0.0;
    for (Index v = 0; v < n; ++v) worst = std::max(worst, (full[v].cast<double>() - fit.row(v).transpose()).norm());
    QVERIFY2(worst < 1e-3, qPrintable(QString::number(worst)));
    const Eigen::MatrixXd fitHalf = affineFit();
    const auto half = forcesWith(0.5f);
    for (Index v = 0; v < n; ++v) {
      const Vec3 expected = 0.5f * (Vec3(fitHalf.row(v).transpose().cast<float>()) + field->field[v]);
      QVERIFY((half[v] - expected).norm() < 1e-3f);
    }
    // An exactly affine field is its own closest affine field.
    const auto x1 = sim.store().positions();
    for (Index v = 0; v < n; ++v) field->field[v] = Vec3(0.1f * x1[v].y(), 1.0f, -0.05f * x1[v].z());
    const auto affine = forcesWith(1.0f);
    for (Index v = 0; v < n; ++v) QVERIFY((affine[v] - field->field[v]).norm() < 1e-4f);
  }

  // Multi-resolution forces (paper 001 section 2.1): at level 2 the shape forces are also computed
  // on levels 0 and 1 (their vertices are the level-2 vertices 16t and 4t) and carried up by the
  // prolongation. The added part is checked against simulations of those levels on the same positions.
  void coarseForcesAreCarriedFromTheCoarserLevel() {
    auto structure = [] {
      StructureSpec s = sphereStructure("s", 2, 10.0f, Vec3(1, 2, 3), 3);
      for (const Vec3& p : s.initialPositions) s.referencePositions.push_back(Vec3(1, 2, 3) + (p - Vec3(1, 2, 3)).cwiseProduct(Vec3(1.3f, 1.0f, 0.8f)));
      return s;
    };
    auto make = [&](int level) {
      auto sim = std::make_unique<Simulation>(forceRegistry(), 2);
      sim->addStructure(structure());
      sim->addForce("smoothing").setAll("weight", 0.3);
      sim->addForce("shape_prior");
      sim->setIntegrator("damped_verlet");
      sim->initialize();
      for (int l = 0; l < level; ++l) sim->advanceLevel();
      return sim;
    };
    // At level 2 both coarser levels contribute: level 0 (vertices 16t) and level 1 (vertices 4t).
    auto fine = make(2), plain = make(2), level0 = make(0), level1 = make(1);
    fine->run(5);  // off the reference's carried shape, so the forces are not zero
    const auto x = fine->store().positions();
    std::copy(x.begin(), x.end(), plain->store().positionsForWrite().begin());
    std::copy(fine->store().previousPositions().begin(), fine->store().previousPositions().end(),
              plain->store().previousPositions().begin());
    for (const auto& [c, stride] : {std::pair{level0.get(), 16}, std::pair{level1.get(), 4}}) {
      auto cx = c->store().positionsForWrite();
      for (Index t = 0; t < c->store().vertexCount(); ++t) cx[t] = x[stride * t];
      std::copy(cx.begin(), cx.end(), c->store().previousPositions().begin());
    }
    fine->setCoarseForceWeight(0.5f);
    for (auto* s : {fine.get(), plain.get(), level0.get(), level1.get()}) s->step();
    const auto& levels = fine->structure(0).levels;
    const auto from0 = levels.carry(level0->store().forces(), 0, 2), from1 = levels.carry(level1->store().forces(), 1, 2);
    double worst = 0.0, size = 0.0;
    for (Index v = 0; v < fine->store().vertexCount(); ++v) {
      const Vec3 added = fine->store().forces()[v] - plain->store().forces()[v];
      worst = std::max(worst, double((added - 0.5f * (from0[v] + from1[v])).norm()));
      size = std::max(size, double((from0[v] + from1[v]).norm()));
    }
    qInfo("coarse forces: up to %.3g, carried part off by %.3g", size, worst);
    QVERIFY(size > 0.05);
    QVERIFY(worst < 1e-4);
    // Off, nothing is added and nothing kept.
    fine->setCoarseForceWeight(0.0f);
    QCOMPARE(fine->coarseForceWeight(), 0.0f);
  }

  void modelFilesRoundTripAndRefuseDamage() {
    QTemporaryDir dir;
    const fs::path folder = fs::path(dir.path().toStdString()) / "model";
    const fs::path atlas = fs::path(dir.path().toStdString()) / "atlas.nii.gz";
    { std::ofstream(atlas) << "stand-in for the atlas image"; }
    Executor executor(2);
    Model m;
    m.atlasImage = atlas;
    m.createdBy = "test";
    const TriangleMesh shape = ellipsoidSurface(Vec3(0, 0, 0), Vec3(12, 9, 7), 3);
    BuiltModel b = buildModelFromMesh(shape, "ellipsoid", 3, executor);
    m.structures.push_back({"Ellipsoid", 5, b.levels, b.positions});
    m.structures.push_back({"Ellipsoid_L", 6, b.levels, b.positions, "left"});  // a side of a label split by side
    const Registry& registry = builtinRegistry();
    writeModel(registry, m, folder);
    const Model back = readModel(registry, folder);
    QCOMPARE(back.structures.size(), size_t(2));
    QCOMPARE(back.structures[0].label, 5);
    QCOMPARE(back.structures[0].side, std::string());
    QCOMPARE(back.structures[1].side, std::string("left"));
    QCOMPARE(back.levelCount(), 3);
    for (int l = 0; l < 3; ++l) {
      QVERIFY(back.structures[0].levels.levels[l].neighbours == b.levels.levels[l].neighbours);
      QVERIFY(back.structures[0].positions[l] == b.positions[l]);  // float for float
    }
    // Damage: one byte of a mesh changed.
    const fs::path level1 = folder / "structures" / "Ellipsoid" / "level1.vtp";
    {
      std::fstream f(level1, std::ios::in | std::ios::out | std::ios::binary);
      f.seekp(-40, std::ios::end);
      f.put('#');
    }
    expectError([&] { readModel(registry, folder); }, QString::fromStdString(level1.string()) + ": checksum mismatch");
    // Another format version, and a side that is neither.
    writeModel(registry, m, folder);
    std::string text;
    {
      std::ifstream in(folder / "model.json");
      text.assign(std::istreambuf_iterator<char>(in), {});
    }
    { std::ofstream(folder / "model.json") << std::string(text).replace(text.find("\"left\""), 6, "\"up\""); }
    expectError([&] { readModel(registry, folder); }, "structure 'Ellipsoid_L': \"side\" must be \"left\" or \"right\", not \"up\"");
    text.replace(text.find("\"version\": 1"), 12, "\"version\": 7");
    { std::ofstream(folder / "model.json") << text; }
    expectError([&] { readModel(registry, folder); }, "model format version 7 is not supported");
    // A version beyond an integer's range (a float to nlohmann-json; cast unchecked it was
    // undefined behaviour, found by fuzz_model).
    text.replace(text.find("\"version\": 7"), 12, "\"version\": 1e46");
    { std::ofstream(folder / "model.json") << text; }
    expectError([&] { readModel(registry, folder); }, "\"version\" must be a whole number from");
    // Two structures of one name (their files would overwrite each other): refused.
    Model twice = m;
    twice.structures[1].name = "Ellipsoid";
    expectError([&] { writeModel(registry, twice, fs::path(dir.path().toStdString()) / "twice"); },
                "two structures are named 'Ellipsoid'");
    // A folder that is not a model is never replaced.
    const fs::path other = fs::path(dir.path().toStdString()) / "other";
    fs::create_directories(other);
    expectError([&] { writeModel(registry, m, other); }, "is not a Sinew model; refusing to replace it");
    QVERIFY(fs::is_empty(other));
  }
};

QTEST_GUILESS_MAIN(TestInitialisation)
#include "tst_initialisation.moc"
