#include "stability_suite.h"

#include "synthetic.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

namespace sinew::testing {

namespace {
struct Ellipsoid {
  Vec3 centre, radii;
};

// An ellipsoid (bright inside) on any grid: size and spacing per axis, light noise.
std::shared_ptr<Image3D> ellipsoidVolume(std::array<int, 3> size, Eigen::Vector3d spacing, const Ellipsoid& e,
                                         unsigned seed = 1) {
  ImageGeometry g;
  g.size = size;
  g.spacing = spacing;
  auto image = std::make_shared<Image3D>(g);
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 4.0f);
  const float meanRadius = e.radii.mean();
  for (int k = 0; k < size[2]; ++k)
    for (int j = 0; j < size[1]; ++j)
      for (int i = 0; i < size[0]; ++i) {
        const Vec3 q = (image->indexToWorld(Vec3(i, j, k)) - e.centre).cwiseQuotient(e.radii);
        const float sd = (q.norm() - 1.0f) * meanRadius;
        image->at(i, j, k) = 30.0f + 70.0f / (1.0f + std::exp(sd / 0.25f)) + noise(rng);
      }
  return image;
}

const Ellipsoid kEllipsoid{Vec3(32, 32, 32), Vec3(20, 15, 12)};

// Mean distance of the final surface to the ellipsoid's.
std::function<double(Simulation&)> distanceTo(const Ellipsoid& e) {
  return [e](Simulation& sim) {
    return surfaceDistance(tessellationOf(sim.store(), 0), ellipsoidSurface(e.centre, e.radii, 4), 0.5f).assd;
  };
}

// A sphere of the ellipsoid's volume, 3 mm off its centre along x: the usual start. The shape
// prior's reference is the true shape.
StructureSpec startFor(const Ellipsoid& e, int level = 3) {
  StructureSpec s = sphereStructure("organ", level, std::cbrt(e.radii.prod()), e.centre + Vec3(3, 0, 0));
  for (const Vec3& p : SimplexMesh::sphere(level, 1.0f).positions)
    s.referencePositions.push_back(onEllipsoid(p, e.centre, e.radii));
  return s;
}

void usualForces(Simulation& sim, double internal, double image) {
  sim.addForce("smoothing").setAll("weight", internal);
  sim.addForce("shape_prior").setAll("weight", internal);
  sim.addForce("gradient").setAll("weight", image);
  sim.forceParams("gradient").setAll("search_depth", 8.0);
}

StabilityCase imageCase(std::string name, std::string description, Ellipsoid e,
                        std::function<std::shared_ptr<Image3D>()> image, double internal = 0.3, double external = 0.5) {
  StabilityCase c;
  c.name = std::move(name);
  c.description = std::move(description);
  c.build = [=](Simulation& sim) {
    sim.addStructure(startFor(e));
    usualForces(sim, internal, external);
    sim.scene().setTargetImage(image());
  };
  c.errorMm = distanceTo(e);
  return c;
}

std::shared_ptr<Image3D> usualImage() { return ellipsoidVolume({64, 64, 64}, Eigen::Vector3d::Ones(), kEllipsoid); }
}  // namespace

std::vector<StabilityCase> stabilityCases(bool includeLarge) {
  std::vector<StabilityCase> cases;
  cases.push_back(imageCase("baseline", "ellipsoid in a 64^3 image, 1 mm voxels, usual weights", kEllipsoid, usualImage));

  StabilityCase maxed = imageCase("weights_at_maxima", "smoothing, shape prior and gradient all at weight 1",
                                  kEllipsoid, usualImage, 1.0, 1.0);
  maxed.stiff = true;
  cases.push_back(maxed);

  StabilityCase light = imageCase("tiny_masses", "weights at maxima, mean vertex mass 0.01 (100x stiffer per mass)",
                                  kEllipsoid, usualImage, 1.0, 1.0);
  light.vertexMass = 0.01;
  light.stiff = true;
  cases.push_back(light);

  {
    const Ellipsoid disc{Vec3(32, 32, 32), Vec3(20, 15, 1.5)};
    StabilityCase c;
    c.name = "thin_structure";
    c.description = "a 3 mm thick disc (20 x 15 x 1.5 mm radii), started as a flattened ellipsoid";
    c.build = [disc](Simulation& sim) {
      StructureSpec s = sphereStructure("disc", 3, 1.0f, Vec3::Zero());
      for (Vec3& p : s.initialPositions) {
        s.referencePositions.push_back(onEllipsoid(p.normalized(), disc.centre, disc.radii));
        p = onEllipsoid(p.normalized(), disc.centre, Vec3(18, 13, 2.5));
      }
      sim.addStructure(s);
      usualForces(sim, 0.3, 0.5);
      sim.scene().setTargetImage(ellipsoidVolume({64, 64, 64}, Eigen::Vector3d::Ones(), disc));
    };
    c.errorMm = distanceTo(disc);
    cases.push_back(c);
  }
  {
    StabilityCase c = imageCase("near_degenerate_cells", "every 10th vertex moved 95 % of the way onto a neighbour",
                                kEllipsoid, usualImage);
    c.build = [](Simulation& sim) {
      StructureSpec s = startFor(kEllipsoid);
      const SimplexMesh m = SimplexMesh::sphere(3, 1.0f, Vec3::Zero());
      for (size_t v = 0; v < s.initialPositions.size(); v += 10) {
        const Index u = m.topology.neighbours[v][0];
        s.initialPositions[v] += 0.95f * (s.initialPositions[u] - s.initialPositions[v]);
      }
      sim.addStructure(s);
      usualForces(sim, 0.3, 0.5);
      sim.scene().setTargetImage(usualImage());
    };
    cases.push_back(c);
  }
  cases.push_back(imageCase("anisotropic_voxels", "1.37 x 1.37 x 5 mm voxels (the seed's data)", kEllipsoid, [] {
    return ellipsoidVolume({47, 47, 13}, Eigen::Vector3d(1.37, 1.37, 5.0), kEllipsoid);
  }));
  {
    StabilityCase c = imageCase("constant_image", "every voxel 100: no image force anywhere", kEllipsoid, [] {
      auto image = usualImage();
      std::fill(image->voxels().begin(), image->voxels().end(), 100.0f);
      return image;
    });
    c.errorMm = [](Simulation&) { return std::numeric_limits<double>::quiet_NaN(); };
    cases.push_back(c);
  }
  cases.push_back(imageCase("nan_inf_voxels", "a 4-slice slab of NaN through the ellipsoid and 1 % of voxels +-Inf",
                            kEllipsoid, [] {
                              auto image = usualImage();
                              const auto& g = image->geometry();
                              std::mt19937 rng(7);
                              std::uniform_real_distribution<float> u(0.0f, 1.0f);
                              for (int k = 0; k < g.size[2]; ++k)
                                for (int j = 0; j < g.size[1]; ++j)
                                  for (int i = 0; i < g.size[0]; ++i) {
                                    if (k >= 30 && k < 34) image->at(i, j, k) = std::numeric_limits<float>::quiet_NaN();
                                    else if (u(rng) < 0.01f)
                                      image->at(i, j, k) = (u(rng) < 0.5f ? 1.0f : -1.0f) * std::numeric_limits<float>::infinity();
                                  }
                              return image;
                            }));
  {
    const Ellipsoid edge{Vec3(4, 32, 32), Vec3(20, 15, 12)};
    cases.push_back(imageCase("partly_outside", "the ellipsoid and the mesh half outside the image (centre 4 mm from its edge)",
                              edge, [edge] { return ellipsoidVolume({64, 64, 64}, Eigen::Vector3d::Ones(), edge); }));
    cases.back().errorMm = [](Simulation&) { return std::numeric_limits<double>::quiet_NaN(); };
  }
  if (includeLarge) {
    const Ellipsoid big{Vec3(64, 64, 64), Vec3(40, 30, 24)};
    StabilityCase c = imageCase("large_image", "512^3 voxels of 0.25 mm (a 512 MiB image)", big, [big] {
      return ellipsoidVolume({512, 512, 512}, Eigen::Vector3d::Constant(0.25), big);
    });
    c.large = true;
    c.iterations = 60;
    cases.push_back(c);
  }
  return cases;
}

namespace {
void scaleMasses(Simulation& sim, double mass) {
  if (mass == 1.0) return;
  MeshStore& store = sim.store();
  const auto areas = store.areas();
  for (Index m = 0; m < store.meshCount(); ++m) {
    const MeshRange& r = store.range(m);
    const double total = std::accumulate(areas.begin() + r.vertexBegin, areas.begin() + r.vertexEnd, 0.0);
    store.setDensity(m, static_cast<float>(mass * r.vertexCount() / total));
  }
}

StabilityRun runBuilt(Simulation& sim, const std::string& caseName, const std::string& integrator, double timeStep,
                      int iterations, const std::function<double(Simulation&)>& error, bool measureError) {
  StabilityRun run;
  run.caseName = caseName;
  run.integrator = integrator;
  run.timeStep = timeStep;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    sim.run(iterations);
  } catch (const NumericalError& e) {
    run.failed = true;
    run.message = e.what();
  }
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const StabilityEvent& e : sim.stabilityEvents()) {
    if (e.recovered) ++run.rollbacks;
    if (run.message.empty()) run.message = e.reason;
  }
  run.finalTimeStep = sim.integratorParams().get(0, sim.integratorParams().indexOf("time_step"));
  for (const Vec3& p : sim.store().positions()) run.finite = run.finite && p.allFinite();
  run.errorMm = run.finite && error && measureError ? error(sim) : std::numeric_limits<double>::quiet_NaN();
  return run;
}
}  // namespace

StabilityRun runStabilityCase(const StabilityCase& c, const std::string& integrator, double timeStep, int iterations,
                              bool measureError) {
  Simulation sim(forceRegistry());
  c.build(sim);
  sim.setIntegrator(integrator).set(0, "time_step", timeStep);
  sim.initialize();
  scaleMasses(sim, c.vertexMass);
  return runBuilt(sim, c.name, integrator, timeStep, iterations > 0 ? iterations : c.iterations, c.errorMm,
                  measureError);
}

double largestStableStep(const StabilityCase& c, const std::string& integrator, double from, double to,
                         int iterations) {
  double best = 0.0;
  for (double dt = from; dt <= to * 1.0001; dt *= std::pow(2.0, 0.25)) {
    const StabilityRun r = runStabilityCase(c, integrator, dt, iterations, false);
    if (r.rollbacks > 0 || r.failed) break;
    best = dt;
  }
  return best;
}

StabilityRun runStiffnessCell(const std::string& integrator, double timeStep, double mass, int iterations) {
  Simulation sim(forceRegistry());
  StructureSpec s = sphereStructure("ball", 2, 10.0f, Vec3::Zero());
  s.referencePositions = s.initialPositions;
  s.initialPositions = withNoise(s.initialPositions, 0.5f, 3);  // something to smooth out
  sim.addStructure(s);
  sim.addForce("smoothing").setAll("weight", 1.0);
  sim.addForce("shape_prior").setAll("weight", 1.0);
  sim.setIntegrator(integrator).set(0, "time_step", timeStep);
  sim.initialize();
  scaleMasses(sim, mass);
  char name[64];
  std::snprintf(name, sizeof name, "mass %g", mass);
  return runBuilt(sim, name, integrator, timeStep, iterations, {}, false);
}

}  // namespace sinew::testing
