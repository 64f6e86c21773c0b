// Image IO through ITK: NIfTI (.nii, .nii.gz), NRRD (.nrrd, .nhdr), MetaImage (.mha, .mhd) and
// DICOM series (a directory). ITK keeps images in LPS world coordinates and converts NIfTI's RAS
// on read and write, so every image in Sinew is LPS (docs/architecture.md, "Physical space").
#include "itk_convert.h"
#include "itk_registration.h"
#include "sinew/core/registry.h"

#include <itkGDCMImageIO.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageIOFactory.h>
#include <itkImageSeriesReader.h>

#include <zlib.h>

#include <cmath>
#include <future>
#include <mutex>
#include <sstream>

namespace sinew {

namespace {
namespace fs = std::filesystem;

std::string brief(const itk::ExceptionObject& e) {
  std::string d = e.GetDescription();
  while (!d.empty() && (d.back() == '\n' || d.back() == ' ')) d.pop_back();
  return d;
}

[[noreturn]] void fail(const fs::path& path, const std::string& problem) {
  throw InputError(path.string() + ": " + problem);
}

// Checks what the header says before a voxel is allocated.
void checkHeader(const fs::path& path, itk::ImageIOBase& io) {
  const unsigned dims = io.GetNumberOfDimensions();
  if (dims < 3) fail(path, "is a " + std::to_string(dims) + "D image; a 3D volume is needed");
  for (unsigned d = 3; d < dims; ++d)
    if (io.GetDimensions(d) != 1) fail(path, "has more than three dimensions (time series?); a 3D volume is needed");
  if (io.GetNumberOfComponents() != 1)
    fail(path, "has " + std::to_string(io.GetNumberOfComponents()) + " components per voxel; a scalar image is needed");
  std::size_t voxels = 1;
  for (unsigned d = 0; d < 3; ++d) {
    const auto n = io.GetDimensions(d);
    if (n == 0) fail(path, "has size 0 along axis " + std::to_string(d));
    voxels *= n;
    if (voxels > kMaxImageVoxels) fail(path, "claims more than 2^31 voxels; refusing to allocate it");
    const double s = io.GetSpacing(d);
    if (!(s > 0.0) || !std::isfinite(s)) fail(path, "has a non-positive or non-finite voxel spacing");
  }
}

// ITK's NIfTI reader does not notice a gzip stream that ends early (it reads zeros), so compressed
// files are also decompressed to the end here: a truncated or corrupt stream is refused.
void checkGzipStream(const fs::path& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) fail(path, "cannot be opened");
  std::vector<char> buffer(1 << 20);
  int n = 0;
  while ((n = gzread(f, buffer.data(), static_cast<unsigned>(buffer.size()))) > 0) {
  }
  int code = Z_OK;
  gzerror(f, &code);
  gzclose(f);
  if (n < 0 || code != Z_OK) fail(path, "the compressed data ends early or is corrupt (truncated file?)");
}

// A single-file image (not a DICOM series), its header checked, read straight into the volume's
// buffer: no second full-size copy (the training image is 230 MB as floats).
template <class Pixel>
Volume<Pixel> readNonSeries(const fs::path& path) {
  using ImageType = itk::Image<Pixel, 3>;
  itk::ImageIOBase::Pointer io;
  {
    // Images are read on several threads at once (scene_runner.cpp); ITK's factory list is not
    // guarded for concurrent first use.
    static std::mutex factoryMutex;
    const std::lock_guard lock(factoryMutex);
    io = itk::ImageIOFactory::CreateImageIO(path.c_str(), itk::CommonEnums::IOFileMode::ReadMode);
  }
  if (!io) fail(path, "is not an image in a format Sinew reads (NIfTI, NRRD, MetaImage, DICOM), or it is corrupt");
  io->SetFileName(path.string());
  try {
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    fail(path, "cannot read the image header: " + brief(e));
  }
  checkHeader(path, *io);
  auto reader = itk::ImageFileReader<ImageType>::New();
  reader->SetImageIO(io);
  reader->SetFileName(path.string());
  reader->UpdateOutputInformation();
  ImageType* image = reader->GetOutput();
  Volume<Pixel> volume(geometryOf(*image));
  image->GetPixelContainer()->SetImportPointer(volume.voxels().data(), volume.voxels().size(), false);
  reader->Update();
  // ITK kept the buffer it was given unless its pipeline chose otherwise; then the voxels are copied.
  if (image->GetBufferPointer() != volume.voxels().data()) return toVolume<Pixel>(*image);
  return volume;
}

template <class Pixel>
Volume<Pixel> readItk(const fs::path& path) {
  using ImageType = itk::Image<Pixel, 3>;
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path, "no such file or directory");
  try {
    if (fs::is_directory(path, ec)) {
      auto names = itk::GDCMSeriesFileNames::New();
      names->SetUseSeriesDetails(true);
      names->SetDirectory(path.string());
      const auto series = names->GetSeriesUIDs();
      if (series.empty()) fail(path, "is a directory without a DICOM series");
      auto dicom = itk::GDCMImageIO::New();
      auto reader = itk::ImageSeriesReader<ImageType>::New();
      reader->SetImageIO(dicom);
      reader->SetFileNames(names->GetFileNames(series.front()));
      reader->UpdateOutputInformation();
      checkHeader(path, *dicom);
      reader->Update();
      return toVolume<Pixel>(*reader->GetOutput());
    }
    // ITK reads a truncated or corrupt gzip stream without complaint, so the stream is checked
    // (its CRC) by a second decompression, which runs beside ITK's; its verdict comes first.
    std::future<void> streamCheck;
    if (ioExtension(path) == ".nii.gz") streamCheck = std::async(std::launch::async, [path] { checkGzipStream(path); });
    const auto verdict = [&] {
      if (streamCheck.valid()) streamCheck.get();
    };
    try {
      auto image = readNonSeries<Pixel>(path);
      verdict();
      return image;
    } catch (...) {
      verdict();
      throw;
    }
  } catch (const itk::ExceptionObject& e) {
    fail(path, "cannot read the voxel data (truncated or corrupt file?): " + brief(e));
  }
}

template <class ItkImage>
void writeItk(const fs::path& path, ItkImage* image) {
  AtomicOutput out(path);
  try {
    auto writer = itk::ImageFileWriter<ItkImage>::New();
    writer->SetFileName(out.tempPath().string());
    writer->SetInput(image);
    writer->UseCompressionOn();
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    fail(path, "cannot write the image: " + brief(e));
  }
  out.commit();
}
}  // namespace

void registerItkImageIO(Registry& registry) {
  ImageIODescriptor d;
  d.name = "itk";
  d.summary = "NIfTI, NRRD, MetaImage and DICOM series through ITK (LPS world coordinates)";
  d.extensions = {".nii", ".nii.gz", ".nrrd", ".nhdr", ".mha", ".mhd", "/"};
  d.readImage = [](const fs::path& p) { return readItk<float>(p); };
  d.readLabels = [](const fs::path& p) { return readItk<std::int32_t>(p); };
  d.writeLabels = [](const fs::path& p, const LabelVolume& v) {
    for (std::int32_t l : v.voxels())
      if (l < 0 || l > 32767) fail(p, "label value " + std::to_string(l) + " does not fit a 16-bit label map");
    writeItk(p, toItk<std::int16_t>(v).GetPointer());
  };
  d.writeImage = [](const fs::path& p, const Image3D& v) { writeItk(p, toItk<float>(v).GetPointer()); };
  d.registerImages = registerImagesItk;
  d.readTransform = readAffineTransform;
  d.writeTransform = writeAffineTransform;
  registry.addImageIO(std::move(d));
}

}  // namespace sinew
