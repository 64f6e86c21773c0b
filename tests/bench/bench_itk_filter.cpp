// The CPU backend against ITK 5.2's itk::DeformableSimplexMesh3DFilter, per iteration, on the same
// meshes and image, side by side in one run. Comparable force sets: ITK's filter computes an
// internal force from simplex parameters (alpha) and an external gradient force (beta) and
// integrates explicitly, sampling the gradient at the vertex only; Sinew runs smoothing + shape prior
// + damped Verlet, with and without its gradient search (+-3 mm, 13 samples along the normal). Four spheres triangulated by ITK (2,048 / 8,192 / 32,768 simplex vertices in all), each
// converted to a simplex mesh by ITK and by Sinew from the same triangles.   bench_itk_filter [max_level=2]
#include "sinew/core/scene_runner.h"
#include "synthetic.h"

#include <itkCovariantVector.h>
#include <itkDeformableSimplexMesh3DFilter.h>
#include <itkGradientRecursiveGaussianImageFilter.h>
#include <itkImage.h>
#include <itkMesh.h>
#include <itkSimplexMesh.h>
#include <itkRegularSphereMeshSource.h>
#include <itkTriangleMeshToSimplexMeshFilter.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

using namespace sinew;
using namespace sinew::testing;
using Clock = std::chrono::steady_clock;

namespace {
using TriMesh = itk::Mesh<double, 3, itk::DefaultStaticMeshTraits<double, 3, 3, double, double, double>>;
using SMesh = itk::SimplexMesh<double, 3>;
using ItkImage = itk::Image<float, 3>;
using Deform = itk::DeformableSimplexMesh3DFilter<SMesh, SMesh>;

ItkImage::Pointer toItk(const Image3D& im) {
  auto out = ItkImage::New();
  ItkImage::SizeType size;
  for (int a = 0; a < 3; ++a) size[a] = im.geometry().size[a];
  out->SetRegions(ItkImage::RegionType(size));
  out->Allocate();
  std::copy(im.voxels().begin(), im.voxels().end(), out->GetBufferPointer());
  return out;
}

// A sphere triangulated by ITK (an octahedron subdivided `resolution` times: 8 * 4^r triangles),
// converted to a simplex mesh by ITK; Sinew gets the same triangles.
struct SphereCase {
  SMesh::Pointer itkMesh;  // disconnected: ITK's converter fails if its pipeline runs twice
  TriangleMesh triangles;
};

SphereCase sphereCase(unsigned resolution, const Vec3& centre, double radius) {
  auto source = itk::RegularSphereMeshSource<TriMesh>::New();
  TriMesh::PointType c;
  itk::RegularSphereMeshSource<TriMesh>::VectorType scale;
  for (int a = 0; a < 3; ++a) {
    c[a] = centre[a];
    scale[a] = radius;
  }
  source->SetCenter(c);
  source->SetScale(scale);
  source->SetResolution(resolution);
  auto convert = itk::TriangleMeshToSimplexMeshFilter<TriMesh, SMesh>::New();
  convert->SetInput(source->GetOutput());
  convert->Update();
  SphereCase out;
  out.itkMesh = convert->GetOutput();
  out.itkMesh->DisconnectPipeline();
  const TriMesh* mesh = source->GetOutput();
  for (auto it = mesh->GetPoints()->Begin(); it != mesh->GetPoints()->End(); ++it) {
    const auto& p = it.Value();
    out.triangles.points.emplace_back(float(p[0]), float(p[1]), float(p[2]));
  }
  for (auto it = mesh->GetCells()->Begin(); it != mesh->GetCells()->End(); ++it) {
    const auto* cell = it.Value();
    if (cell->GetNumberOfPoints() != 3) continue;
    const auto* ids = cell->GetPointIds();
    out.triangles.triangles.push_back({Index(ids[0]), Index(ids[1]), Index(ids[2])});
  }
  if (out.triangles.volume() < 0)
    for (auto& t : out.triangles.triangles) std::swap(t[1], t[2]);
  return out;
}
}  // namespace

int main(int argc, char** argv) {
  const int maxLevel = argc > 1 ? std::atoi(argv[1]) : 2;
  EllipsoidImageSpec spec;
  spec.size = 128;
  spec.centre = Vec3(64, 64, 64);
  spec.radii = Vec3(40, 30, 25);
  const auto image = std::make_shared<Image3D>(ellipsoidImage(spec));
  auto gradientFilter = itk::GradientRecursiveGaussianImageFilter<ItkImage, Deform::GradientImageType>::New();
  gradientFilter->SetInput(toItk(*image));
  gradientFilter->SetSigma(1.0);
  gradientFilter->Update();

  const std::vector<Vec3> centres = {Vec3(40, 64, 64), Vec3(88, 64, 64), Vec3(64, 40, 64), Vec3(64, 88, 64)};
  std::printf("CPU: %s\n\n", cpuDescription(Executor().threads()).c_str());
  std::printf("| vertices | Sinew forces (+ damped Verlet) | ITK filter ms/iter (1 thread) | Sinew ms/iter, 1 thread | Sinew ms/iter, all threads | ITK/Sinew, 1 thread | ITK/Sinew, all threads |\n");
  std::printf("| ---: | --- | ---: | ---: | ---: | ---: | ---: |\n");
  for (int level = 0; level <= maxLevel; ++level) {
    std::vector<StructureSpec> specs;
    std::vector<SphereCase> itkMeshes;
    for (size_t i = 0; i < centres.size(); ++i) {
      SphereCase c = sphereCase(3 + level, centres[i], 14.0);
      const SimplexMesh dual = SimplexMesh::dualOf(c.triangles);
      StructureSpec s;
      s.name = "s" + std::to_string(i);
      s.levels = LevelHierarchy::build(dual.topology, 1);
      s.initialPositions = dual.positions;
      s.referencePositions = dual.positions;
      specs.push_back(std::move(s));
      itkMeshes.push_back(c);
    }
    Index vertices = 0;
    for (const auto& s : specs) vertices += s.levels.levels[0].vertexCount();

    const int iterations = level == 0 ? 100 : (level == 1 ? 30 : 10);
    // ITK: one filter per mesh (it deforms one mesh at a time); total time over the four.
    double itkSeconds = 0;
    for (auto& m : itkMeshes) {
      auto deform = Deform::New();
      deform->SetInput(m.itkMesh);
      deform->SetGradient(gradientFilter->GetOutput());
      deform->SetAlpha(0.2);
      deform->SetBeta(0.1);
      deform->SetGamma(0.05);
      deform->SetRigidity(1);
      deform->SetIterations(iterations);
      const auto t0 = Clock::now();
      deform->Update();
      itkSeconds += std::chrono::duration<double>(Clock::now() - t0).count();
    }
    auto sinewMs = [&](int threads, bool gradientSearch) {
      Simulation sim(forceRegistry(), threads);
      for (const auto& s : specs) sim.addStructure(s);
      sim.addForce("smoothing");
      sim.addForce("shape_prior");
      if (gradientSearch) sim.addForce("gradient");
      sim.setIntegrator("damped_verlet");
      sim.scene().setTargetImage(image);
      sim.initialize();
      sim.run(2);
      const auto t0 = Clock::now();
      sim.run(iterations);
      return 1e3 * std::chrono::duration<double>(Clock::now() - t0).count() / iterations;
    };
    const double itkMs = 1e3 * itkSeconds / iterations;
    for (bool search : {true, false}) {
      const double one = sinewMs(1, search), all = sinewMs(0, search);
      std::printf("| %d | %s | %.2f | %.3f | %.3f | %.1fx | %.1fx |\n", vertices,
                  search ? "smoothing + shape prior + gradient search (13 samples)" : "smoothing + shape prior",
                  itkMs, one, all, itkMs / one, itkMs / all);
    }
    std::fflush(stdout);
  }
  return 0;
}
