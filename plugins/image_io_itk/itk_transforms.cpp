#include "itk_transforms.h"

#include <itkAffineTransform.h>
#include <itkCompositeTransform.h>
#include <itkTransformFactory.h>
#include <itkTransformFileReader.h>
#include <itkTransformFileWriter.h>

#include <cmath>

namespace sinew {

namespace fs = std::filesystem;
using BSplineType = itk::BSplineTransform<double, 3, 3>;
using AffineType = itk::AffineTransform<double, 3>;
using CompositeType = itk::CompositeTransform<double, 3>;

Eigen::Matrix4d toMatrix(const itk::MatrixOffsetTransformBase<double, 3, 3>& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m(r, c) = t.GetMatrix()[r][c];
    m(r, 3) = t.GetOffset()[r];
  }
  return m;
}

BSplineWarp bsplineWarpOf(const BSplineType& transform) {
  const auto& images = transform.GetCoefficientImages();
  const auto& image = *images[0];
  BSplineWarp w;
  const auto size = image.GetLargestPossibleRegion().GetSize();
  for (int a = 0; a < 3; ++a) {
    w.size[a] = int(size[a]);
    w.origin[a] = image.GetOrigin()[a];
    w.spacing[a] = image.GetSpacing()[a];
    for (int b = 0; b < 3; ++b) w.direction(a, b) = image.GetDirection()[a][b];
  }
  const size_t count = image.GetLargestPossibleRegion().GetNumberOfPixels();
  w.coefficients.resize(count);
  for (int a = 0; a < 3; ++a) {
    const double* c = images[a]->GetBufferPointer();
    for (size_t i = 0; i < count; ++i) w.coefficients[i][a] = c[i];
  }
  return w;
}

// ITK describes the grid by the domain it covers: a cubic B-spline's control points start one
// spacing before it, and there are three more of them than cells per axis.
BSplineType::Pointer bsplineTransformOf(const BSplineWarp& w) {
  auto t = BSplineType::New();
  BSplineType::OriginType origin;
  BSplineType::PhysicalDimensionsType extent;
  BSplineType::MeshSizeType mesh;
  BSplineType::DirectionType direction;
  const Eigen::Vector3d domainOrigin = w.origin + w.direction * w.spacing;
  for (int a = 0; a < 3; ++a) {
    origin[a] = domainOrigin[a];
    mesh[a] = unsigned(w.size[a] - 3);
    extent[a] = w.spacing[a] * double(w.size[a] - 3);
    for (int b = 0; b < 3; ++b) direction[a][b] = w.direction(a, b);
  }
  t->SetTransformDomainOrigin(origin);
  t->SetTransformDomainPhysicalDimensions(extent);
  t->SetTransformDomainMeshSize(mesh);
  t->SetTransformDomainDirection(direction);
  BSplineType::ParametersType p(t->GetNumberOfParameters());
  const size_t count = w.coefficients.size();
  for (int a = 0; a < 3; ++a)
    for (size_t i = 0; i < count; ++i) p[unsigned(a * count + i)] = w.coefficients[i][a];
  t->SetParametersByValue(p);
  return t;
}

namespace {
Eigen::Matrix4d affineOf(const itk::TransformBaseTemplate<double>* base, const fs::path& path) {
  const auto* t = dynamic_cast<const itk::MatrixOffsetTransformBase<double, 3, 3>*>(base);
  if (!t)
    throw InputError(path.string() + ": transform '" + base->GetNameOfClass() +
                     "' is not affine (rigid, similarity and affine 3D transforms are read, or a composite of one "
                     "and a cubic B-spline)");
  const Eigen::Matrix4d m = toMatrix(*t);
  if (!m.allFinite() || std::abs(m.topLeftCorner<3, 3>().determinant()) < 1e-9)
    throw InputError(path.string() + ": the transform is singular or not finite");
  return m;
}
}  // namespace

RegistrationTransform readRegistrationTransform(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path.string() + ": no such transform file");
  itk::TransformFactoryBase::RegisterDefaultTransforms();
  auto reader = itk::TransformFileReaderTemplate<double>::New();
  reader->SetFileName(path.string());
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InputError(path.string() + ": cannot read the transform: " + std::string(e.GetDescription()));
  }
  const auto* list = reader->GetTransformList();
  if (list->size() != 1)
    throw InputError(path.string() + ": holds " + std::to_string(list->size()) +
                     " transforms; one affine, or one composite of an affine and a B-spline, is needed");
  RegistrationTransform out;
  const auto* composite = dynamic_cast<const CompositeType*>(list->front().GetPointer());
  if (!composite) {
    out.targetToModel = affineOf(list->front().GetPointer(), path);
    return out;
  }
  // ITK applies a composite's transforms last added first: the B-spline, then the affine.
  const auto n = composite->GetNumberOfTransforms();
  if (n < 1 || n > 2)
    throw InputError(path.string() + ": a composite of " + std::to_string(n) +
                     " transforms; an affine, or an affine and a cubic B-spline after it in the file, is needed");
  out.targetToModel = affineOf(composite->GetNthTransformConstPointer(0), path);
  if (n == 2) {
    const auto* bspline = dynamic_cast<const BSplineType*>(composite->GetNthTransformConstPointer(1));
    if (!bspline)
      throw InputError(path.string() + ": the composite's second transform, '" +
                       composite->GetNthTransformConstPointer(1)->GetNameOfClass() + "', is not a cubic 3D B-spline");
    out.deformation = bsplineWarpOf(*bspline);
    if (!out.deformation.valid())
      throw InputError(path.string() + ": the B-spline's control grid is malformed or not finite");
  }
  return out;
}

itk::Transform<double, 3, 3>::Pointer itkTransformOf(const RegistrationTransform& transform) {
  const Eigen::Matrix4d& m = transform.targetToModel;
  auto affine = AffineType::New();
  AffineType::MatrixType matrix;
  AffineType::OutputVectorType offset;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) matrix[r][c] = m(r, c);
    offset[r] = m(r, 3);
  }
  affine->SetMatrix(matrix);
  affine->SetOffset(offset);
  if (transform.deformation.empty()) return affine.GetPointer();  // a plain affine file, as other tools expect
  // ITK applies a composite's transforms last added first: the B-spline, then the affine.
  auto composite = CompositeType::New();
  composite->AddTransform(affine);
  composite->AddTransform(bsplineTransformOf(transform.deformation));
  return composite.GetPointer();
}

void writeRegistrationTransform(const fs::path& path, const RegistrationTransform& transform) {
  const auto written = itkTransformOf(transform);
  AtomicOutput out(path);
  auto writer = itk::TransformFileWriterTemplate<double>::New();
  writer->SetInput(written);
  writer->SetFileName(out.tempPath().string());
  try {
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw InputError(path.string() + ": cannot write the transform: " + std::string(e.GetDescription()));
  }
  out.commit();
}

}  // namespace sinew
