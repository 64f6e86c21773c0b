// Compressed voxel data checked before ITK reads them. ITK's readers inflate with zlib and trust
// what they find: a .nii.gz that ends early reads as zeros, and MetaIO returns uninitialised
// memory for a compressed MetaImage it cannot place, or never returns (found by fuzz_image;
// docs/reliability.md). Here the data are inflated with libdeflate and refused, naming the file,
// unless they hold exactly what the header declares.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>

namespace sinew::itk_input {

// An uncompressed copy of an image in the temporary directory, removed when this goes.
class PlainCopy {
public:
  explicit PlainCopy(std::filesystem::path p);
  PlainCopy(PlainCopy&& other) noexcept;
  PlainCopy& operator=(PlainCopy&& other) noexcept;
  ~PlainCopy();
  const std::filesystem::path& path() const { return path_; }

private:
  std::filesystem::path path_;
};

// A .nii.gz checked (every gzip member's CRC-32 and length) and decompressed in one pass, for ITK to
// read instead of the file; none for a file that is not gzip-compressed, a header that names a
// separate data file, or where the temporary directory takes no copy (ITK then reads the file
// itself, already checked). Throws InputError naming `path` on a corrupt or truncated stream.
std::optional<PlainCopy> decompressedNiftiCopy(const std::filesystem::path& path);

// Whether the file starts with gzip's magic (what zlib and libdeflate take for a gzip stream).
bool startsWithGzipMagic(const std::filesystem::path& path);

// Where MetaIO will look for a compressed MetaImage's voxels, as its header says.
struct MetaImageData {
  std::filesystem::path file;            // the header itself (LOCAL) or the data file beside it
  bool local = false;                    // the voxels follow the header in the same file
  std::uintmax_t afterHeader = 0;        // LOCAL: the byte after the ElementDataFile line
  double headerSize = 0;                 // HeaderSize: bytes skipped from the data file's start
  double compressedSize = 0;             // CompressedDataSize (0: not stated)
};

// Refuses, naming `header`, compressed MetaImage data that MetaIO would misread: a LOCAL stream or
// a header skip without CompressedDataSize (MetaIO then inflates from the file's first byte), a
// stated size beyond the file, or a zlib/gzip stream that is corrupt or does not inflate to exactly
// `voxelBytes`.
void checkCompressedMetaImage(const std::filesystem::path& header, const MetaImageData& data, std::uintmax_t voxelBytes);

}  // namespace sinew::itk_input
