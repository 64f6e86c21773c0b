// Acceptance tests of the seed's forces and damped Verlet on shapes and images with known answers.
#include "sinew/core/image_fit.h"
#include "synthetic.h"

#include <Eigen/Geometry>
#include <QtTest>

#include <cstring>

using namespace sinew;
using namespace sinew::testing;

namespace {

double volumeOf(MeshStore& s, Index m = 0) { return tessellationOf(s, m).volume(); }

// Winding number of a closed triangle mesh about p (Van Oosterom and Strackee's solid angles): about
// 1 inside, 0 outside. Independent of the force's own side test on the closest vertex's normal.
double windingNumber(const TriangleMesh& mesh, const Vec3& p) {
  double total = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = (mesh.points[t[0]] - p).cast<double>(), b = (mesh.points[t[1]] - p).cast<double>(),
                          c = (mesh.points[t[2]] - p).cast<double>();
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    total += 2 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return total / (4 * M_PI);
}

double meanEdgeLength(MeshStore& s) {
  const auto x = s.positions();
  double sum = 0;
  for (Index v = 0; v < s.vertexCount(); ++v)
    for (Index n : s.neighbours()[v]) sum += (x[v] - x[n]).norm();
  return sum / (3.0 * s.vertexCount());
}

// RMS distance between corresponding points after the best similarity transform (Umeyama).
double rmsAfterSimilarity(std::span<const Vec3> a, std::span<const Vec3> b) {
  Eigen::Matrix3Xd A(3, a.size()), B(3, b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    A.col(i) = a[i].cast<double>();
    B.col(i) = b[i].cast<double>();
  }
  const Eigen::Matrix4d T = Eigen::umeyama(A, B, true);
  const Eigen::Matrix3Xd mapped = (T.topLeftCorner<3, 3>() * A).colwise() + T.topRightCorner<3, 1>();
  return std::sqrt((mapped - B).colwise().squaredNorm().mean());
}

// A smooth, non-spherical reference shape (an ellipsoid with a bump).
std::vector<Vec3> bumpyEllipsoid(const std::vector<Vec3>& unitSphere) {
  std::vector<Vec3> out;
  for (const Vec3& u : unitSphere) {
    const float bump = 1.0f + 0.15f * std::exp(-4.0f * (u - Vec3(0.6f, 0.6f, 0.5f).normalized()).squaredNorm());
    out.push_back(bump * u.cwiseProduct(Vec3(20, 14, 11)));
  }
  return out;
}

struct EllipsoidCase {
  EllipsoidImageSpec image;
  TriangleMesh truth;
  StructureSpec start;
  std::vector<Vec3> referenceOnTruth;  // same topology as start, sitting on the true surface
};

EllipsoidCase ellipsoidCase(int level) {
  EllipsoidCase c;
  c.truth = ellipsoidSurface(c.image.centre, c.image.radii, 5);
  const float r = std::cbrt(c.image.radii.prod());
  // A sphere of the ellipsoid's volume, its centre 3 voxels off along x.
  c.start = sphereStructure("ellipsoid", level, r, c.image.centre + Vec3(3 * c.image.spacing, 0, 0));
  for (const Vec3& p : SimplexMesh::sphere(level, 1.0f).positions)
    c.referenceOnTruth.push_back(onEllipsoid(p, c.image.centre, c.image.radii));
  return c;
}

double assdVoxels(MeshStore& s, const EllipsoidCase& c) {
  return surfaceDistance(tessellationOf(s, 0), c.truth, 0.25f).assd / c.image.spacing;
}

// The intensity profile alone on the case's image, trained on `training` (what the image fit tests
// score), at the case's initial positions.
std::unique_ptr<Simulation> profileScene(const EllipsoidCase& c, const EllipsoidImageSpec& training) {
  auto sim = std::make_unique<Simulation>(forceRegistry());
  sim->addStructure(c.start);
  sim->addForce("intensity_profile");
  sim->setIntegrator("damped_verlet");
  sim->scene().setTargetImage(std::make_shared<Image3D>(ellipsoidImage(c.image)));
  sim->scene().setTrainingImage(std::make_shared<Image3D>(ellipsoidImage(training)));
  sim->initialize();
  return sim;
}

}  // namespace

class TestForces : public QObject {
  Q_OBJECT
private slots:
  void smoothingRemovesNoiseWithoutShrinking() {
    StructureSpec s = sphereStructure("ball", 4, 20.0f, Vec3::Zero());
    s.initialPositions = withNoise(s.initialPositions, 0.3f, 11);
    Simulation sim(forceRegistry());
    sim.addStructure(s);
    sim.addForce("smoothing");
    sim.setIntegrator("damped_verlet");
    sim.initialize();
    const double dev0 = fitSphere(sim.store().positions()).meanDeviation;
    const double vol0 = volumeOf(sim.store());
    sim.run(200);
    const double dev1 = fitSphere(sim.store().positions()).meanDeviation;
    const double vol1 = volumeOf(sim.store());
    qInfo("deviation %.4f -> %.4f mm (%.1fx), volume change %.3f %%", dev0, dev1, dev0 / dev1,
          100.0 * (vol1 - vol0) / vol0);
    QVERIFY(dev0 / dev1 >= 5.0);
    QVERIFY(std::abs(vol1 - vol0) / vol0 < 0.02);
  }

  void shapePriorRestoresTheReferenceShape() {
    // Paper 000 Fig. 2: a reference shape with 1-voxel noise (1 mm voxels) returns to the reference
    // up to a similarity transform.
    const SimplexMesh sphere = SimplexMesh::sphere(3, 1.0f);
    StructureSpec s;
    s.name = "bone";
    s.levels = LevelHierarchy::build(sphere.topology, 1);
    s.referencePositions = bumpyEllipsoid(sphere.positions);
    s.initialPositions = withNoise(s.referencePositions, 1.0f / std::sqrt(3.0f), 5);  // 1 mm RMS
    Simulation sim(forceRegistry());
    sim.addStructure(s);
    sim.addForce("shape_prior");
    sim.setIntegrator("damped_verlet");
    sim.initialize();
    const double edge = meanEdgeLength(sim.store());
    const double before = rmsAfterSimilarity(sim.store().positions(), s.referencePositions) / edge;
    sim.run(1500);
    const double after = rmsAfterSimilarity(sim.store().positions(), s.referencePositions) / edge;
    qInfo("RMS to reference: %.4f -> %.4f edge lengths (edge %.2f mm)", before, after, edge);
    QVERIFY(after <= 0.05);
  }

  // A vertex 40 edge lengths out of its place: the shape prior pulls it at most kPriorReach times
  // its neighbours' longest edge, where without the limit its pull is the spike's whole height (on
  // new subjects' cortical labels, a reference folded at a vertex pulled it 130-270 mm in one step).
  void shapePriorPullIsHeldNearTheNeighbours() {
    const SpikedSphere spiked = spikedSphere(40.0f);
    Simulation sim(forceRegistry());
    sim.addStructure(spiked.spec);
    sim.addForce("shape_prior");
    sim.setIntegrator("damped_verlet");
    sim.initialize();
    sim.run(1);  // the forces at the start's positions
    const float pull = sim.store().forces()[0].norm();
    qInfo("spike 40 edges high: pull %.2f mm, limit %.2f mm", pull, spiked.limit);
    QVERIFY(pull <= spiked.limit * 1.0001f);
    QVERIFY(pull >= 0.99f * spiked.limit);  // held at the limit, not a small pull
  }

  // A reference folded at a vertex (here a spike 40 edge lengths out) gives that vertex neutral
  // parameters (isFoldedReference): it stays with its neighbours instead of being pulled, at the
  // limit every step, to the spike (on a new subject, a vertex of Lingual_L ended 15 mm out; here,
  // without the neutral parameters, 59 mm). The neighbours' own references still include the spike
  // and dent the surface there (2.5 edge lengths measured), so the bound is 3.
  void shapePriorIgnoresAReferenceFoldedAtAVertex() {
    const SpikedSphere spiked = spikedSphere(40.0f, true);
    Simulation sim(forceRegistry());
    sim.addStructure(spiked.spec);
    sim.addForce("shape_prior");
    sim.setIntegrator("damped_verlet");
    sim.initialize();
    const double edge = meanEdgeLength(sim.store());
    sim.run(1);
    const float pull = sim.store().forces()[0].norm();
    sim.run(299);
    const float out = sim.store().positions()[0].norm() - 20.0f;  // the sphere's radius
    qInfo("reference spike 40 edges high: pull %.3f mm at the start, vertex %.3f mm off the sphere after 300 steps "
          "(edge %.2f mm, limit %.2f mm)", pull, out, edge, spiked.limit);
    QVERIFY(pull < 0.5 * edge);
    QVERIFY(std::abs(out) < 3.0 * edge);
  }

  void gradientForceFindsTheEllipsoid() {
    EllipsoidCase c = ellipsoidCase(3);
    Simulation sim(forceRegistry());
    sim.addStructure(c.start);
    sim.addForce("smoothing").setAll("weight", 0.3);
    sim.addForce("gradient").setAll("search_depth", 8.0);
    sim.setIntegrator("damped_verlet");
    sim.scene().setTargetImage(std::make_shared<Image3D>(ellipsoidImage(c.image)));
    sim.initialize();
    const double before = assdVoxels(sim.store(), c);
    sim.run(300);
    const double after = assdVoxels(sim.store(), c);
    qInfo("gradient: ASSD %.3f -> %.3f voxels", before, after);
    QVERIFY(before > 1.0);
    QVERIFY(after < 0.5);
  }

  void profileForceTrainedOnAnotherNoiseRealisationFindsTheEllipsoid() {
    EllipsoidCase c = ellipsoidCase(3);
    c.start.referencePositions = c.referenceOnTruth;
    EllipsoidImageSpec training = c.image;
    training.seed = 99;  // another noise realisation
    Simulation sim(forceRegistry());
    sim.addStructure(c.start);
    sim.addForce("smoothing").setAll("weight", 0.3);
    sim.addForce("intensity_profile").setAll("search_depth", 8.0);
    sim.setIntegrator("damped_verlet");
    sim.scene().setTargetImage(std::make_shared<Image3D>(ellipsoidImage(c.image)));
    sim.scene().setTrainingImage(std::make_shared<Image3D>(ellipsoidImage(training)));
    sim.initialize();
    const double before = assdVoxels(sim.store(), c);
    sim.run(300);
    const double after = assdVoxels(sim.store(), c);
    qInfo("intensity profile: ASSD %.3f -> %.3f voxels", before, after);
    QVERIFY(before > 1.0);
    QVERIFY(after < 0.5);
  }

  // The image fit (image_fit.h) of a surface on the boundary and of the same surface 8 mm off, in a
  // clean and a noisy image: the match falls with the miss and with the noise; the lines' agreement
  // with their parallels falls with the noise, so the fit corrected by it (imageFitOf: what
  // sinew-run reports) falls with the miss alone.
  void imageFitTellsAMissFromNoise() {
    const auto fitOf = [](float noise, float shiftMm) {
      EllipsoidCase c = ellipsoidCase(4);
      c.start.referencePositions = c.referenceOnTruth;
      c.start.initialPositions = c.referenceOnTruth;
      for (Vec3& p : c.start.initialPositions) p.x() += shiftMm;
      EllipsoidImageSpec training = c.image;
      training.seed = 99;
      c.image.noiseSigma = noise;
      const std::unique_ptr<Simulation> scene = profileScene(c, training);
      Simulation& sim = *scene;
      // Every vertex's scores are NCCs, in [-1, 1]; imageFitOf averages them.
      auto* fit = dynamic_cast<ImageFit*>(&sim.force("intensity_profile"));
      if (!fit) qFatal("the intensity profile offers no image fit");
      const Index n = sim.store().vertexCount();
      std::vector<float> match(n, -9.0f), agreement(n, -9.0f);
      ForceContext ctx{sim.store(), sim.forceParams("intensity_profile"), sim.scene(), sim.executor()};
      fit->fitScores(ctx, match, agreement);
      for (Index v = 0; v < n; ++v)
        if (!(std::abs(match[v]) <= 1.0001f && std::abs(agreement[v]) <= 1.0001f))
          qFatal("vertex %d: match %g, agreement %g", int(v), double(match[v]), double(agreement[v]));
      const std::vector<StructureImageFit> fits = imageFitOf(sim);
      if (fits.size() != 1) qFatal("one structure, %zu fits", fits.size());
      return fits[0];
    };
    const StructureImageFit on = fitOf(8.0f, 0.0f), onNoisy = fitOf(48.0f, 0.0f), off = fitOf(8.0f, 8.0f),
                            offNoisy = fitOf(48.0f, 8.0f);
    for (const auto& [name, f] : {std::pair{"on", on}, {"on, noisy", onNoisy}, {"off", off}, {"off, noisy", offNoisy}})
      qInfo("%-10s match %.3f agreement %.3f fit %.3f", name, f.match, f.agreement, f.fit);
    QVERIFY(on.fit > 0.9 && onNoisy.fit > 0.9);
    QVERIFY(onNoisy.match < on.match - 0.2);          // the noise lowers the match
    QVERIFY(std::abs(on.fit - onNoisy.fit) < 0.05);  // but not the fit
    QVERIFY(off.fit < on.fit - 0.2 && offNoisy.fit < onNoisy.fit - 0.2);  // a miss lowers both
  }

  // The image fit vertex by vertex (vertexImageFit: what the workstation colours): a surface on the
  // boundary but for one half pushed 6 mm out scores low on that half and high on the other, in a
  // clean and in a noisy image (the structure's noise correction keeps the boundary's score), and
  // never above the cap of 1.
  void vertexImageFitShowsWhereTheSurfaceMisses() {
    const auto medians = [](float noise) {
      EllipsoidCase c = ellipsoidCase(4);
      c.start.referencePositions = c.referenceOnTruth;
      c.start.initialPositions = c.referenceOnTruth;
      Vec3 centre = Vec3::Zero();
      for (const Vec3& p : c.referenceOnTruth) centre += p;
      centre /= float(c.referenceOnTruth.size());
      std::vector<bool> pushed(c.start.initialPositions.size());
      for (std::size_t v = 0; v < pushed.size(); ++v) {
        Vec3& p = c.start.initialPositions[v];
        // Well clear of the seam, where the smoothing mixes the two halves.
        pushed[v] = p.x() > centre.x() + 4.0f;
        if (pushed[v]) p += 6.0f * (p - centre).normalized();
      }
      EllipsoidImageSpec training = c.image;
      training.seed = 99;
      c.image.noiseSigma = noise;
      const std::unique_ptr<Simulation> scene = profileScene(c, training);
      const std::vector<float> fit = vertexImageFit(*scene);
      if (fit.size() != std::size_t(scene->store().vertexCount())) qFatal("%zu values", fit.size());
      std::vector<float> on, off;
      for (std::size_t v = 0; v < fit.size(); ++v) {
        if (!(fit[v] >= -1.0f && fit[v] <= 1.0f)) qFatal("vertex %zu: fit %g", v, double(fit[v]));
        if (pushed[v]) off.push_back(fit[v]);
        else if (scene->store().positions()[v].x() < centre.x() - 4.0f) on.push_back(fit[v]);
      }
      if (on.size() < 100 || off.size() < 100) qFatal("%zu and %zu vertices", on.size(), off.size());
      const auto median = [](std::vector<float> a) {
        std::nth_element(a.begin(), a.begin() + a.size() / 2, a.end());
        return a[a.size() / 2];
      };
      qInfo("noise %g: median fit on the boundary %.3f (%zu vertices), pushed off %.3f (%zu)", double(noise),
            double(median(on)), on.size(), double(median(off)), off.size());
      return std::pair{median(on), median(off)};
    };
    const auto [on, off] = medians(8.0f);
    const auto [onNoisy, offNoisy] = medians(48.0f);
    QVERIFY(on > 0.9 && onNoisy > 0.9);
    QVERIFY(off < on - 0.4 && offNoisy < onNoisy - 0.3);
    // Without a force that scores the image, nothing is known.
    EllipsoidCase c = ellipsoidCase(4);
    Simulation plain(forceRegistry());
    plain.addStructure(c.start);
    plain.addForce("smoothing");
    plain.setIntegrator("damped_verlet");
    plain.initialize();
    const std::vector<float> none = vertexImageFit(plain);
    QVERIFY(std::all_of(none.begin(), none.end(), [](float f) { return std::isnan(f); }));
  }

  // The profile force's line sampler: the values of sampleIndex at every sample, to the bit, for
  // lines inside the image (the path without clamps), across its border, outside it, along each
  // axis up to the last cell, and of one sample.
  void sampleLineEqualsSampleIndex() {
    ImageGeometry g;
    g.size = {13, 9, 7};
    g.spacing = Eigen::Vector3d(0.9, 1.1, 1.7);
    Image3D im(g);
    // Tiny values (odd indices) beside large ones: a + (b - a) * 1 is then not b, so a sample on
    // the last voxel plane tells whether it was taken from the last cell, as sampleIndex takes it.
    for (std::size_t i = 0; i < im.voxels().size(); ++i)
      im.voxels()[i] = i % 2 ? 1e-7f * float(i % 13 + 1) : float((i * 7919) % 1013) * 0.37f - 50.0f;
    struct Line {
      Vec3 start, step;
      int count;
    };
    std::vector<Line> lines = {
        {Vec3(1.2f, 1.7f, 0.4f), Vec3(0.31f, 0.17f, 0.13f), 30},   // inside
        {Vec3(0.3f, 7.2f, 5.1f), Vec3(-0.05f, 0.02f, 0.03f), 40},  // leaves through x = 0 and z = 6
        {Vec3(-3.0f, -2.0f, 9.0f), Vec3(0.2f, 0.1f, -0.1f), 50},   // starts outside, crosses in
        {Vec3(5.5f, 4.5f, 3.5f), Vec3(0.0f, 0.0f, 0.0f), 1},       // one sample
    };
    // Along each axis, to just short of the last voxel plane and onto it. From a voxel whose last
    // one along the line is tiny and the one before large (the voxel index's parity), the values
    // on the plane are exactly the two cells' blend; from (1.5, 1.5, 1.5) the lines cross cells.
    for (int a = 0; a < 3; ++a)
      for (const Vec3& start : {a == 0 ? Vec3(0, 1, 0) : Vec3(1, 0, 0), Vec3(1.5f, 1.5f, 1.5f)}) {
        Vec3 step = Vec3::Zero();
        step[a] = 0.25f;
        const int cells = g.size[a] - 1;
        lines.push_back({start, step, 4 * cells});      // the last sample 0.25 short of it
        lines.push_back({start, step, 4 * cells + 1});  // the last sample on it
      }
    for (const Line& l : lines) {
      std::vector<float> got(std::size_t(l.count));
      im.sampleLine(l.start, l.step, l.count, got.data());
      for (int q = 0; q < l.count; ++q) {
        const float want = im.sampleIndex(l.start + float(q) * l.step);
        QVERIFY2(std::memcmp(&got[q], &want, sizeof want) == 0,
                 qPrintable(QString("sample %1: %2 against %3").arg(q).arg(got[q]).arg(want)));
      }
    }
  }

  void attractionPointCapturesItsClosestVertex() {
    Simulation sim(forceRegistry());
    sim.addStructure(sphereStructure("ball", 3, 10.0f, Vec3::Zero()));
    sim.addForce("smoothing").setAll("weight", 0.1);
    sim.addForce("attraction_points");
    sim.setIntegrator("damped_verlet");
    sim.initialize();
    const Vec3 target(0.0f, 0.0f, 13.0f);  // 3 mm outside the sphere
    sim.scene().attractionPoints()[0].push_back(target);
    int steps = 0;
    float distance = 0;
    for (; steps < 400; ++steps) {
      sim.step();
      const auto x = sim.store().positions();
      distance = std::numeric_limits<float>::max();
      for (const Vec3& p : x) distance = std::min(distance, (p - target).norm());
      if (distance < 0.1f) break;
    }
    qInfo("closest vertex within %.3f mm after %d steps", distance, steps + 1);
    QVERIFY(distance < 0.1f);
  }

  // Include / exclude points (paper 001 section 4): a ball held by its shape prior is pushed until
  // the include point lies inside it and the exclude point outside; points already satisfied leave
  // the run exactly as it is without them.
  void includeAndExcludePointsEndOnTheirSide() {
    const auto run = [](const std::vector<ConstraintPoint>& points, int steps) {
      auto sim = std::make_unique<Simulation>(forceRegistry());
      StructureSpec ball = sphereStructure("ball", 3, 10.0f, Vec3::Zero());
      ball.referencePositions = ball.initialPositions;
      sim->addStructure(std::move(ball));
      sim->addForce("shape_prior").setAll("weight", 0.2);
      sim->addForce("attraction_points");
      sim->setIntegrator("damped_verlet");
      sim->initialize();
      sim->scene().constraintPoints()[0] = points;
      sim->run(steps);
      return sim;
    };
    const Vec3 include(0, 0, 12), exclude(0, 8.5f, 0);  // 2 mm outside, 1.5 mm inside
    auto sim = run({{include, true}, {exclude, false}}, 300);
    const TriangleMesh surface = tessellationOf(sim->store(), 0);
    const double wIn = windingNumber(surface, include), wOut = windingNumber(surface, exclude);
    qInfo("include point winding %.3f, exclude point winding %.3f", wIn, wOut);
    QVERIFY(wIn > 0.99 && wIn < 1.01);
    QVERIFY(std::abs(wOut) < 0.01);
    for (const Vec3& p : sim->store().positions()) QVERIFY(p.allFinite());
    // Satisfied points (well inside, well outside) change nothing.
    auto plain = run({}, 50), satisfied = run({{Vec3(0, 0, 5), true}, {Vec3(0, 0, 15), false}}, 50);
    const auto a = plain->store().positions(), b = satisfied->store().positions();
    for (Index v = 0; v < Index(a.size()); ++v) QVERIFY(a[v] == b[v]);
  }

  void oneAndManyThreadsGiveIdenticalPositions() {
    // Meshes large enough that every parallel path splits: 5,120 vertices each, above the grains of
    // the force loops (256), Verlet (2,048) and the attraction search (1,024).
    auto runWith = [](int threads) {
      EllipsoidCase c = ellipsoidCase(4);
      c.start.referencePositions = c.referenceOnTruth;
      Simulation sim(forceRegistry(), threads);
      sim.addStructure(c.start);
      sim.addStructure(sphereStructure("second", 4, 6.0f, c.image.centre));
      sim.addForce("smoothing");
      sim.addForce("shape_prior").set(1, "weight", 0.0);
      sim.addForce("gradient").set(0, "weight", 0.5);
      sim.addForce("intensity_profile").set(1, "weight", 0.0);
      sim.addForce("attraction_points");
      sim.setIntegrator("damped_verlet");
      sim.scene().setTargetImage(std::make_shared<Image3D>(ellipsoidImage(c.image)));
      sim.scene().attractionPoints()[1].push_back(c.image.centre + Vec3(0, 0, 9));
      sim.initialize();
      sim.run(50);
      return std::vector<Vec3>(sim.store().positions().begin(), sim.store().positions().end());
    };
    const auto one = runWith(1), many = runWith(4);
    QCOMPARE(one.size(), many.size());
    for (size_t i = 0; i < one.size(); ++i)
      QVERIFY2(one[i] == many[i], qPrintable(QString("vertex %1 differs").arg(i)));
  }
};

QTEST_APPLESS_MAIN(TestForces)
#include "tst_forces.moc"
