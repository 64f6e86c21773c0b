// Image IO through ITK: NIfTI (.nii, .nii.gz), NRRD (.nrrd, .nhdr), MetaImage (.mha, .mhd) and
// DICOM series (a directory). ITK keeps images in LPS world coordinates and converts NIfTI's RAS
// on read and write, so every image in Sinew is LPS (docs/architecture.md, "Physical space").
#include "compressed_input.h"
#include "itk_convert.h"
#include "itk_registration.h"
#include "itk_transforms.h"
#include "nifti_sform.h"
#include "sinew/core/registry.h"

#include <itkGDCMImageIO.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkImage.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkMetaImageIO.h>
#include <itkNiftiImageIO.h>
#include <itkNrrdImageIO.h>
#include <itkImageSeriesReader.h>

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <fstream>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <utility>

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
    if (!std::isfinite(io.GetOrigin(d))) fail(path, "has a non-finite origin");
    for (unsigned e = 0; e < 3; ++e)
      if (!std::isfinite(io.GetDirection(d)[e])) fail(path, "has a non-finite orientation (direction cosines)");
  }
}

// ITK's MetaImage reader (MetaIO) mishandles many malformed headers (found by fuzz_image): a huge
// NDims (minutes of work), long names (a buffer overflow), data split over several files (a '%'
// name goes to printf; a LIST crashes it). The header is checked here, strictly, before ITK sees
// the file. Sinew reads a volume from one data file.
void checkMetaImageHeader(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  for (int lines = 1; std::getline(in, line); ++lines) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto bad = [&](const std::string& problem) {
      fail(path, "MetaImage header line " + std::to_string(lines) + ": " + problem);
    };
    // MetaIO copies names and values into fixed buffers of 255 characters (a long name overflows
    // one: found by fuzz_image), so the header must be plain "Key = Value" lines of text.
    if (lines > 200) bad("no ElementDataFile within 200 lines");
    const auto eq = line.find('=');
    if (eq == std::string::npos) bad("not a \"Key = Value\" line");
    std::string key = line.substr(0, eq), value = line.substr(eq + 1);
    while (!key.empty() && key.back() == ' ') key.pop_back();
    while (!value.empty() && value.front() == ' ') value.erase(0, 1);
    if (key.empty() || key.size() > 64 || key.find_first_not_of(
                                               "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_") != std::string::npos)
      bad("the key is not a name of letters, digits and _ (at most 64)");
    if (value.size() > 200) bad("the value is longer than 200 characters");
    for (const char c : value)
      if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) bad("the value is not plain text");
    if (key == "NDims") {
      // Digits only: read as an integer, "1e30" passed as 1, but MetaIO reads a double and then
      // tried to read 10^30 numbers per axis field (found by fuzz_image on CI).
      while (!value.empty() && value.back() == ' ') value.pop_back();
      const bool digits = !value.empty() && value.size() <= 2 && value.find_first_not_of("0123456789") == std::string::npos;
      if (!digits || std::stoi(value) < 1 || std::stoi(value) > 10) bad("NDims is not a dimension count between 1 and 10");
    }
    if (key == "ElementDataFile") {
      // Without a name MetaIO reads compressed data from a failed stream and asks for 2^63 bytes
      // (found by fuzz_image).
      while (!value.empty() && value.back() == ' ') value.pop_back();
      if (value.empty()) bad("ElementDataFile names no data file (LOCAL or a file name)");
      if (value.find_first_of("% \t") != std::string::npos || value.rfind("LIST", 0) == 0)
        bad("the data are split over several files (a '%' pattern or a LIST), which Sinew does not read");
      return;  // the header ends here
    }
  }
  fail(path, "MetaImage header: no ElementDataFile line");
}

// ITK's NRRD reader (teem) leaves the data file of a detached header open when it fails after
// opening it (found by fuzz_image: one descriptor per bad file, until a long session had none
// left), and teem reads field names case-insensitively. The header is checked here, strictly:
// the magic, then known fields, "key:=value" pairs and comments, all plain text, and one data file.
void checkNrrdHeader(const fs::path& path, bool detached) {
  static const std::set<std::string> fields = {
      "dimension", "type", "sizes", "encoding", "endian", "content", "block size", "blocksize", "min", "max", "old min",
      "oldmin", "old max", "oldmax", "data file", "datafile", "line skip", "lineskip", "byte skip", "byteskip", "number",
      "sample units", "sampleunits", "spacings", "thicknesses", "axis mins", "axismins", "axis maxs", "axismaxs",
      "centers", "centerings", "labels", "units", "kinds", "space", "space dimension", "space units", "space origin",
      "space directions", "measurement frame"};
  std::ifstream in(path, std::ios::binary);
  std::string line;
  bool dataFile = false;
  for (int lines = 1; std::getline(in, line); ++lines) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto bad = [&](const std::string& problem) {
      fail(path, "NRRD header line " + std::to_string(lines) + ": " + problem);
    };
    if (lines == 1) {
      if (line.size() != 8 || line.rfind("NRRD000", 0) != 0 || line[7] < '1' || line[7] > '5') bad("not an NRRD magic (NRRD0001 to NRRD0005)");
      continue;
    }
    if (line.empty()) break;  // the end of the header; the data follow (attached)
    if (lines > 200) bad("no end of the header within 200 lines");
    if (line.size() > 1024) bad("longer than 1024 characters");
    for (const char c : line)
      if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) > 126) bad("not plain text");
    if (line.front() == '#') continue;
    if (line.find(":=") != std::string::npos && line.find(":=") < line.find(": ")) continue;  // key:=value
    const auto colon = line.find(": ");
    if (colon == std::string::npos) bad("not a \"field: value\" line");
    std::string field = line.substr(0, colon), value = line.substr(colon + 2);
    std::transform(field.begin(), field.end(), field.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (!fields.count(field)) bad("unknown field \"" + field + "\"");
    if (field == "data file" || field == "datafile") {
      while (!value.empty() && value.front() == ' ') value.erase(0, 1);
      while (!value.empty() && value.back() == ' ') value.pop_back();
      if (value.empty() || value.find_first_of(" %") != std::string::npos || value == "LIST")
        bad("the data are split over several files (a pattern or a LIST), which Sinew does not read");
      if (dataFile) bad("a second data file");
      dataFile = true;
    }
  }
  if (detached && !dataFile) fail(path, "NRRD header: a detached header (.nhdr) without a data file");
}

// ITK's NIfTI reader aborts the process (vnl's assert_finite, in the orientation's SVD) on a header
// whose voxel size, quaternion or affine rows hold a NaN, an infinity, or values so large that the
// orientation overflows (found by fuzz_image): they are checked here first, for NIfTI-1 (and
// Analyze) and NIfTI-2, either byte order, compressed or not. The byte order is told by dim[0]
// (1-7), as the NIfTI library does. The library picks the layout by sizeof_hdr (348 or 540, either
// byte order) before the magic: a header with NIfTI-2's magic and another size was read as NIfTI-1
// (found by fuzz_image on the H100 host, 2026-11-27). So the NIfTI-2 layout is checked where the
// size or the magic says NIfTI-2, and the NIfTI-1 layout wherever the size is not 540.
// Returns the header's vox_offset (where the voxels start in a single file; 0 when it cannot tell).
double checkNiftiHeader(const fs::path& path) {
  gzFile f = gzopen(path.c_str(), "rb");  // reads uncompressed files as they are
  if (!f) fail(path, "cannot be opened");
  unsigned char h[540] = {};
  const int n = gzread(f, h, sizeof h);
  gzclose(f);
  if (n < 348) return 0.0;  // ITK says what is wrong with it
  std::uint32_t size;
  std::memcpy(&size, h, 4);
  const bool size540 = size == 540 || __builtin_bswap32(size) == 540;
  // The library reads such a header as NIfTI-2 whatever its length (found by fuzz_image).
  if (size540 && n < 540) fail(path, "its NIfTI-2 header is cut short (" + std::to_string(n) + " of 540 bytes)");
  const bool nifti2 = size540 || (n >= 540 && std::memcmp(h + 4, "n+2", 3) == 0), nifti1 = !size540;
  // Checks one layout's voxel size and orientation; returns its vox_offset.
  const auto checkLayout = [&](bool two) {
    bool swapped = false;
    if (two) {
      std::int64_t dim0;
      std::memcpy(&dim0, h + 16, 8);
      swapped = !(dim0 >= 1 && dim0 <= 7);
    } else {
      std::int16_t dim0;
      std::memcpy(&dim0, h + 40, 2);
      swapped = !(dim0 >= 1 && dim0 <= 7);
    }
    const auto valueAt = [&](int at, bool isDouble) {
      double v;
      if (isDouble) {
        std::uint64_t bits;
        std::memcpy(&bits, h + at, 8);
        if (swapped) bits = __builtin_bswap64(bits);
        std::memcpy(&v, &bits, 8);
      } else {
        std::uint32_t bits;
        std::memcpy(&bits, h + at, 4);
        if (swapped) bits = __builtin_bswap32(bits);
        float x;
        std::memcpy(&x, &bits, 4);
        v = x;
      }
      return v;
    };
    const auto check = [&](int at, int count, bool isDouble) {
      for (int k = 0; k < count; ++k)
        if (!(std::abs(valueAt(at + k * (isDouble ? 8 : 4), isDouble)) <= 1e9))
          fail(path, "has a NaN, infinite or absurd (beyond 1e9) voxel size or orientation in its NIfTI header");
    };
    if (two) {
      check(104, 8, true);   // pixdim
      check(352, 18, true);  // quatern_b..qoffset_z, srow_x, srow_y, srow_z
      std::uint64_t bits;
      std::memcpy(&bits, h + 168, 8);
      return double(static_cast<std::int64_t>(swapped ? __builtin_bswap64(bits) : bits));
    }
    check(76, 8, false);
    check(256, 18, false);
    return valueAt(108, false);  // a float: compared as a double, whatever it holds (fuzz_image)
  };
  const double offset1 = nifti1 ? checkLayout(false) : 0.0, offset2 = nifti2 ? checkLayout(true) : 0.0;
  const double offset = size540 ? offset2 : offset1;
  return offset > 0.0 && offset < 1e12 ? std::floor(offset) : 0.0;
}

// The file that holds the voxels (the image file itself, or the data file a detached header names,
// beside it; empty when it cannot tell) and whether they may be compressed there.
struct DataFile {
  fs::path path;
  bool compressed = false;
  itk_input::MetaImageData meta;  // a MetaImage's: where MetaIO looks for compressed voxels
};

DataFile dataFileOf(const fs::path& path, const std::string& extension) {
  if (extension == ".nii") return {path, false};
  // A .nii.gz that is not gzip-compressed is read as it is (znzlib): its voxels are measured as
  // uncompressed. Taken as compressed, a short one passed checkDataFits and ITK's NIfTI reader left
  // the file open after the short read (found by fuzz_image, 2026-12-01).
  if (extension == ".nii.gz") return {path, itk_input::startsWithGzipMagic(path)};
  const bool meta = extension == ".mha" || extension == ".mhd";
  DataFile found{extension == ".nrrd" || extension == ".mha" ? path : fs::path{}, !meta};  // NRRD: raw unless it says
  std::ifstream in(path, std::ios::binary);
  std::string line;
  bool binary = true;  // MetaIO's default for images
  // MetaIO reads a flag as true when its value starts with T, t or 1.
  const auto flag = [](const std::string& value) { return !value.empty() && (value[0] == 'T' || value[0] == 't' || value[0] == '1'); };
  const auto number = [](const std::string& value) {
    double v = 0;
    std::istringstream(value) >> v;
    return v;
  };
  for (int lines = 0; lines < 200 && std::getline(in, line); ++lines) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto at = meta ? line.find('=') : line.find(':');
    if (at == std::string::npos) {
      if (!meta && line.empty()) break;  // the end of an NRRD header
      continue;
    }
    std::string key = line.substr(0, at), value = line.substr(at + 1);
    if (!value.empty() && value.front() == '=') value.erase(0, 1);  // NRRD's key:=value
    while (!key.empty() && key.back() == ' ') key.pop_back();
    while (!value.empty() && value.front() == ' ') value.erase(0, 1);
    while (!value.empty() && value.back() == ' ') value.pop_back();
    // NRRD's field names are case-insensitive for teem ("Data file" is its data file).
    if (!meta) std::transform(key.begin(), key.end(), key.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (!meta && key == "encoding") found.compressed = value != "raw";
    if (meta && key == "BinaryData") binary = flag(value);
    if (meta && key == "CompressedData") found.compressed = flag(value);
    if (meta && key == "CompressedDataSize") found.meta.compressedSize = number(value);
    if (meta && key == "HeaderSize") found.meta.headerSize = number(value);
    if ((meta && key == "ElementDataFile") || (!meta && (key == "data file" || key == "datafile"))) {
      found.meta.local = meta && (value == "LOCAL" || value == "Local" || value == "local");
      if (found.meta.local || (!meta && value == "LOCAL")) found.path = path;
      else if (value.find_first_of(" %") != std::string::npos || value == "LIST") found.path.clear();  // several files
      else found.path = path.parent_path() / value;
      if (meta) {
        const auto end = in.tellg();  // -1 where the header ends without a newline: no data follow
        std::error_code ec;
        found.meta.afterHeader = end >= 0 ? std::uintmax_t(end) : fs::file_size(path, ec);
        break;  // the header ends here
      }
    }
  }
  found.compressed = found.compressed && (binary || !meta);  // MetaIO reads text data as they are
  found.meta.file = found.path;
  return found;
}

// A header may claim gigabytes in a file of a few hundred bytes; the volume is allocated before ITK
// finds out (found by fuzz_image). The voxels must fit the file that holds them: its size, or
// deflate's largest ratio (1032:1) times it when they may be compressed.
// voxelOffset: where the voxels start in the data file (a .nii's header before them).
void checkDataFits(const fs::path& path, const std::string& extension, itk::ImageIOBase& io, double voxelOffset) {
  const DataFile data = dataFileOf(path, extension);
  std::error_code ec;
  const auto size = data.path.empty() ? std::uintmax_t(0) : fs::file_size(data.path, ec);
  std::error_code kindError;
  if (!data.path.empty() && fs::exists(data.path, kindError) && !fs::is_regular_file(data.path, kindError))
    fail(path, "its data file " + data.path.string() + " is not a regular file");
  // A named data file that is missing is refused here, before the volume the header claims is
  // allocated (found by fuzz_image: 2.7 GB for a header whose data file did not exist).
  if (!data.path.empty() && ec) fail(path, "its data file " + data.path.string() + " cannot be read (" + ec.message() + ")");
  if (data.path.empty()) return;  // several files, or a format that does not say: ITK checks
  const double need = double(io.GetImageSizeInBytes());
  const double room = (data.compressed ? 1032.0 : 1.0) * double(size) - voxelOffset;
  if (need > room)
    fail(path, "its header claims " + std::to_string(std::uintmax_t(need)) + " bytes of voxels" +
                   (voxelOffset > 0 ? " from byte " + std::to_string(std::uintmax_t(voxelOffset)) : std::string()) + ", more than " +
                   data.path.filename().string() + " (" + std::to_string(size) + " bytes) can hold (truncated or corrupt?)");
  if ((extension == ".mha" || extension == ".mhd") && data.compressed)
    itk_input::checkCompressedMetaImage(path, data.meta, io.GetImageSizeInBytes());
}

template <class Pixel>
Volume<Pixel> readNonSeries(const fs::path& path);

Volume<std::int32_t> labelsFrom(const fs::path& path, const Volume<double>& values) {
  Volume<std::int32_t> labels(values.geometry());
  auto out = labels.voxels().begin();
  for (const double v : values.voxels()) {
    if (!(v >= -2147483648.0 && v <= 2147483647.0) || v != std::floor(v)) {
      std::ostringstream text;
      text << "is not a label map: voxel value " << v << " is not a whole number in the label range";
      fail(path, text.str());
    }
    *out++ = static_cast<std::int32_t>(v);
  }
  return labels;
}

Volume<float> floatsFrom(const fs::path& path, const Volume<double>& values) {
  Volume<float> image(values.geometry());
  auto out = image.voxels().begin();
  for (const double v : values.voxels()) {
    if (std::isfinite(v) && std::abs(v) > double(std::numeric_limits<float>::max())) {
      std::ostringstream text;
      text << "voxel value " << v << " is beyond the range Sinew computes in (float)";
      fail(path, text.str());
    }
    *out++ = static_cast<float>(v);
  }
  return image;
}

// teem (ITK's NRRD reader) leaves a detached header's data file open when it fails after opening
// it: a corrupt compressed stream, a skip past the end, bad text (found by fuzz_image: one
// descriptor per bad file, until a long session had none left). After a failed read this closes
// the descriptors opened during it on that data file. Detached reads are serialised, so no other
// read has that file open meanwhile; a read of an image nested in it (a conversion) shares the lock.
class DetachedNrrdGuard {
public:
  explicit DetachedNrrdGuard(const fs::path& dataFile)
      : lock_(mutex()), dataFile_(fs::weakly_canonical(dataFile)), before_(descriptorsOn(dataFile_)),
        exceptions_(std::uncaught_exceptions()) {}
  DetachedNrrdGuard(const DetachedNrrdGuard&) = delete;
  DetachedNrrdGuard& operator=(const DetachedNrrdGuard&) = delete;
  ~DetachedNrrdGuard() {
    if (std::uncaught_exceptions() == exceptions_) return;  // a read that succeeded closed it
    for (const int fd : descriptorsOn(dataFile_))
      if (!before_.count(fd)) ::close(fd);
  }

private:
  static std::recursive_mutex& mutex() {
    static std::recursive_mutex m;
    return m;
  }
  static std::set<int> descriptorsOn(const fs::path& file) {
    std::set<int> out;
    std::error_code ec;
    for (auto it = fs::directory_iterator("/proc/self/fd", ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
      std::error_code linkError;
      const fs::path target = fs::read_symlink(it->path(), linkError);
      if (!linkError && target == file) out.insert(std::stoi(it->path().filename().string()));
    }
    return out;
  }
  std::lock_guard<std::recursive_mutex> lock_;
  fs::path dataFile_;
  std::set<int> before_;
  int exceptions_;
};

// The ITK reader / writer for a file name's extension (lower case, ioExtension), or null. ITK's
// object factory list is not guarded for concurrent first use, and images are read and written on
// several threads at once (scene_runner.cpp, sinew-run's outputs).
itk::ImageIOBase::Pointer imageIOFor(const std::string& extension) {
  static std::mutex factoryMutex;
  const std::lock_guard lock(factoryMutex);
  if (extension == ".nii" || extension == ".nii.gz") return itk::NiftiImageIO::New().GetPointer();
  if (extension == ".nrrd" || extension == ".nhdr") return itk::NrrdImageIO::New().GetPointer();
  if (extension == ".mha" || extension == ".mhd") return itk::MetaImageIO::New().GetPointer();
  return nullptr;
}

// ITK 5.2's NiftiImageIO::ReadImageInformation compares a global string of libITKIONIFTI with the
// file name and assigns it when they differ: two headers read at once on two threads wrote the
// same address (ThreadSanitizer, sinew-run on a subject scene, 2026-11-27), and the runner reads
// every input image on its own thread. Two assignments at once that both grow the string free its
// buffer twice: the likely cause of the rare "malloc(): unaligned tcache chunk detected" in CI
// (docs/reliability.md). Every NIfTI header read and every NIfTI write holds this lock; the
// voxels' reading and decompression stay parallel.
std::unique_lock<std::mutex> niftiLock(const std::string& extension) {
  static std::mutex niftiMutex;
  if (extension == ".nii" || extension == ".nii.gz") return std::unique_lock(niftiMutex);
  return {};
}

// A NIfTI file's voxels, a slab of slices at a time, each read by ITK straight into its place in the
// volume. Read whole, ITK would hold two more full copies of the file's voxels beside the volume
// while it converts them (nifti_image_load's buffer and the reader's own when the file's type is not
// the volume's): 70 MB for the demo's 0.5 mm training image, at the run's early peak of host memory.
// A slab is about 256 K voxels: slabs of 4 M voxels kept the peak 36-45 MB higher, since glibc, once
// it has freed a buffer that large, keeps freed buffers up to that size in its arenas
// (docs/benchmarks.md, "The demo's host memory"). NiftiImageIO reads a slab alone
// (nifti_read_subregion_image). False when ITK read more than the slab (the caller then reads the
// file whole).
template <class Pixel>
bool readNiftiInSlabs(itk::ImageFileReader<itk::Image<Pixel, 3>>& reader, Volume<Pixel>& volume) {
  constexpr std::size_t kSlabVoxels = std::size_t(1) << 18;
  auto* image = reader.GetOutput();
  const auto whole = image->GetLargestPossibleRegion();
  const std::size_t slice = std::size_t(whole.GetSize(0)) * whole.GetSize(1);
  const auto depth = static_cast<itk::SizeValueType>(std::max<std::size_t>(1, kSlabVoxels / std::max<std::size_t>(slice, 1)));
  if (depth >= whole.GetSize(2)) return false;  // one slab: the whole read is as small
  for (itk::SizeValueType z = 0; z < whole.GetSize(2); z += depth) {
    auto slab = whole;
    slab.SetIndex(2, whole.GetIndex(2) + static_cast<itk::IndexValueType>(z));
    slab.SetSize(2, std::min(depth, whole.GetSize(2) - z));
    Pixel* const at = volume.voxels().data() + z * slice;
    image->GetPixelContainer()->SetImportPointer(at, slab.GetNumberOfPixels(), false);  // ITK reads into the volume
    image->SetRequestedRegion(slab);
    reader.Update();
    if (image->GetBufferedRegion() != slab) return false;
    if (image->GetBufferPointer() != at) std::copy_n(image->GetBufferPointer(), slab.GetNumberOfPixels(), at);
  }
  return true;
}

// A single-file image (not a DICOM series), its header checked, read straight into the volume's
// buffer: no second full-size copy (the training image is 230 MB as floats).
template <class Pixel>
Volume<Pixel> readNonSeries(const fs::path& path) {
  using ImageType = itk::Image<Pixel, 3>;
  const std::string extension = ioExtension(path);
  if (extension == ".mha" || extension == ".mhd") checkMetaImageHeader(path);
  const double voxelOffset = extension == ".nii" || extension == ".nii.gz" ? checkNiftiHeader(path) : 0.0;
  if (extension == ".nrrd" || extension == ".nhdr") checkNrrdHeader(path, extension == ".nhdr");
  std::optional<DetachedNrrdGuard> detachedGuard;  // also a .nrrd whose header names a data file
  if (extension == ".nrrd" || extension == ".nhdr")
    if (const fs::path data = dataFileOf(path, extension).path; !data.empty() && data != path) detachedGuard.emplace(data);
  // The reader the name says, not ITK's factory: the factory asks every reader it knows whether it
  // can read the file, and GDCM's asserts (aborting the process) on a file that holds "DICM" where
  // a DICOM preamble would end (found by fuzz_image).
  const itk::ImageIOBase::Pointer io = imageIOFor(extension);
  if (!io || !io->CanReadFile(path.c_str()))
    fail(path, "is not a " + (extension.empty() ? std::string("readable") : extension) +
                   " image of a format Sinew reads (NIfTI, NRRD, MetaImage; DICOM as a folder), or it is corrupt");
  io->SetFileName(path.string());
  try {
    const auto lock = niftiLock(extension);
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    fail(path, "cannot read the image header: " + brief(e));
  }
  checkHeader(path, *io);
  checkDataFits(path, extension, *io, voxelOffset);
  if constexpr (std::is_same_v<Pixel, std::int32_t>) {
    // ITK converts other voxel types to int32 by a cast: a float beyond int32's range is undefined
    // behaviour (found by fuzz_image), a fraction or a large unsigned value a wrong label. Those
    // types are read as double and every voxel checked.
    using IO = itk::IOComponentEnum;
    const IO type = io->GetComponentType();
    if (type != IO::CHAR && type != IO::UCHAR && type != IO::SHORT && type != IO::USHORT && type != IO::INT)
      return labelsFrom(path, readNonSeries<double>(path));
  }
  if constexpr (std::is_same_v<Pixel, float>) {
    // Likewise a double beyond float's range.
    if (io->GetComponentType() == itk::IOComponentEnum::DOUBLE) return floatsFrom(path, readNonSeries<double>(path));
  }
  auto reader = itk::ImageFileReader<ImageType>::New();
  reader->SetImageIO(io);
  reader->SetFileName(path.string());
  {
    const auto lock = niftiLock(extension);
    reader->UpdateOutputInformation();
  }
  ImageType* image = reader->GetOutput();
  const bool nifti = extension == ".nii" || extension == ".nii.gz";
  ImageGeometry geometry = geometryOf(*image);
  if (nifti) {
    const auto lock = niftiLock(extension);
    if (const auto sform = nifti::sformPlacement(path.string(), image->GetSpacing(), {image->GetOrigin(), image->GetDirection()}))
      for (int a = 0; a < 3; ++a) {
        geometry.origin[a] = sform->origin[a];
        for (int b = 0; b < 3; ++b) geometry.direction(a, b) = sform->direction[a][b];
      }
  }
  Volume<Pixel> volume(geometry);
  if (nifti && readNiftiInSlabs(*reader, volume)) return volume;
  image->SetRequestedRegionToLargestPossibleRegion();
  image->GetPixelContainer()->SetImportPointer(volume.voxels().data(), volume.voxels().size(), false);
  reader->Update();
  // ITK kept the buffer it was given unless its pipeline chose otherwise; then the voxels are copied.
  if (image->GetBufferPointer() != volume.voxels().data())
    std::copy_n(image->GetBufferPointer(), volume.voxels().size(), volume.voxels().data());
  return volume;
}

template <class Pixel>
Volume<Pixel> readItk(const fs::path& path) {
  using ImageType = itk::Image<Pixel, 3>;
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path, "no such file or directory");
  std::optional<itk_input::PlainCopy> copy;
  // What is said about the copy is said about the file.
  const auto named = [&](std::string message) {
    if (!copy) return message;
    for (const auto& [from, to] : {std::pair(copy->path().string(), path.string()),
                                   std::pair(copy->path().filename().string(), path.filename().string() + " decompressed")})
      for (auto at = message.find(from); at != std::string::npos; at = message.find(from, at + to.size()))
        message.replace(at, from.size(), to);
    return message;
  };
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
    // A .nii.gz is checked and decompressed first; ITK reads the copy (decompressedNiftiCopy).
    if (ioExtension(path) == ".nii.gz") copy = itk_input::decompressedNiftiCopy(path);
    return readNonSeries<Pixel>(copy ? copy->path() : path);
  } catch (const itk::ExceptionObject& e) {
    fail(path, "cannot read the voxel data (truncated or corrupt file?): " + named(brief(e)));
  } catch (const InputError& e) {
    if (!copy) throw;
    throw InputError(named(e.what()));
  } catch (const std::exception& e) {
    // ITK's readers let standard exceptions through on some corrupt headers (a std::length_error
    // from MetaIO, found by fuzz_image).
    fail(path, std::string("cannot be read (corrupt header?): ") + named(e.what()));
  }
}

template <class ItkImage>
void writeItk(const fs::path& path, ItkImage* image) {
  AtomicOutput out(path);
  // The writer the name says, not ITK's factory: sinew-run writes its outputs on several threads at
  // once, and a factory lookup there once found no NIfTI writer (H100 host, 2026-11-24).
  const std::string extension = ioExtension(path);
  const itk::ImageIOBase::Pointer io = imageIOFor(extension);
  if (!io) fail(path, "cannot be written: give it a .nii, .nii.gz, .nrrd, .nhdr, .mha or .mhd name");
  try {
    auto writer = itk::ImageFileWriter<ItkImage>::New();
    writer->SetImageIO(io);
    writer->SetFileName(out.tempPath().string());
    writer->SetInput(image);
    writer->UseCompressionOn();
    const auto lock = niftiLock(extension);
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
  d.readTransform = readRegistrationTransform;
  d.writeTransform = writeRegistrationTransform;
  registry.addImageIO(std::move(d));
}

}  // namespace sinew
