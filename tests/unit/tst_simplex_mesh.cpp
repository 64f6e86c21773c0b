// 2-simplex meshes as duals of closed triangle meshes: invariants, refusals, tessellation.
#include "synthetic.h"

#include <QtTest>

#include <set>

using namespace sinew;

namespace {

// A torus (genus 1, Euler characteristic 0) as a closed triangle mesh.
TriangleMesh torus(int nu, int nv) {
  TriangleMesh m;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const float u = 2 * float(M_PI) * i / nu, v = 2 * float(M_PI) * j / nv;
      m.points.emplace_back((3 + std::cos(v)) * std::cos(u), (3 + std::cos(v)) * std::sin(u), std::sin(v));
    }
  auto id = [&](int i, int j) { return Index(((i + nu) % nu) * nv + (j + nv) % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

int triangleEuler(const TriangleMesh& m) {
  std::set<std::pair<Index, Index>> edges;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) edges.insert(std::minmax(t[k], t[(k + 1) % 3]));
  return int(m.points.size()) - int(edges.size()) + int(m.triangles.size());
}

void checkInvariants(const SimplexTopology& t) {
  for (Index v = 0; v < t.vertexCount(); ++v) {
    const auto& n = t.neighbours[v];
    QVERIFY2(n[0] != n[1] && n[1] != n[2] && n[0] != n[2], "neighbours must be distinct");
    for (Index w : n) {
      QVERIFY(w != v && w >= 0 && w < t.vertexCount());
      const auto& back = t.neighbours[w];
      QVERIFY2(std::count(back.begin(), back.end(), v) == 1, "adjacency must be symmetric");
    }
    // The edge to neighbour j separates cells j and j+1: both must contain v and n[j].
    for (int j = 0; j < 3; ++j)
      for (Index c : {t.vertexCells[v][j], t.vertexCells[v][(j + 1) % 3]}) {
        const auto b = t.cellVertices.begin() + t.cellOffsets[c], e = t.cellVertices.begin() + t.cellOffsets[c + 1];
        QVERIFY(std::find(b, e, v) != e);
        QVERIFY(std::find(b, e, n[j]) != e);
      }
  }
  // Cells are closed cycles of neighbouring vertices.
  std::vector<int> cellsPerVertex(t.vertexCount(), 0);
  for (Index c = 0; c < t.cellCount(); ++c) {
    const Index b = t.cellOffsets[c], e = t.cellOffsets[c + 1];
    QVERIFY(e - b >= 3);
    for (Index i = b; i < e; ++i) {
      const Index v = t.cellVertices[i], w = t.cellVertices[i + 1 == e ? b : i + 1];
      QVERIFY2(std::count(t.neighbours[v].begin(), t.neighbours[v].end(), w) == 1,
               "consecutive cell vertices must be neighbours");
      ++cellsPerVertex[v];
    }
  }
  for (int n : cellsPerVertex) QCOMPARE(n, 3);
}

std::vector<int> valences(const TriangleMesh& m) {
  std::vector<int> v(m.points.size(), 0);
  for (const auto& t : m.triangles)
    for (Index i : t) ++v[i];  // a closed mesh: as many triangles as edges at each vertex
  return v;
}

// Flips edge (a, b) between the triangle holding a -> b and the one holding b -> a.
void flipEdge(TriangleMesh& m, Index a, Index b) {
  int t0 = -1, t1 = -1, k0 = 0, k1 = 0;
  for (int t = 0; t < int(m.triangles.size()); ++t)
    for (int k = 0; k < 3; ++k) {
      if (m.triangles[t][k] == a && m.triangles[t][(k + 1) % 3] == b) t0 = t, k0 = k;
      if (m.triangles[t][k] == b && m.triangles[t][(k + 1) % 3] == a) t1 = t, k1 = k;
    }
  const Index c = m.triangles[t0][(k0 + 2) % 3], d = m.triangles[t1][(k1 + 2) % 3];
  m.triangles[t0] = {a, d, c};
  m.triangles[t1] = {d, b, c};
}

// An icosphere of 642 points, one of whose points of valence 6 is raised to 9 or 10 by flipping
// edges opposite it (what a decimation leaves behind, on a smooth surface); its neighbours keep
// valences of 5 or more.
constexpr Index kRaised = 100;
TriangleMesh sphereWithARaisedValence() {
  TriangleMesh m = icosphere(3);
  for (bool flipped = true; flipped && valences(m)[kRaised] < 10;) {
    flipped = false;
    const auto val = valences(m);
    for (const auto& t : m.triangles) {
      const int k = int(std::find(t.begin(), t.end(), kRaised) - t.begin());
      if (k == 3 || val[t[(k + 1) % 3]] < 6 || val[t[(k + 2) % 3]] < 6) continue;
      flipEdge(m, t[(k + 1) % 3], t[(k + 2) % 3]);
      flipped = true;
      break;
    }
  }
  return m;
}

void expectRefusal(const TriangleMesh& m, const QString& needle1, const QString& needle2) {
  try {
    SimplexTopology::dualOf(m);
    QFAIL("the mesh was accepted");
  } catch (const InputError& e) {
    const QString msg = QString::fromUtf8(e.what());
    QVERIFY2(msg.contains(needle1) && msg.contains(needle2), qPrintable("unexpected message: " + msg));
  }
}

}  // namespace

class TestSimplexMesh : public QObject {
  Q_OBJECT
private slots:
  void generatorsAreClosedAndOutward() {
    for (int level = 0; level <= 3; ++level) {
      for (const TriangleMesh& m : {icosphere(level), octasphere(level), tetrasphere(level)}) {
        validateClosedManifold(m);
        QVERIFY(m.volume() > 0.0);
      }
      QCOMPARE(icosphere(level).triangles.size(), size_t(20) << (2 * level));
    }
  }

  void dualHasThreeNeighboursAndClosedCells_data() {
    QTest::addColumn<int>("level");
    for (int l = 0; l <= 4; ++l) QTest::newRow(qPrintable(QString("icosphere %1").arg(l))) << l;
  }
  void dualHasThreeNeighboursAndClosedCells() {
    QFETCH(int, level);
    const TriangleMesh tri = icosphere(level, 10.0f);
    const SimplexMesh s = SimplexMesh::dualOf(tri);
    QCOMPARE(s.topology.vertexCount(), Index(tri.triangles.size()));
    QCOMPARE(s.topology.cellCount(), Index(tri.points.size()));
    checkInvariants(s.topology);
    QCOMPARE(s.topology.eulerCharacteristic(), triangleEuler(tri));
    QCOMPARE(s.topology.eulerCharacteristic(), 2);
  }

  void eulerCharacteristicPreservedOnTorus() {
    const TriangleMesh tri = torus(24, 12);
    const SimplexMesh s = SimplexMesh::dualOf(tri);
    checkInvariants(s.topology);
    QCOMPARE(triangleEuler(tri), 0);
    QCOMPARE(s.topology.eulerCharacteristic(), 0);
  }

  void tessellationIsClosedAndConsistentlyOriented() {
    for (const TriangleMesh& tri : {icosphere(3, 5.0f), torus(24, 12)}) {
      const SimplexMesh s = SimplexMesh::dualOf(tri);
      const TriangleMesh tess = tessellate(s.topology, s.positions);
      validateClosedManifold(tess);  // throws on inconsistent orientation
      QVERIFY(tess.volume() > 0.0);  // outward
      QCOMPARE(tess.triangles.size(), s.topology.cellVertices.size());
      QCOMPARE(tess.points.size(), size_t(s.topology.vertexCount() + s.topology.cellCount()));
    }
  }

  void normalsFromNeighbourOrderPointOutward() {
    const SimplexMesh s = SimplexMesh::sphere(2, 3.0f, Vec3(1, 2, 3));
    for (Index v = 0; v < s.topology.vertexCount(); ++v) {
      const auto& n = s.topology.neighbours[v];
      const auto f = neighbourFrame(s.positions[n[0]], s.positions[n[1]], s.positions[n[2]]);
      QVERIFY(f.normal.dot(s.positions[v] - Vec3(1, 2, 3)) > 0.9f * 3.0f);
    }
  }

  void dualOfTheDualIsTheSameMesh() {
    // The dual back (cell centres, one triangle per simplex vertex) is a valid closed mesh whose
    // own dual has the original simplex topology.
    const SimplexMesh s = SimplexMesh::dualOf(icosphere(2));
    const TriangleMesh back = dualTriangleMesh(s.topology, s.positions);
    validateClosedManifold(back);
    QVERIFY(back.volume() > 0.0);
    const SimplexTopology again = SimplexTopology::dualOf(back);
    QCOMPARE(again.neighbours, s.topology.neighbours);
    QCOMPARE(again.cellVertices, s.topology.cellVertices);
  }

  // Model building lowers a decimated surface's high valences before taking its dual: the cell of
  // 9 or 10 vertices becomes cells of at most 7, the mesh stays valid and keeps its points and volume.
  void lowerHighValencesSplitsALargeCell() {
    TriangleMesh m = sphereWithARaisedValence();
    QVERIFY(valences(m)[kRaised] >= 9);
    const TriangleMesh before = m;
    QVERIFY(lowerHighValences(m) > 0);
    const std::vector<int> after = valences(m);
    QVERIFY2(*std::max_element(after.begin(), after.end()) <= 7, "a valence of 8 or more is left");
    QVERIFY(*std::min_element(after.begin(), after.end()) >= 4);
    validateClosedManifold(m);
    QCOMPARE(m.triangles.size(), before.triangles.size());
    QVERIFY(m.points == before.points);
    QVERIFY(std::abs(m.volume() / before.volume() - 1.0) < 1e-3);
    QCOMPARE(triangleEuler(m), 2);
    const SimplexTopology dual = SimplexTopology::dualOf(m);
    checkInvariants(dual);
    for (Index c = 0; c < dual.cellCount(); ++c) QVERIFY(dual.cellOffsets[c + 1] - dual.cellOffsets[c] <= 7);
  }

  // Across a crease a flip would cut into the shape: the raised point pulled out into a spike,
  // whose neighbouring triangles are far from coplanar, keeps its edges.
  void lowerHighValencesKeepsCreases() {
    TriangleMesh m = sphereWithARaisedValence();
    m.points[kRaised] *= 3.0f;
    const TriangleMesh before = m;
    QCOMPARE(lowerHighValences(m), 0);
    QVERIFY(m.triangles == before.triangles);
    // It is the fold limit that holds them: without it, the spike's edges are flipped.
    QVERIFY(lowerHighValences(m, 8, 4, 179.0f) > 0);
  }

  void refusesOpenMesh() {
    TriangleMesh m = icosphere(1);
    m.triangles.pop_back();
    expectRefusal(m, "open", "edge (");
  }

  void refusesInconsistentOrientation() {
    TriangleMesh m = icosphere(1);
    std::swap(m.triangles[7][1], m.triangles[7][2]);
    expectRefusal(m, "inconsistently oriented", "triangles");
  }

  void refusesNonManifoldEdge() {
    TriangleMesh m = icosphere(0);
    const auto t = m.triangles[0];
    // A fin: a new vertex hanging off edge (t0, t1), closed so the only fault is the edge.
    m.points.push_back(Vec3(3, 3, 3));
    const Index p = Index(m.points.size()) - 1;
    m.triangles.push_back({t[1], t[0], p});
    m.triangles.push_back({t[0], t[1], p});
    expectRefusal(m, "more than two triangles", "edge");
  }

  void refusesNonManifoldVertex() {
    // Two tetrahedra sharing one vertex (index 0).
    TriangleMesh m = tetrasphere(0);
    TriangleMesh second = tetrasphere(0, 1.0f, Vec3(2, 2, 2));
    const Index base = Index(m.points.size()) - 1;
    for (size_t i = 1; i < second.points.size(); ++i) m.points.push_back(second.points[i]);
    for (auto t : second.triangles) {
      for (Index& v : t) v = v == 0 ? 0 : v + base;
      m.triangles.push_back(t);
    }
    expectRefusal(m, "vertex 0", "non-manifold");
  }

  void refusesBadIndicesAndDegenerates() {
    TriangleMesh m = icosphere(0);
    m.triangles[3][2] = 99;
    expectRefusal(m, "triangle 3", "vertex 99");
    m = icosphere(0);
    m.triangles[2][1] = m.triangles[2][0];
    expectRefusal(m, "triangle 2", "degenerate");
    m = icosphere(0);
    m.points.push_back(Vec3::Zero());
    expectRefusal(m, "vertex 12", "not used");
  }

  // Of several problems, the one a scan of the triangles in order meets first is named (the
  // directed edges are grouped by vertex, not met in that order, so this is checked).
  void namesTheFirstProblemInTriangleOrder() {
    TriangleMesh m = icosphere(1);
    m.triangles[12][1] = m.triangles[12][0];               // degenerate
    m.triangles.push_back(m.triangles[30]);                // an edge used twice, after it
    expectRefusal(m, "triangle 12", "degenerate");
    m = icosphere(1);
    m.triangles[60][1] = m.triangles[60][0];               // degenerate, after the repeat
    std::swap(m.triangles[5][1], m.triangles[5][2]);       // triangle 5 reversed
    expectRefusal(m, "and 5", "inconsistently oriented");
    m = icosphere(1);
    const auto repeated = m.triangles[20];
    m.triangles.insert(m.triangles.begin() + 40, repeated);  // triangle 40 repeats triangle 20
    m.triangles[60][2] = 999;                                // out of range, after it
    expectRefusal(m, "by triangles 20 and 40", "same direction");
  }
};

QTEST_APPLESS_MAIN(TestSimplexMesh)
#include "tst_simplex_mesh.moc"
