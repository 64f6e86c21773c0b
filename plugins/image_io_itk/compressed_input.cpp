#include "compressed_input.h"

#include "sinew/core/io.h"

#include <libdeflate.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <new>
#include <string>
#include <utility>
#include <vector>

namespace sinew::itk_input {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void refuse(const fs::path& path, const std::string& problem) {
  throw InputError(path.string() + ": " + problem);
}

using Inflater = std::unique_ptr<libdeflate_decompressor, void (*)(libdeflate_decompressor*)>;

Inflater newInflater() {
  Inflater inflater(libdeflate_alloc_decompressor(), libdeflate_free_decompressor);
  if (!inflater) throw std::bad_alloc();
  return inflater;
}

std::vector<unsigned char> wholeFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) refuse(path, "cannot be opened");
  std::vector<unsigned char> bytes;
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (!ec) bytes.resize(size);
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  if (!in && !ec) refuse(path, "cannot be read");
  return bytes;
}

bool gzipMagicAt(const unsigned char* bytes, std::size_t size, std::size_t at) {
  return size >= at + 2 && bytes[at] == 0x1f && bytes[at + 1] == 0x8b;
}

// The decompressed stream (gzip members one after another; anything after the last member that
// does not start another one is ignored, as zlib's gzread does), or a refusal naming the file.
std::vector<unsigned char> inflateGzip(const fs::path& path, const std::vector<unsigned char>& in) {
  // The first guess is the last member's stated length (its last 4 bytes), no more than deflate's
  // largest ratio (1032:1) allows; a buffer too small grows.
  std::uint32_t stated = 0;
  std::memcpy(&stated, in.data() + in.size() - 4, 4);
  const std::size_t ceiling = 1032 * in.size() + (1 << 20);
  std::size_t capacity = std::min<std::size_t>(std::max<std::size_t>(stated, 1 << 16), ceiling);
  const Inflater inflater = newInflater();
  std::vector<unsigned char> out;
  std::size_t read = 0, written = 0;
  while (read < in.size() && (read == 0 || gzipMagicAt(in.data(), in.size(), read))) {
    std::size_t used = 0, made = 0;
    out.resize(std::max(out.size(), written + capacity));
    const libdeflate_result r = libdeflate_gzip_decompress_ex(inflater.get(), in.data() + read, in.size() - read,
                                                              out.data() + written, out.size() - written, &used, &made);
    if (r == LIBDEFLATE_INSUFFICIENT_SPACE && out.size() < ceiling) {
      capacity = std::min(2 * (out.size() - written), ceiling);
      continue;  // the member again, into more room
    }
    if (r != LIBDEFLATE_SUCCESS) refuse(path, "the compressed data ends early or is corrupt (truncated file?)");
    read += used, written += made;
  }
  out.resize(written);
  return out;
}

}  // namespace

PlainCopy::PlainCopy(fs::path p) : path_(std::move(p)) {}
PlainCopy::PlainCopy(PlainCopy&& other) noexcept : path_(std::exchange(other.path_, {})) {}
PlainCopy& PlainCopy::operator=(PlainCopy&& other) noexcept {
  std::swap(path_, other.path_);
  return *this;
}
PlainCopy::~PlainCopy() {
  std::error_code ec;
  if (!path_.empty()) fs::remove(path_, ec);
}

bool startsWithGzipMagic(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char magic[2] = {};
  in.read(reinterpret_cast<char*>(magic), 2);
  return gzipMagicAt(magic, std::size_t(in.gcount()), 0);
}

// ITK's NIfTI reader does not notice a gzip stream that ends early (it reads zeros) or a corrupt
// one, and inflates with zlib. So a .nii.gz is decompressed here instead, in one pass with
// libdeflate (ch2better.nii.gz's 35 MB in 0.055 s on the 2-core machine, where gzip -d takes 0.24
// s), into an uncompressed copy that ITK reads. Before, the stream was decompressed twice: by ITK,
// and by a check beside it (docs/benchmarks.md).
std::optional<PlainCopy> decompressedNiftiCopy(const fs::path& path) {
  const std::vector<unsigned char> packed = wholeFile(path);
  if (!gzipMagicAt(packed.data(), packed.size(), 0)) return std::nullopt;
  if (packed.size() < 18) refuse(path, "the compressed data ends early or is corrupt (truncated file?)");
  const std::vector<unsigned char> plain = inflateGzip(path, packed);
  const bool singleFile = (plain.size() >= 348 && std::memcmp(plain.data() + 344, "n+1", 4) == 0) ||
                          (plain.size() >= 540 && std::memcmp(plain.data() + 4, "n+2", 4) == 0);
  if (!singleFile) return std::nullopt;  // ITK says what is wrong with it
  std::error_code ec;
  std::string name = (fs::temp_directory_path(ec) / "sinew-read-XXXXXX.nii").string();
  if (ec) return std::nullopt;
  const int fd = mkstemps(name.data(), 4);
  if (fd < 0) return std::nullopt;
  PlainCopy copy{fs::path(name)};
  std::size_t done = 0;
  while (done < plain.size()) {
    const ssize_t n = ::write(fd, plain.data() + done, plain.size() - done);
    if (n <= 0) break;
    done += std::size_t(n);
  }
  if (::close(fd) != 0 || done < plain.size()) return std::nullopt;  // the copy goes with `copy`
  return copy;
}

// MetaIO (ITK 5.2) reads CompressedDataSize bytes from the data's start (after the header, or the
// HeaderSize skip) and inflates them; without a stated size it inflates the whole data file from
// its first byte, header and skip included. Where that misses the stream it returns the buffer
// uninitialised without an error, and one corrupt stream made its inflate loop forever (fuzz_image
// on the H100 host, 2026-11-27). The stream is inflated here once, into exactly the declared size.
void checkCompressedMetaImage(const fs::path& header, const MetaImageData& data, std::uintmax_t voxelBytes) {
  const auto bad = [&](const std::string& problem) { refuse(header, "compressed MetaImage data: " + problem); };
  if (!(data.compressedSize >= 0) || !(data.headerSize >= 0) || !std::isfinite(data.compressedSize) ||
      !std::isfinite(data.headerSize))
    bad("CompressedDataSize and HeaderSize must be byte counts (HeaderSize -1 is not read with compressed data)");
  // MetaIO truncates both to whole bytes.
  const bool sized = data.compressedSize >= 1.0, skips = data.headerSize >= 1.0;
  if (!sized && data.local) bad("the voxels follow the header (LOCAL) but CompressedDataSize does not say how many bytes they take");
  if (!sized && skips) bad("a HeaderSize skip needs CompressedDataSize, or the skipped bytes are read as data");
  const std::vector<unsigned char> bytes = wholeFile(data.file);
  // Compared as doubles first: a value beyond any integer type is not converted (found by review;
  // the conversion would be undefined behaviour).
  const double fileBytes = double(bytes.size());
  if (data.compressedSize > fileBytes || data.headerSize > fileBytes)
    bad("CompressedDataSize or HeaderSize goes beyond the end of " + data.file.filename().string() + " (" +
        std::to_string(bytes.size()) + " bytes; truncated?)");
  const auto stated = std::uintmax_t(data.compressedSize), skip = std::uintmax_t(data.headerSize);
  const std::uintmax_t start = stated == 0 ? 0 : skip > 0 ? skip : data.local ? data.afterHeader : 0;
  const std::uintmax_t size = stated == 0 ? bytes.size() : stated;
  if (start > bytes.size() || size > bytes.size() - start)
    bad("CompressedDataSize says " + std::to_string(stated) + " bytes from byte " + std::to_string(start) + ", beyond the end of " +
        data.file.filename().string() + " (" + std::to_string(bytes.size()) + " bytes; truncated?)");
  // MetaIO inflates zlib or gzip (inflateInit2 with 47); a stream that makes more or less than the
  // voxels is as corrupt as one that does not decode.
  const Inflater inflater = newInflater();
  std::vector<unsigned char> voxels(voxelBytes);
  const unsigned char* in = bytes.data() + start;
  const libdeflate_result r =
      gzipMagicAt(in, size, 0) ? libdeflate_gzip_decompress(inflater.get(), in, size, voxels.data(), voxels.size(), nullptr)
                               : libdeflate_zlib_decompress(inflater.get(), in, size, voxels.data(), voxels.size(), nullptr);
  if (r == LIBDEFLATE_SHORT_OUTPUT) bad("the stream holds fewer than the " + std::to_string(voxelBytes) + " bytes of voxels the header declares (truncated or corrupt?)");
  if (r == LIBDEFLATE_INSUFFICIENT_SPACE) bad("the stream holds more than the " + std::to_string(voxelBytes) + " bytes of voxels the header declares (corrupt header?)");
  if (r != LIBDEFLATE_SUCCESS) bad("the stream is not zlib or gzip data, or it is corrupt");
}

}  // namespace sinew::itk_input
