// Mesh IO (.vtk, .vtp, .stl, .obj, .ply) and label surfaces (flying edges on a label's mask,
// optional windowed-sinc smoothing and quadric decimation) through VTK.
#include "isolated_read.h"
#include "mesh_header_checks.h"
#include "sinew/core/registry.h"

#include <vtkAlgorithm.h>
#include <vtkAlgorithmOutput.h>
#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCleanPolyData.h>
#include <vtkFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkIdList.h>
#include <vtkImageData.h>
#include <vtkImageGaussianSmooth.h>
#include <vtkNew.h>
#include <vtkOBJReader.h>
#include <vtkOBJWriter.h>
#include <vtkPLYWriter.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkDecimatePro.h>
#include <vtkPolyDataConnectivityFilter.h>
#include <vtkPolyDataNormals.h>
#include <vtkPolyDataReader.h>
#include <vtkPolyDataWriter.h>
#include <vtkQuadricDecimation.h>
#include <vtkSTLReader.h>
#include <vtkSTLWriter.h>
#include <vtkSmartPointer.h>
#include <vtkTriangleFilter.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowedSincPolyDataFilter.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <iterator>
#include <type_traits>
#include <optional>
#include <stdexcept>

namespace sinew {

namespace {
namespace fs = std::filesystem;

[[noreturn]] void fail(const fs::path& path, const std::string& problem) {
  throw InputError(path.string() + ": " + problem);
}

// Collects VTK error events instead of letting VTK print them, so the user gets one clear line.
struct ErrorCatcher {
  vtkNew<vtkCallbackCommand> command;
  std::string message;
  ErrorCatcher() {
    command->SetClientData(this);
    command->SetCallback([](vtkObject*, unsigned long, void* self, void* data) {
      auto* c = static_cast<ErrorCatcher*>(self);
      if (c->message.empty() && data) c->message = static_cast<const char*>(data);
    });
  }
  void watch(vtkObject* o) {
    o->AddObserver(vtkCommand::ErrorEvent, command);
    o->AddObserver(vtkCommand::WarningEvent, command);
  }
};

std::string firstLine(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  const auto nl = s.rfind('\n');
  return nl == std::string::npos ? s : s.substr(nl + 1);
}

std::vector<Vec3> pointsOf(vtkPolyData* pd) {
  std::vector<Vec3> points(pd->GetNumberOfPoints());
  for (vtkIdType i = 0; i < pd->GetNumberOfPoints(); ++i) {
    double p[3];
    pd->GetPoint(i, p);
    points[i] = Vec3(float(p[0]), float(p[1]), float(p[2]));
  }
  return points;
}

TriangleMesh fromPolyData(vtkPolyData* input) {
  vtkNew<vtkTriangleFilter> tri;
  tri->SetInputData(input);
  tri->PassVertsOff();
  tri->PassLinesOff();
  vtkNew<vtkCleanPolyData> clean;  // merge duplicated points (STL stores each triangle apart)
  clean->SetInputConnection(tri->GetOutputPort());
  clean->PointMergingOn();
  clean->SetTolerance(0.0);
  clean->Update();
  vtkPolyData* pd = clean->GetOutput();
  TriangleMesh m;
  m.points = pointsOf(pd);
  vtkNew<vtkIdList> ids;
  vtkCellArray* polys = pd->GetPolys();
  for (polys->InitTraversal(); polys->GetNextCell(ids);)
    if (ids->GetNumberOfIds() == 3)
      m.triangles.push_back({Index(ids->GetId(0)), Index(ids->GetId(1)), Index(ids->GetId(2))});
  return m;
}

vtkSmartPointer<vtkPolyData> toPolyData(const TriangleMesh& m) {
  vtkNew<vtkPoints> points;
  points->SetDataTypeToFloat();
  for (const Vec3& p : m.points) points->InsertNextPoint(p.x(), p.y(), p.z());
  vtkNew<vtkCellArray> polys;
  for (const auto& t : m.triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    polys->InsertNextCell(3, ids);
  }
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetPolys(polys);
  for (const PointArray& a : m.pointData) {
    if (a.values.size() != m.points.size()) continue;  // writeMesh refuses these first
    vtkNew<vtkFloatArray> values;
    values->SetName(a.name.c_str());
    values->SetNumberOfValues(vtkIdType(a.values.size()));
    for (std::size_t i = 0; i < a.values.size(); ++i) values->SetValue(vtkIdType(i), a.values[i]);
    pd->GetPointData()->AddArray(values);
  }
  return pd;
}

template <class Reader>
vtkSmartPointer<vtkPolyData> readWith(const fs::path& path) {
  // Helper objects inside the readers (XML parsers) print to VTK's output window rather than
  // raising events on the reader; keep them quiet and report one line ourselves.
  vtkObject::GlobalWarningDisplayOff();
  vtkNew<Reader> reader;
  ErrorCatcher errors;
  errors.watch(reader);
  reader->SetFileName(path.string().c_str());
  reader->Update();
  if (!errors.message.empty()) fail(path, "cannot read the mesh: " + firstLine(errors.message));
  return reader->GetOutput();
}

TriangleMesh readMeshHere(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) fail(path, "no such file");
  if (fs::file_size(path, ec) == 0) fail(path, "is empty");
  const std::string ext = ioExtension(path);
  vtkSmartPointer<vtkPolyData> pd;
  if (ext == ".vtk") pd = readWith<vtkPolyDataReader>(path);
  else if (ext == ".vtp") pd = readWith<vtkXMLPolyDataReader>(path);
  else if (ext == ".stl") {
    checkStlSize(path);
    pd = readWith<vtkSTLReader>(path);
  }
  else if (ext == ".obj") pd = readWith<vtkOBJReader>(path);
  else if (ext == ".ply") pd = toPolyData(readPly(path));  // VTK's reader crashes on malformed files
  else fail(path, "unsupported mesh format '" + ext + "'");
  TriangleMesh m = fromPolyData(pd);
  if (m.triangles.empty()) fail(path, "holds no triangles (corrupt or truncated?)");
  for (const Vec3& p : m.points)
    if (!p.allFinite()) fail(path, "has a non-finite point coordinate");
  return m;
}

// Points and triangles exactly as the file stores them (no triangulation, no point merging): model
// files rely on the order of their points.
TriangleMesh readMeshExactHere(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) fail(path, "no such file");
  if (ioExtension(path) != ".vtp") fail(path, "model meshes are VTK XML polydata (.vtp)");
  vtkSmartPointer<vtkPolyData> pd = readWith<vtkXMLPolyDataReader>(path);
  TriangleMesh m;
  m.points = pointsOf(pd);
  for (const Vec3& p : m.points)
    if (!p.allFinite()) fail(path, "has a non-finite point coordinate");
  vtkNew<vtkIdList> ids;
  vtkCellArray* polys = pd->GetPolys();
  for (polys->InitTraversal(); polys->GetNextCell(ids);) {
    if (ids->GetNumberOfIds() != 3) fail(path, "holds a polygon that is not a triangle");
    m.triangles.push_back({Index(ids->GetId(0)), Index(ids->GetId(1)), Index(ids->GetId(2))});
    for (int k = 0; k < 3; ++k)
      if (m.triangles.back()[k] < 0 || m.triangles.back()[k] >= Index(m.points.size()))
        fail(path, "a triangle refers to a point that does not exist");
  }
  if (m.triangles.empty()) fail(path, "holds no triangles (corrupt or truncated?)");
  return m;
}

// Read in a reader server: VTK's readers crash on some corrupt files (isolated_read.h). A PLY file
// is read by Sinew's own reader, here; a VTP file's sizes are checked here first.
TriangleMesh readMesh(const fs::path& path) {
  if (ioExtension(path) == ".ply") {
    const std::shared_lock vtkInUse(vtkWorkMutex());
    return readMeshHere(path);
  }
  if (ioExtension(path) == ".vtp" && fs::is_regular_file(path)) checkVtkXmlSizes(path);
  return readIsolated(path, &readMeshHere);
}

TriangleMesh readMeshExact(const fs::path& path) {
  if (ioExtension(path) == ".vtp" && fs::is_regular_file(path)) checkVtkXmlSizes(path);
  return readIsolated(path, &readMeshExactHere);
}

template <class Writer>
void writeWith(const fs::path& target, const fs::path& temp, vtkPolyData* pd) {
  vtkNew<Writer> writer;
  ErrorCatcher errors;
  errors.watch(writer);
  writer->SetFileName(temp.string().c_str());
  writer->SetInputData(pd);
  // zlib's fastest level: the demo's 12 meshes 2 % larger than at VTK's default (5), a third
  // of sinew-run's time to write its outputs saved with the pictures' level (docs/benchmarks.md).
  if constexpr (std::is_base_of_v<vtkXMLWriterBase, Writer>) writer->SetCompressionLevel(1);
  if (!writer->Write() || !errors.message.empty())
    fail(target, "cannot write the mesh: " + firstLine(errors.message));
}

void writeMesh(const fs::path& path, const TriangleMesh& m) {
  const std::shared_lock vtkInUse(vtkWorkMutex());
  for (const Vec3& p : m.points)
    if (!p.allFinite()) fail(path, "refusing to write a mesh with a non-finite coordinate");
  for (const PointArray& a : m.pointData) {
    if (a.values.size() != m.points.size())
      fail(path, "point data '" + a.name + "' has " + std::to_string(a.values.size()) + " values for " +
                     std::to_string(m.points.size()) + " points");
    for (float v : a.values)
      if (!std::isfinite(v)) fail(path, "refusing to write point data '" + a.name + "' with a non-finite value");
  }
  AtomicOutput out(path);
  const auto pd = toPolyData(m);
  const std::string ext = ioExtension(path);
  if (ext == ".vtk") writeWith<vtkPolyDataWriter>(path, out.tempPath(), pd);
  else if (ext == ".vtp") writeWith<vtkXMLPolyDataWriter>(path, out.tempPath(), pd);
  else if (ext == ".stl") writeWith<vtkSTLWriter>(path, out.tempPath(), pd);
  else if (ext == ".obj") writeWith<vtkOBJWriter>(path, out.tempPath(), pd);
  else if (ext == ".ply") writeWith<vtkPLYWriter>(path, out.tempPath(), pd);
  else fail(path, "unsupported mesh format '" + ext + "'");
  out.commit();
}

// The iso-surface pipeline of one label's mask: flying edges at 0.5 in index space, the largest
// connected piece, then windowed-sinc smoothing. With `sigma` > 0 (voxels) the mask is blurred
// first, and padded by enough background that the blur stays inside it.
struct MaskSurface {
  vtkNew<vtkImageData> mask;
  vtkNew<vtkImageGaussianSmooth> blur;
  vtkNew<vtkFlyingEdges3D> iso;
  vtkNew<vtkPolyDataConnectivityFilter> largest;
  vtkNew<vtkWindowedSincPolyDataFilter> smooth;
  vtkIdType cells = 0;  // the iso-surface's triangles, once built

  // The smoothed surface's output port.
  vtkAlgorithmOutput* build(const LabelVolume& labels, std::int32_t label, const int lo[3], const int hi[3],
                            int smoothingIterations, double sigma) {
    const int pad = sigma > 0.0 ? 1 + int(std::ceil(3.0 * sigma)) : 1;
    const int px = hi[0] - lo[0] + 1 + 2 * pad, py = hi[1] - lo[1] + 1 + 2 * pad, pz = hi[2] - lo[2] + 1 + 2 * pad;
    mask->SetDimensions(px, py, pz);
    mask->SetOrigin(lo[0] - pad, lo[1] - pad, lo[2] - pad);  // index coordinates, as over the whole volume
    mask->AllocateScalars(sigma > 0.0 ? VTK_FLOAT : VTK_UNSIGNED_CHAR, 1);
    const auto fill = [&](auto* buffer) {
      std::fill(buffer, buffer + std::size_t(px) * py * pz, 0);
      for (int k = lo[2]; k <= hi[2]; ++k)
        for (int j = lo[1]; j <= hi[1]; ++j)
          for (int i = lo[0]; i <= hi[0]; ++i)
            if (labels.at(i, j, k) == label)
              buffer[(std::size_t(k - lo[2] + pad) * py + (j - lo[1] + pad)) * px + (i - lo[0] + pad)] = 1;
    };
    if (sigma > 0.0) {
      fill(static_cast<float*>(mask->GetScalarPointer()));
      blur->SetInputData(mask);
      blur->SetDimensionality(3);
      blur->SetStandardDeviations(sigma, sigma, sigma);
      blur->SetRadiusFactors(3.0, 3.0, 3.0);
      iso->SetInputConnection(blur->GetOutputPort());
    } else {
      fill(static_cast<unsigned char*>(mask->GetScalarPointer()));
      iso->SetInputData(mask);
    }
    iso->SetValue(0, 0.5);
    iso->ComputeNormalsOff();
    iso->ComputeGradientsOff();
    largest->SetInputConnection(iso->GetOutputPort());
    largest->SetExtractionModeToLargestRegion();
    vtkAlgorithmOutput* port = largest->GetOutputPort();
    if (smoothingIterations > 0) {
      smooth->SetInputConnection(port);
      smooth->SetNumberOfIterations(smoothingIterations);
      smooth->SetPassBand(0.1);
      smooth->NonManifoldSmoothingOn();
      smooth->NormalizeCoordinatesOn();
      port = smooth->GetOutputPort();
    }
    largest->Update();
    cells = largest->GetOutput()->GetNumberOfPolys();
    return port;
  }
};

// A surface with its triangles ordered consistently outward, and merged points.
TriangleMesh orientedAndCleaned(vtkAlgorithmOutput* input) {
  vtkNew<vtkPolyDataNormals> orient;
  orient->ConsistencyOn();
  orient->AutoOrientNormalsOn();
  orient->SplittingOff();
  orient->ComputeCellNormalsOff();
  orient->SetInputConnection(input);
  vtkNew<vtkCleanPolyData> clean;
  clean->SetInputConnection(orient->GetOutputPort());
  clean->Update();
  return fromPolyData(clean->GetOutput());
}

// A pipeline's output, updated and copied out of it.
vtkSmartPointer<vtkPolyData> plainCopy(vtkAlgorithmOutput* port) {
  port->GetProducer()->Update();
  auto copy = vtkSmartPointer<vtkPolyData>::New();
  copy->DeepCopy(vtkPolyData::SafeDownCast(port->GetProducer()->GetOutputDataObject(port->GetIndex())));
  return copy;
}

// The input decimated by quadrics to `reduction`, if that gives a closed manifold.
std::optional<TriangleMesh> decimatedClosed(vtkPolyData* input, double reduction) {
  vtkNew<vtkQuadricDecimation> quadric;
  quadric->VolumePreservationOn();
  quadric->SetInputData(input);
  quadric->SetTargetReduction(reduction);
  TriangleMesh m = orientedAndCleaned(quadric->GetOutputPort());
  try {
    validateClosedManifold(m);
  } catch (const InputError&) {
    return std::nullopt;
  }
  return m;
}

// Surface of one label: mask (padded by one voxel so it closes), flying edges at 0.5 in index
// space, then mapped to world millimetres through the image's index-to-world transform.
TriangleMesh labelSurface(const LabelVolume& labels, std::int32_t label, const LabelSurfaceOptions& opt) {
  const std::shared_lock vtkInUse(vtkWorkMutex());
  const ImageGeometry& g = labels.geometry();
  // The mask covers the label's bounding box and one voxel of background around it, not the whole
  // volume: a structure is a small part of a brain, and the iso-surface costs what the mask holds.
  // The caller's extent when it has one, else this label's from one pass (labelExtents).
  std::optional<LabelExtent> found;
  if (!opt.extent) {
    const auto all = labelExtents(labels);
    if (const auto it = all.find(label); it != all.end()) found = it->second;
  }
  const LabelExtent* extent = opt.extent ? opt.extent : found ? &*found : nullptr;
  if (!extent || extent->count == 0) throw InputError("label " + std::to_string(label) + " is absent from the label map");
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = extent->lo[a], hi[a] = extent->hi[a];
    if (lo[a] < 0 || lo[a] > hi[a] || hi[a] >= g.size[a]) throw std::invalid_argument("labelSurface: an extent outside the label map");
  }
  MaskSurface surface;
  vtkAlgorithmOutput* const plain = surface.build(labels, label, lo, hi, opt.smoothingIterations, 0.0);
  TriangleMesh m;
  if (opt.targetTriangles <= 0 || surface.cells <= opt.targetTriangles) {
    m = orientedAndCleaned(plain);
  } else {
    // Quadric decimation is smooth but folds now and then; a slightly different target usually
    // does not. Where every target folds (thin, convoluted labels such as the precuneus or the
    // anterior cingulum: 22,608 triangles to 388), the mask blurred by one voxel, then two, gives
    // a rounder surface that decimates cleanly; the coarse mesh only has to start the levels, which
    // are fitted to the label's own surface. Topology-preserving decimation (vtkDecimatePro) is the
    // last resort: it keeps the surface closed and manifold but stops far above the target there
    // (6,760 triangles).
    const double factors[] = {1.0, 1.07, 0.94, 1.15, 0.87, 1.25, 0.8};
    const auto reduction = [&](double f, vtkIdType cells) {
      return std::clamp(1.0 - f * double(opt.targetTriangles) / double(cells), 0.0, 0.99);
    };
    const vtkSmartPointer<vtkPolyData> plainInput = plainCopy(plain);
    std::optional<TriangleMesh> decimated = decimatedClosed(plainInput, reduction(factors[0], surface.cells));
    // The other targets side by side, a surface at a time, in their order: the first that holds is
    // taken, so the result is that of trying them one after another (a label of the Harvard-Oxford
    // atlas went through 15 targets on 76,664 triangles). Each decimates its own copy.
    MaskSurface blurred;
    for (int stage = 0; stage < 3 && !decimated; ++stage) {
      const vtkSmartPointer<vtkPolyData> input =
          stage == 0 ? plainInput : plainCopy(blurred.build(labels, label, lo, hi, opt.smoothingIterations, double(stage)));
      const vtkIdType cells = stage == 0 ? surface.cells : blurred.cells;
      const int skip = stage == 0 ? 1 : 0, n = int(std::size(factors)) - skip;  // the first target was tried
      std::vector<std::optional<TriangleMesh>> results(static_cast<size_t>(n));
      std::atomic<int> first{n};
      // Isolated: while it waits, this thread (which holds vtkWorkMutex shared) takes no other
      // structure's surface from the caller's parallel loop.
      tbb::this_task_arena::isolate([&] {
        tbb::parallel_for(0, n, [&](int k) {
          if (k > first.load()) return;  // one before it held
          vtkNew<vtkPolyData> copy;
          copy->DeepCopy(input);
          results[size_t(k)] = decimatedClosed(copy, reduction(factors[k + skip], cells));
          if (results[size_t(k)])
            for (int seen = first.load(); k < seen && !first.compare_exchange_weak(seen, k);) {
            }
        });
      });
      if (first.load() < n) decimated = std::move(results[size_t(first.load())]);
    }
    if (decimated) {
      m = std::move(*decimated);
    } else {
      vtkNew<vtkDecimatePro> pro;
      pro->SetInputConnection(plain);
      pro->SetTargetReduction(1.0 - double(opt.targetTriangles) / double(surface.cells));
      pro->PreserveTopologyOn();
      pro->SplittingOff();
      pro->BoundaryVertexDeletionOff();
      m = orientedAndCleaned(pro->GetOutputPort());
    }
  }
  for (Vec3& p : m.points) p = labels.indexToWorld(p);
  if (m.volume() < 0.0)
    for (auto& t : m.triangles) std::swap(t[1], t[2]);
  return m;
}
}  // namespace

void registerVtkMeshIO(Registry& registry) {
  MeshIODescriptor d;
  d.name = "vtk";
  d.summary = "triangle meshes (.vtk, .vtp, .stl, .obj, .ply) and label surfaces through VTK";
  d.extensions = {".vtk", ".vtp", ".stl", ".obj", ".ply"};
  d.read = readMesh;
  d.write = writeMesh;
  d.labelSurface = labelSurface;
  d.readExact = readMeshExact;
  registry.addMeshIO(std::move(d));
}

}  // namespace sinew
