// VTK XML sizes checked before VTK reads them (mesh_header_checks.h). VTK's XML reader allocates
// what a piece's counts and an appended array's block header claim before it reads a byte of the
// data: a damaged header of a 300-byte file made it zero-fill gigabytes (found by fuzz_model).
#include "mesh_header_checks.h"

#include "sinew/core/types.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <optional>
#include <string>

namespace sinew {

namespace fs = std::filesystem;

namespace {
[[noreturn]] void fail(const fs::path& path, const std::string& problem) { throw InputError(path.string() + ": " + problem); }

// The value of name="..." in a tag's text, if there.
std::optional<std::string> attribute(const std::string& tag, const std::string& name) {
  for (std::size_t at = tag.find(name + "=\""); at != std::string::npos; at = tag.find(name + "=\"", at + 1)) {
    if (at > 0 && !std::isspace(static_cast<unsigned char>(tag[at - 1]))) continue;  // "XNumberOfPoints"
    const std::size_t begin = at + name.size() + 2, end = tag.find('"', begin);
    if (end == std::string::npos) return std::nullopt;
    return tag.substr(begin, end - begin);
  }
  return std::nullopt;
}

std::uint64_t count(const fs::path& path, const std::string& text, const std::string& what) {
  const auto first = text.find_first_not_of(" \t\r\n"), last = text.find_last_not_of(" \t\r\n");
  if (first == std::string::npos || last - first > 19) fail(path, what + " \"" + text + "\" is not a count");
  std::uint64_t n = 0;
  for (std::size_t i = first; i <= last; ++i) {
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) fail(path, what + " \"" + text + "\" is not a count");
    n = n * 10 + std::uint64_t(text[i] - '0');
  }
  return n;
}

// Each tag of this name in the text, from '<' to '>'.
template <class Visit>
void forEachTag(const std::string& text, const std::string& name, Visit visit) {
  for (std::size_t at = text.find("<" + name); at != std::string::npos; at = text.find("<" + name, at + 1)) {
    const std::size_t end = text.find('>', at);
    if (end == std::string::npos) return;  // VTK refuses the unclosed tag itself
    const char next = text[at + 1 + name.size()];
    if (std::isspace(static_cast<unsigned char>(next)) || next == '>' || next == '/') visit(text.substr(at, end - at + 1));
  }
}
}  // namespace

void checkVtkXmlSizes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const std::uint64_t fileSize = fs::file_size(path, ec);
  if (!in || ec) fail(path, "cannot be opened");
  // The XML up to the appended data (all of it when the data are inline), at most 4 MB: the tags
  // that say what VTK allocates come first.
  std::string xml(std::size_t(std::min<std::uint64_t>(fileSize, 4u << 20)), '\0');
  in.read(xml.data(), std::streamsize(xml.size()));
  xml.resize(std::size_t(in.gcount()));
  const std::size_t appended = xml.find("<AppendedData");
  const std::string head = xml.substr(0, appended);

  std::string headerType = "UInt32", compressor, byteOrder = "LittleEndian";
  forEachTag(head, "VTKFile", [&](const std::string& tag) {
    headerType = attribute(tag, "header_type").value_or("UInt32");
    compressor = attribute(tag, "compressor").value_or("");
    byteOrder = attribute(tag, "byte_order").value_or("LittleEndian");
  });
  if (headerType != "UInt32" && headerType != "UInt64") fail(path, "header_type \"" + headerType + "\" is neither UInt32 nor UInt64");
  const bool zlib = compressor == "vtkZLibDataCompressor";
  // A count of elements may not exceed the bytes that could hold them: one per element at least,
  // after zlib's largest expansion (1032:1) when compressed. Other compressors are not bounded here.
  const std::uint64_t most = compressor.empty() || zlib ? (zlib ? 1032 : 1) * fileSize + 1024 : UINT64_MAX;
  forEachTag(head, "Piece", [&](const std::string& tag) {
    for (const char* name : {"NumberOfPoints", "NumberOfVerts", "NumberOfLines", "NumberOfStrips", "NumberOfPolys"})
      if (const auto value = attribute(tag, name)) {
        const std::uint64_t n = count(path, *value, name);
        if (n > most)
          fail(path, std::string(name) + " is " + std::to_string(n) + ", more than a file of " + std::to_string(fileSize) +
                         " bytes can hold (truncated or corrupt?)");
      }
  });
  if (appended == std::string::npos) return;
  // Appended data: each array's header at its offset after the '_' that starts the data, raw or in
  // base64 (then the offset counts characters, and the header is encoded apart from the data).
  const std::size_t tagEnd = xml.find('>', appended);
  if (tagEnd == std::string::npos) return;
  const std::string encoding = attribute(xml.substr(appended, tagEnd - appended + 1), "encoding").value_or("");
  if (encoding != "raw" && encoding != "base64") return;
  const bool base64 = encoding == "base64";
  const std::size_t underscore = xml.find('_', tagEnd);
  if (underscore == std::string::npos) fail(path, "its appended data has no start ('_')");
  const std::uint64_t dataStart = underscore + 1;
  const int word = headerType == "UInt64" ? 8 : 4;
  const bool swap = byteOrder == "BigEndian";
  const auto encodedSize = [&](std::uint64_t bytes) { return base64 ? (bytes + 2) / 3 * 4 : bytes; };
  // The first n bytes of the header at file position at: Short where the file ends first, Unclear
  // where the base64 holds other characters (line breaks?: then VTK, in its server, judges it).
  enum class Got { Bytes, Short, Unclear };
  const auto headerBytes = [&](std::uint64_t at, std::uint64_t n, std::string& out) {
    std::string stored(std::size_t(encodedSize(n)), '\0');
    in.clear();
    in.seekg(std::streamoff(at));
    in.read(stored.data(), std::streamsize(stored.size()));
    if (std::uint64_t(in.gcount()) != stored.size()) return Got::Short;
    if (!base64) {
      out = std::move(stored);
      return Got::Bytes;
    }
    out.clear();
    std::uint32_t bits = 0;
    int count = 0;
    for (char c : stored) {
      int v = c >= 'A' && c <= 'Z' ? c - 'A' : c >= 'a' && c <= 'z' ? c - 'a' + 26 : c >= '0' && c <= '9' ? c - '0' + 52
            : c == '+' ? 62 : c == '/' ? 63 : c == '=' ? 0 : -1;
      if (v < 0) return Got::Unclear;
      bits = (bits << 6) | std::uint32_t(v);
      if (++count == 4) {
        for (int k = 2; k >= 0; --k) out += char((bits >> (8 * k)) & 0xff);
        bits = 0;
        count = 0;
      }
    }
    out.resize(std::size_t(n));
    return Got::Bytes;
  };
  const auto wordAt = [&](const std::string& bytes, std::uint64_t i) {
    std::uint64_t v = 0;
    for (int b = 0; b < word; ++b)
      v |= std::uint64_t(static_cast<unsigned char>(bytes[std::size_t(i * word + b)])) << (8 * (swap ? word - 1 - b : b));
    return v;
  };
  forEachTag(head, "DataArray", [&](const std::string& tag) {
    if (attribute(tag, "format").value_or("") != "appended") return;
    const std::string name = attribute(tag, "Name").value_or("(unnamed)");
    const auto offsetText = attribute(tag, "offset");
    if (!offsetText) fail(path, "appended array " + name + " has no offset");
    const std::uint64_t offset = count(path, *offsetText, "the offset of array " + name);
    if (offset >= fileSize || dataStart + offset >= fileSize) fail(path, "array " + name + " starts beyond the end of the file");
    const std::uint64_t at = dataStart + offset, stored = fileSize - at;
    // The data bytes the file can hold after a header of n bytes (a little slack for padding).
    const auto room = [&](std::uint64_t n) {
      const std::uint64_t after = stored - std::min(stored, encodedSize(n));
      return (base64 ? after / 4 * 3 : after) + 8;
    };
    std::string h;
    // The header's first n bytes into h; false: not checkable here.
    const auto header = [&](std::uint64_t n) {
      const Got got = headerBytes(at, n, h);
      if (got == Got::Short) fail(path, "array " + name + " has a truncated header");
      return got == Got::Bytes;
    };
    if (compressor.empty()) {
      if (header(word) && wordAt(h, 0) > room(word))
        fail(path, "array " + name + " claims more bytes than the file holds (truncated or corrupt?)");
      return;
    }
    if (!header(3 * word)) return;
    const std::uint64_t blocks = wordAt(h, 0), blockSize = wordAt(h, 1), lastSize = wordAt(h, 2);
    const std::uint64_t most = room(3 * word) / word;
    if (blocks > most)
      fail(path, "array " + name + " claims " + std::to_string(blocks) + " compressed blocks; the file holds at most " +
                     std::to_string(most) + " (truncated or corrupt?)");
    if (!header((3 + blocks) * word)) return;
    std::uint64_t compressed = 0;
    for (std::uint64_t b = 0; b < blocks; ++b) compressed += std::min<std::uint64_t>(wordAt(h, 3 + b), fileSize);
    if (compressed > room((3 + blocks) * word))
      fail(path, "array " + name + "'s compressed blocks are larger than the file (truncated or corrupt?)");
    if (lastSize > blockSize) fail(path, "array " + name + "'s last block is larger than its blocks");
    // What the blocks hold uncompressed: all full but the last (lastSize 0: full too).
    std::uint64_t total = 0;
    const bool overflows = blocks > 0 && (__builtin_mul_overflow(blocks - 1, blockSize, &total) ||
                                          __builtin_add_overflow(total, lastSize ? lastSize : blockSize, &total));
    if (zlib && (overflows || total > 1032 * compressed + 1024 * (blocks + 1)))
      fail(path, "array " + name + " claims " + (overflows ? std::string("over 2^64") : std::to_string(total)) +
                     " bytes from " + std::to_string(compressed) +
                     " compressed bytes: more than zlib can expand them to (corrupt?)");
  });
}

}  // namespace sinew
