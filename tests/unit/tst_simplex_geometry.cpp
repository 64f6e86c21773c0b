// Per-vertex geometry: simplex parameters (invariance, reconstruction), normals, elevation, areas,
// masses, and derived quantities that are never stale.
#include "synthetic.h"

#include <QtTest>

#include <random>

using namespace sinew;
using namespace sinew::testing;

namespace {
using V3d = Eigen::Vector3d;

SimplexParamsT<double> paramsAt(const std::vector<V3d>& x, const SimplexTopology& t, Index v) {
  const auto& n = t.neighbours[v];
  const auto f = neighbourFrame(x[n[0]], x[n[1]], x[n[2]]);
  return simplexParams(x[v], x[n[0]], x[n[1]], x[n[2]], f);
}

double relErr(double a, double b) { return std::abs(a - b) / std::max(std::abs(a), std::abs(b)); }
}  // namespace

class TestSimplexGeometry : public QObject {
  Q_OBJECT
private slots:
  void parametersAreInvariantUnderSimilarity() {
    // Formulas checked in double; the store runs the same code in float.
    const SimplexMesh m = SimplexMesh::sphere(3, 10.0f);
    const auto noisy = withNoise(m.positions, 0.3f, 7);
    std::vector<V3d> x;
    for (const Vec3& p : noisy) x.push_back(p.cast<double>());
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int trial = 0; trial < 10; ++trial) {
      const Eigen::Matrix3d R =
          Eigen::Quaterniond(Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
      const double s = std::exp(2.0 * u(rng));  // 0.14 .. 7.4
      const V3d t(100 * u(rng), 100 * u(rng), 100 * u(rng));
      std::vector<V3d> y;
      for (const V3d& p : x) y.push_back(s * (R * p) + t);
      for (Index v = 0; v < m.topology.vertexCount(); ++v) {
        const auto a = paramsAt(x, m.topology, v), b = paramsAt(y, m.topology, v);
        QVERIFY2(relErr(a.eps1, b.eps1) < 1e-5 && relErr(a.eps2, b.eps2) < 1e-5 && relErr(a.phi, b.phi) < 1e-5,
                 qPrintable(QString("vertex %1 trial %2: phi %3 vs %4").arg(v).arg(trial).arg(a.phi).arg(b.phi)));
      }
    }
  }

  void meshRebuiltFromItsParametersReproducesItself() {
    // Heavy noise (a third of the edge length) puts many foot points outside the neighbours'
    // circumcircle, where the elevation hint picks the root (see elevationFromAngle).
    const SimplexMesh m = SimplexMesh::sphere(3, 10.0f);
    const auto noisy = withNoise(m.positions, 0.2f, 3);
    // Double: exact to rounding.
    std::vector<V3d> x;
    for (const Vec3& p : noisy) x.push_back(p.cast<double>());
    for (Index v = 0; v < m.topology.vertexCount(); ++v) {
      const auto& n = m.topology.neighbours[v];
      const auto f = neighbourFrame(x[n[0]], x[n[1]], x[n[2]]);
      const V3d back =
          positionFromParams(x[n[0]], x[n[1]], x[n[2]], f, paramsAt(x, m.topology, v), elevation(x[v], x[n[0]], f));
      QVERIFY2((back - x[v]).norm() < 1e-9, qPrintable(QString("vertex %1: %2").arg(v).arg((back - x[v]).norm())));
    }
    // Float, through the store's parameters.
    MeshStore store(std::vector<const SimplexTopology*>{&m.topology});
    store.require(Attribute::SimplexParams);
    auto w = store.positionsForWrite();
    std::copy(noisy.begin(), noisy.end(), w.begin());
    const auto params = store.simplexParams();
    const auto xs = store.positions();
    for (Index v = 0; v < store.vertexCount(); ++v) {
      const auto& n = store.neighbours()[v];
      const auto f = neighbourFrame(xs[n[0]], xs[n[1]], xs[n[2]]);
      const float hint = elevation(xs[v], xs[n[0]], f);
      QVERIFY((positionFromParams(xs[n[0]], xs[n[1]], xs[n[2]], f, params[v], hint) - xs[v]).norm() < 1e-4f);
    }
  }

  // isFoldedReference: no vertex of a slightly noisy sphere; a vertex carried past its neighbours'
  // triangle (its foot 3 triangle sizes out) or raised into a spike. followableReference
  // neutralises those.
  void foldedReferencesAreToldFromHealthyOnes() {
    const SimplexMesh m = SimplexMesh::sphere(3, 10.0f);
    std::vector<V3d> x;
    for (const Vec3& p : withNoise(m.positions, 0.1f, 7)) x.push_back(p.cast<double>());
    for (Index v = 0; v < m.topology.vertexCount(); ++v) QVERIFY(!isFoldedReference(paramsAt(x, m.topology, v)));
    const auto& n = m.topology.neighbours[0];
    const V3d centroid = (x[n[0]] + x[n[1]] + x[n[2]]) / 3.0;
    std::vector<V3d> slid = x, spiked = x;
    slid[0] = centroid + 3.0 * (x[n[0]] - centroid);
    spiked[0] = centroid + 20.0 * (x[n[0]] - x[n[1]]).norm() * x[0].normalized();
    const auto a = paramsAt(slid, m.topology, 0), b = paramsAt(spiked, m.topology, 0);
    qInfo("slid: eps %.2f %.2f %.2f; spike: phi %.1f degrees", a.eps1, a.eps2, a.eps3(), b.phi * 180 / M_PI);
    QVERIFY(isFoldedReference(a));
    QVERIFY(isFoldedReference(b));
    const auto neutral = followableReference(a);
    QCOMPARE(neutral.eps1, 1.0 / 3.0);
    QCOMPARE(neutral.phi, 0.0);
    QCOMPARE(followableReference(paramsAt(x, m.topology, 0)).eps1, paramsAt(x, m.topology, 0).eps1);
  }

  void flatNeighbourhoodHasZeroAngleAndElevation() {
    const Vec3 p1(0, 0, 0), p2(1, 0, 0), p3(0, 1, 0);
    const auto f = neighbourFrame(p1, p2, p3);
    const auto s = simplexParams(Vec3(0.3f, 0.3f, 0.0f), p1, p2, p3, f);
    QVERIFY(std::abs(s.phi) < 1e-6f);
    QVERIFY(std::abs(s.eps1 - 0.4f) < 1e-6f && std::abs(s.eps2 - 0.3f) < 1e-6f);
    QVERIFY(std::abs(elevation(Vec3(0.3f, 0.3f, 2.0f), p1, f) - 2.0f) < 1e-6f);
    QVERIFY(std::abs(f.normal.z() - 1.0f) < 1e-6f);
  }

  void areasMassesAndCentres() {
    const SimplexMesh m = SimplexMesh::sphere(2, 5.0f);
    MeshStore store(std::vector<const SimplexTopology*>{&m.topology});
    store.require(Attribute::Mass);
    QVERIFY(store.has(Attribute::Area) && store.has(Attribute::CellCentre));
    std::copy(m.positions.begin(), m.positions.end(), store.positionsForWrite().begin());
    store.setDensity(0, 2.5f);
    const auto area = store.areas();
    const auto mass = store.masses();
    // Each Fig. 1b triangle (vertex, next vertex, cell centre) is counted at its two vertices.
    const double tessArea = tessellate(m.topology, m.positions).area();
    double sum = 0;
    for (Index v = 0; v < store.vertexCount(); ++v) {
      sum += area[v];
      QVERIFY(std::abs(mass[v] - 2.5f * area[v]) < 1e-5f * mass[v]);
    }
    QVERIFY(std::abs(sum - 2.0 * tessArea) < 1e-4 * sum);
    const auto centres = store.cellCentres();
    const auto expected = cellCentres(m.topology, m.positions);
    for (Index c = 0; c < store.cellCount(); ++c) QVERIFY((centres[c] - expected[c]).norm() < 1e-5f);
  }

  // mass = max(area x density, floor): the floor lifts the light vertices and leaves the others, and
  // the simulation sets it as a share of each structure's mean vertex mass at the level's start.
  void massFloorLiftsOnlyTheLightVertices() {
    // A sphere squashed along one axis, so that its vertices' areas differ.
    SimplexMesh m = SimplexMesh::sphere(2, 5.0f);
    for (Vec3& p : m.positions) p.z() *= 0.3f;
    MeshStore store(std::vector<const SimplexTopology*>{&m.topology});
    store.require(Attribute::Mass);
    std::copy(m.positions.begin(), m.positions.end(), store.positionsForWrite().begin());
    store.setDensity(0, 2.5f);
    std::vector<float> sorted(store.areas().begin(), store.areas().end());
    std::sort(sorted.begin(), sorted.end());
    const float floor = 2.5f * sorted[sorted.size() / 2];  // the median vertex's mass
    store.setMassFloor(0, floor);
    const auto area = store.areas();
    const auto mass = store.masses();  // recomputed: the floor makes the masses stale
    int lifted = 0, kept = 0;
    for (Index v = 0; v < store.vertexCount(); ++v) {
      QCOMPARE(mass[v], std::max(2.5f * area[v], floor));
      (2.5f * area[v] < floor ? lifted : kept)++;
    }
    QVERIFY(lifted > 0 && kept > 0);

    auto sim = std::make_unique<Simulation>(forceRegistry(), 1);
    for (float share : {0.0f, 0.6f}) {
      StructureSpec s = sphereStructure("s" + std::to_string(int(share * 10)), 2, 5.0f, Vec3(16 + 20 * share, 16, 16));
      for (Vec3& p : s.initialPositions) p.z() = 16 + 0.3f * (p.z() - 16);
      s.referencePositions = s.initialPositions;
      s.massFloor = share;
      sim->addStructure(std::move(s));
    }
    sim->addForce("smoothing");
    sim->setIntegrator("damped_verlet");
    sim->initialize();
    MeshStore& st = sim->store();
    for (Index k = 0; k < 2; ++k) {
      const MeshRange& r = st.range(k);
      double total = 0;
      float lightest = 1e30f;
      for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) total += st.areas()[v] * st.density(k);
      for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) lightest = std::min(lightest, st.masses()[v]);
      const double mean = total / r.vertexCount();  // auto density: 1
      QVERIFY(std::abs(mean - 1.0) < 1e-4);
      QVERIFY(std::abs(st.massFloor(k) - (k == 0 ? 0.0 : 0.6 * mean)) < 1e-5);
      if (k == 0) QVERIFY(lightest < 0.6f);  // without the floor some vertices are lighter
      else QVERIFY(lightest >= 0.6f * float(mean) - 1e-5f);
    }
  }

  void derivedGeometryIsNeverStale() {
    const SimplexMesh m = SimplexMesh::sphere(2, 5.0f);
    MeshStore store(std::vector<const SimplexTopology*>{&m.topology});
    store.require(Attribute::Normal);
    store.require(Attribute::Elevation);
    std::copy(m.positions.begin(), m.positions.end(), store.positionsForWrite().begin());
    const float before = store.elevations()[0];
    const Vec3 normal0 = store.normals()[0];
    // Move vertex 0 outward: its elevation must follow without any explicit refresh call.
    store.positionsForWrite()[0] += 0.7f * normal0;
    QVERIFY(std::abs(store.elevations()[0] - (before + 0.7f)) < 1e-4f);
    // Rotate everything: normals follow.
    const Eigen::Matrix3f R = Eigen::AngleAxisf(0.5f, Vec3(0, 0, 1)).toRotationMatrix();
    for (Vec3& p : store.positionsForWrite()) p = R * p;
    QVERIFY((store.normals()[0] - R * normal0).norm() < 1e-4f);
    // Unrequired attributes are not handed out.
    QVERIFY_THROWS_EXCEPTION(std::logic_error, store.areas());
  }
};

QTEST_APPLESS_MAIN(TestSimplexGeometry)
#include "tst_simplex_geometry.moc"
