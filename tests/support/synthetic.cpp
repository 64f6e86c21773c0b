#include "synthetic.h"

#include "sinew/core/simplex_geometry.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>
#include <utility>

namespace sinew::testing {

const Registry& forceRegistry() {
  static const Registry registry = [] {
    Registry r;
    registerBuiltinForces(r);
    return r;
  }();
  return registry;
}

std::vector<Vec3> withNoise(std::vector<Vec3> points, float sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, sigma);
  for (Vec3& p : points) p += Vec3(n(rng), n(rng), n(rng));
  return points;
}

SpikedSphere spikedSphere(float edges, bool inReference) {
  const SimplexMesh sphere = SimplexMesh::sphere(3, 20.0f);
  SpikedSphere out;
  StructureSpec& s = out.spec;
  s.name = "spiked";
  s.levels = LevelHierarchy::build(sphere.topology, 1);
  s.initialPositions = sphere.positions;
  s.referencePositions = sphere.positions;
  const auto& n = sphere.topology.neighbours[0];
  const Vec3 &p1 = sphere.positions[n[0]], &p2 = sphere.positions[n[1]], &p3 = sphere.positions[n[2]];
  const float edge = ((p1 - sphere.positions[0]).norm() + (p2 - sphere.positions[0]).norm() + (p3 - sphere.positions[0]).norm()) / 3.0f;
  (inReference ? s.referencePositions : s.initialPositions)[0] =
      sphere.positions[0] + edges * edge * sphere.positions[0].normalized();
  out.limit = kPriorReach * std::sqrt(std::max({(p1 - p2).squaredNorm(), (p2 - p3).squaredNorm(), (p3 - p1).squaredNorm()}));
  return out;
}

StructureSpec sphereStructure(const std::string& name, int level, float radius, const Vec3& centre,
                              int levels) {
  const SimplexMesh m = SimplexMesh::sphere(level, radius, centre);
  StructureSpec s;
  s.name = name;
  s.levels = LevelHierarchy::build(m.topology, levels);
  s.initialPositions = m.positions;
  return s;
}

void addSpherePair(Simulation& sim, float gap, float radiusB) {
  for (const auto& [name, radius, centre] : {std::tuple{"a", 10.0f, Vec3(0, 0, 0)}, std::tuple{"b", radiusB, Vec3(gap, 0, 0)}}) {
    StructureSpec s = sphereStructure(name, 3, radius, centre);
    s.referencePositions = s.initialPositions;
    sim.addStructure(std::move(s));
  }
}

Vec3 onEllipsoid(const Vec3& unitDirection, const Vec3& centre, const Vec3& radii) {
  return centre + unitDirection.cwiseProduct(radii);
}

TriangleMesh ellipsoidSurface(const Vec3& centre, const Vec3& radii, int level) {
  TriangleMesh m = icosphere(level, 1.0f);
  for (Vec3& p : m.points) p = onEllipsoid(p, centre, radii);
  return m;
}

TriangleMesh capsuleSurface(float radius, float length, int around, const Vec3& centre) {
  const float pi = 3.14159265358979f;
  const float step = 2.0f * pi * radius / float(around);  // about square faces
  std::vector<std::pair<float, float>> rings;              // (z, distance from the axis), top to bottom
  const int capRings = std::max(2, int(std::lround(0.5f * pi * radius / step)));
  for (int k = 1; k <= capRings; ++k) {
    const float theta = 0.5f * pi * float(k) / float(capRings);
    rings.emplace_back(0.5f * length + radius * std::cos(theta), radius * std::sin(theta));
  }
  const int cylinderSteps = std::max(1, int(std::lround(length / step)));
  for (int k = 1; k < cylinderSteps; ++k) rings.emplace_back(0.5f * length - length * float(k) / float(cylinderSteps), radius);
  for (int k = capRings; k >= 1; --k) {
    const float theta = 0.5f * pi * float(k) / float(capRings);
    rings.emplace_back(-0.5f * length - radius * std::cos(theta), radius * std::sin(theta));
  }
  TriangleMesh m;
  m.points.push_back(centre + Vec3(0, 0, 0.5f * length + radius));
  for (const auto& [z, rho] : rings)
    for (int j = 0; j < around; ++j) {
      const float phi = 2.0f * pi * float(j) / float(around);
      m.points.push_back(centre + Vec3(rho * std::cos(phi), rho * std::sin(phi), z));
    }
  m.points.push_back(centre + Vec3(0, 0, -0.5f * length - radius));
  const Index bottom = Index(m.points.size()) - 1;
  const auto at = [&](std::size_t ring, int j) { return Index(1 + ring * std::size_t(around) + std::size_t(j % around)); };
  for (int j = 0; j < around; ++j) m.triangles.push_back({0, at(0, j + 1), at(0, j)});
  for (std::size_t r = 0; r + 1 < rings.size(); ++r)
    for (int j = 0; j < around; ++j) {
      m.triangles.push_back({at(r, j), at(r, j + 1), at(r + 1, j + 1)});
      m.triangles.push_back({at(r, j), at(r + 1, j + 1), at(r + 1, j)});
    }
  for (int j = 0; j < around; ++j) m.triangles.push_back({bottom, at(rings.size() - 1, j), at(rings.size() - 1, j + 1)});
  for (auto& t : m.triangles) std::swap(t[1], t[2]);  // the rings run counter-clockwise seen from +z: outward
  return m;
}

Image3D ellipsoidImage(const EllipsoidImageSpec& spec) {
  ImageGeometry g;
  g.size = {spec.size, spec.size, spec.size};
  g.spacing = Eigen::Vector3d::Constant(spec.spacing);
  Image3D image(g);
  std::mt19937 rng(spec.seed);
  std::normal_distribution<float> noise(0.0f, spec.noiseSigma);
  const float extent = spec.size * spec.spacing;
  for (int k = 0; k < spec.size; ++k)
    for (int j = 0; j < spec.size; ++j)
      for (int i = 0; i < spec.size; ++i) {
        const Vec3 p = image.indexToWorld(Vec3(i, j, k));
        // Approximate signed distance: scaled implicit function times the mean radius.
        const Vec3 q = (p - spec.centre).cwiseQuotient(spec.radii);
        const float meanRadius = spec.radii.mean();
        const float sd = (q.norm() - 1.0f) * meanRadius;
        const float inside = 1.0f / (1.0f + std::exp(sd / (0.25f * spec.edgeWidth)));
        const float bias = 1.0f + spec.biasAmplitude * (2.0f * p.x() / extent - 1.0f);
        image.at(i, j, k) = bias * (spec.outside + (spec.inside - spec.outside) * inside) + noise(rng);
      }
  return image;
}

SphereFit fitSphere(std::span<const Vec3> points) {
  // |p|^2 = 2 c.p + (r^2 - |c|^2): linear least squares in (c, k).
  Eigen::MatrixXd A(points.size(), 4);
  Eigen::VectorXd b(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = points[i].cast<double>();
    A.row(i) << 2 * p.x(), 2 * p.y(), 2 * p.z(), 1.0;
    b[i] = p.squaredNorm();
  }
  const Eigen::Vector4d s = A.colPivHouseholderQr().solve(b);
  SphereFit fit;
  const Eigen::Vector3d c = s.head<3>();
  fit.centre = c.cast<float>();
  fit.radius = std::sqrt(s[3] + c.squaredNorm());
  double dev = 0;
  for (const Vec3& p : points) dev += std::abs((p.cast<double>() - c).norm() - fit.radius);
  fit.meanDeviation = dev / static_cast<double>(points.size());
  return fit;
}

SeedScene seedStructures(int levels) {
  const std::vector<std::pair<TriangleMesh, Vec3>> meshes = {{icosphere(3), Vec3(40, 64, 64)},
                                                             {icosphere(3), Vec3(88, 64, 64)},
                                                             {icosphere(1), Vec3(64, 40, 64)},
                                                             {tetrasphere(1), Vec3(64, 88, 64)}};
  SeedScene out;
  for (size_t i = 0; i < meshes.size(); ++i) {
    const SimplexMesh m = SimplexMesh::fromSphereTriangles(meshes[i].first, 1.0f, Vec3::Zero());
    StructureSpec s;
    s.name = "structure" + std::to_string(i);
    s.levels = LevelHierarchy::build(m.topology, levels);
    for (const Vec3& p : m.positions) {
      s.initialPositions.push_back(meshes[i].second + 14.0f * p);
      s.referencePositions.push_back(meshes[i].second + 15.0f * p);
    }
    out.structures.push_back(std::move(s));
    out.centres.push_back(meshes[i].second);
  }
  return out;
}

std::shared_ptr<const Image3D> seedImage() {
  static const auto image = [] {
    EllipsoidImageSpec spec;
    spec.size = 128;
    spec.centre = Vec3(64, 64, 64);
    spec.radii = Vec3(40, 30, 25);
    return std::make_shared<const Image3D>(ellipsoidImage(spec));
  }();
  return image;
}

TriangleMesh tessellationOf(MeshStore& store, Index mesh) {
  const auto x = store.mesh(store.positions(), mesh);
  return tessellate(store.topologyOf(mesh), std::vector<Vec3>(x.begin(), x.end()));
}

}  // namespace sinew::testing
