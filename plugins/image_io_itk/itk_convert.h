// Conversions between Sinew's volumes and ITK images (geometry and voxels), shared by the image IO
// and the registration of this plugin.
#pragma once

#include "sinew/core/image.h"

#include <itkImage.h>

namespace sinew {

template <class ItkImage>
ImageGeometry geometryOf(const ItkImage& image) {
  ImageGeometry g;
  const auto size = image.GetLargestPossibleRegion().GetSize();
  for (int a = 0; a < 3; ++a) {
    g.size[a] = static_cast<int>(size[a]);
    g.spacing[a] = image.GetSpacing()[a];
    g.origin[a] = image.GetOrigin()[a];
    for (int b = 0; b < 3; ++b) g.direction(a, b) = image.GetDirection()[a][b];
  }
  return g;
}

template <class T, class ItkImage>
Volume<T> toVolume(const ItkImage& image) {
  const ImageGeometry g = geometryOf(image);
  Volume<T> v(g);
  const auto* buffer = image.GetBufferPointer();
  for (std::size_t i = 0; i < g.voxelCount(); ++i) v.voxels()[i] = static_cast<T>(buffer[i]);
  return v;
}

// An ITK image of g's geometry, its buffer not yet allocated.
template <class Pixel>
typename itk::Image<Pixel, 3>::Pointer itkImageOf(const ImageGeometry& g) {
  using ImageType = itk::Image<Pixel, 3>;
  auto image = ImageType::New();
  typename ImageType::SizeType size;
  typename ImageType::SpacingType spacing;
  typename ImageType::PointType origin;
  typename ImageType::DirectionType direction;
  for (int a = 0; a < 3; ++a) {
    size[a] = g.size[a];
    spacing[a] = g.spacing[a];
    origin[a] = g.origin[a];
    for (int b = 0; b < 3; ++b) direction[a][b] = g.direction(a, b);
  }
  image->SetRegions(typename ImageType::RegionType(size));
  image->SetSpacing(spacing);
  image->SetOrigin(origin);
  image->SetDirection(direction);
  return image;
}

template <class Pixel, class T>
typename itk::Image<Pixel, 3>::Pointer toItk(const Volume<T>& v) {
  auto image = itkImageOf<Pixel>(v.geometry());
  image->Allocate();
  Pixel* buffer = image->GetBufferPointer();
  for (std::size_t i = 0; i < v.geometry().voxelCount(); ++i) buffer[i] = static_cast<Pixel>(v.voxels()[i]);
  return image;
}

// v's voxels seen as an ITK image, not copied: for filters that only read their input. v must
// outlive the image, and nothing may write through it.
template <class Pixel>
typename itk::Image<Pixel, 3>::Pointer itkViewOf(const Volume<Pixel>& v) {
  auto image = itkImageOf<Pixel>(v.geometry());
  image->GetPixelContainer()->SetImportPointer(const_cast<Pixel*>(v.voxels().data()), v.geometry().voxelCount(), false);
  return image;
}

}  // namespace sinew
