#include "mesh_header_checks.h"

#include "sinew/core/types.h"

#include <bit>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace sinew {

namespace fs = std::filesystem;

namespace {
[[noreturn]] void fail(const fs::path& path, const std::string& problem) { throw InputError(path.string() + ": " + problem); }

// Bytes of each PLY scalar type (0: unknown).
int typeBytes(const std::string& t) {
  static const std::map<std::string, int> sizes = {
      {"char", 1},   {"uchar", 1},  {"int8", 1},   {"uint8", 1},    {"short", 2},   {"ushort", 2},
      {"int16", 2},  {"uint16", 2}, {"int", 4},    {"uint", 4},     {"int32", 4},   {"uint32", 4},
      {"float", 4},  {"float32", 4}, {"double", 8}, {"float64", 8}};
  const auto it = sizes.find(t);
  return it == sizes.end() ? 0 : it->second;
}

struct Property {
  std::string name, type, countType;  // countType set: a list
};
struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

// Reads values one after the other from the data part, ascii or binary.
class Values {
public:
  Values(const fs::path& path, const std::string& data, int format) : path_(path), data_(data), format_(format) {}
  double next(const std::string& type, const char* what) {
    if (format_ == 0) {
      while (at_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[at_]))) ++at_;
      const std::size_t start = at_;
      while (at_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[at_]))) ++at_;
      if (start == at_) fail(path_, std::string("the data end early (reading ") + what + ")");
      const std::string word = data_.substr(start, at_ - start);
      char* end = nullptr;
      const double v = std::strtod(word.c_str(), &end);
      if (end != word.c_str() + word.size()) fail(path_, "'" + word + "' is not a number (reading " + what + ")");
      return v;
    }
    const int n = typeBytes(type);
    if (data_.size() - at_ < std::size_t(n)) fail(path_, std::string("the data end early (reading ") + what + ")");
    unsigned char b[8];
    std::memcpy(b, data_.data() + at_, n);
    at_ += n;
    const bool little = format_ == 1;
    if (little != (std::endian::native == std::endian::little))
      for (int i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
    auto as = [&](auto v) {
      std::memcpy(&v, b, sizeof v);
      return double(v);
    };
    if (type == "char" || type == "int8") return as(std::int8_t{});
    if (type == "uchar" || type == "uint8") return as(std::uint8_t{});
    if (type == "short" || type == "int16") return as(std::int16_t{});
    if (type == "ushort" || type == "uint16") return as(std::uint16_t{});
    if (type == "int" || type == "int32") return as(std::int32_t{});
    if (type == "uint" || type == "uint32") return as(std::uint32_t{});
    if (type == "float" || type == "float32") return as(float{});
    return as(double{});
  }

private:
  const fs::path& path_;
  const std::string& data_;
  int format_;  // 0 ascii, 1 binary little endian, 2 binary big endian
  std::size_t at_ = 0;
};
}  // namespace

TriangleMesh readPly(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot be opened");
  const std::string bytes{std::istreambuf_iterator<char>(in), {}};
  // The header, line by line.
  std::vector<Element> elements;
  int format = -1;
  std::size_t at = 0;
  for (int n = 1;; ++n) {
    const std::size_t eol = bytes.find('\n', at);
    if (eol == std::string::npos || eol - at > 4096) fail(path, "PLY header line " + std::to_string(n) + ": no end_header");
    std::string line = bytes.substr(at, eol - at);
    at = eol + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto bad = [&](const std::string& problem) { fail(path, "PLY header line " + std::to_string(n) + ": " + problem); };
    std::istringstream words(line);
    std::string word, rest;
    words >> word;
    if (n == 1) {
      if (line != "ply") bad("the file does not start with \"ply\"");
      continue;
    }
    if (word == "format") {
      std::string f, version;
      words >> f >> version;
      format = f == "ascii" ? 0 : f == "binary_little_endian" ? 1 : f == "binary_big_endian" ? 2 : -1;
      if (format < 0 || version != "1.0" || (words >> rest)) bad("expected \"format ascii|binary_little_endian|binary_big_endian 1.0\"");
    } else if (word == "comment" || word == "obj_info" || word.empty()) {
    } else if (word == "end_header") {
      break;
    } else if (word == "element") {
      Element e;
      long long count = -1;
      if (!(words >> e.name >> count) || count < 0 || (words >> rest)) bad("expected \"element NAME COUNT\"");
      if (std::uint64_t(count) > bytes.size()) bad("element '" + e.name + "' claims more items than the file has bytes");
      e.count = std::uint64_t(count);
      elements.push_back(std::move(e));
    } else if (word == "property") {
      if (elements.empty()) bad("a property before any element");
      Property p;
      words >> p.type;
      if (p.type == "list") {
        words >> p.countType >> p.type;
        if (!typeBytes(p.countType) || p.countType.find("float") == 0 || p.countType == "double")
          bad("a list count must be of an integer type");
      }
      if (!typeBytes(p.type) || !(words >> p.name) || (words >> rest)) bad("expected \"property [list COUNT_TYPE] TYPE NAME\" with known types");
      elements.back().properties.push_back(std::move(p));
    } else {
      bad("unknown keyword '" + word + "'");
    }
  }
  if (format < 0) fail(path, "PLY header: no format line");
  // The data.
  const std::string data = bytes.substr(at);
  Values values(path, data, format);
  TriangleMesh mesh;
  bool sawVertex = false, sawFace = false;
  for (const Element& e : elements) {
    int x = -1, y = -1, z = -1, list = -1;
    for (int k = 0; k < int(e.properties.size()); ++k) {
      const Property& p = e.properties[k];
      if (p.countType.empty()) x = p.name == "x" ? k : x, y = p.name == "y" ? k : y, z = p.name == "z" ? k : z;
      else if (p.name == "vertex_indices" || p.name == "vertex_index") list = k;
    }
    const bool isVertex = e.name == "vertex", isFace = e.name == "face";
    if (isVertex && (x < 0 || y < 0 || z < 0)) fail(path, "PLY header: the vertex element lacks x, y or z");
    if (isFace && list < 0) fail(path, "PLY header: the face element has no vertex_indices list");
    if (isVertex) mesh.points.reserve(std::size_t(e.count));
    sawVertex |= isVertex;
    sawFace |= isFace;
    const std::string what = "element '" + e.name + "'";
    for (std::uint64_t i = 0; i < e.count; ++i) {
      Vec3 p = Vec3::Zero();
      for (int k = 0; k < int(e.properties.size()); ++k) {
        const Property& prop = e.properties[k];
        if (prop.countType.empty()) {
          const double v = values.next(prop.type, what.c_str());
          if (!isVertex || (k != x && k != y && k != z)) continue;
          if (!(std::abs(v) <= double(std::numeric_limits<float>::max())))  // NaN too: float(v) would be undefined
            fail(path, "vertex " + std::to_string(i) + " has a coordinate that is not a finite float (" + std::to_string(v) + ")");
          p[k == x ? 0 : k == y ? 1 : 2] = float(v);
          continue;
        }
        const double count = values.next(prop.countType, what.c_str());
        if (!(count >= 0 && count <= 1e6) || count != double(std::int64_t(count))) fail(path, what + ": a list count of " + std::to_string(count));
        std::vector<Index> ids(static_cast<std::size_t>(count));
        for (auto& id : ids) {
          const double v = values.next(prop.type, what.c_str());
          if (!isFace || k != list) continue;  // another list: read past it
          if (!(v >= 0 && v < double(mesh.points.size()) && v == std::floor(v)))
            fail(path, "face " + std::to_string(i) + " refers to vertex " + std::to_string(v) + ", which does not exist");
          id = Index(v);
        }
        if (isFace && k == list)
          for (std::size_t j = 1; j + 1 < ids.size(); ++j) mesh.triangles.push_back({ids[0], ids[j], ids[j + 1]});
      }
      if (isVertex) {
        if (!p.allFinite()) fail(path, "vertex " + std::to_string(i) + " has a non-finite coordinate");
        mesh.points.push_back(p);
      }
    }
    if (isFace && !sawVertex) fail(path, "PLY: the face element comes before the vertex element");
  }
  if (!sawVertex || !sawFace) fail(path, "PLY: no vertex and face elements");
  return mesh;
}

void checkStlSize(const fs::path& path) {
  // VTK reads a file as ASCII when its first 256 bytes are mostly text (vtksys DetectFileType);
  // here only when they all are, so every file VTK would read as binary has its count checked.
  std::ifstream in(path, std::ios::binary);
  char first[256] = {};
  in.read(first, sizeof first);
  const std::streamsize got = in.gcount();
  bool text = got >= 5 && std::string(first, 5) == "solid";
  for (std::streamsize i = 0; text && i < got; ++i) {
    const unsigned char c = static_cast<unsigned char>(first[i]);
    text = (c >= 32 && c < 127) || c == '\n' || c == '\r' || c == '\t';
  }
  if (text) return;  // ASCII: read line by line
  const char* header = first;
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (got < 84 || ec) fail(path, "is neither an ASCII STL (\"solid ...\") nor a binary one (too short)");
  std::uint32_t count;
  std::memcpy(&count, header + 80, 4);
  if (std::endian::native == std::endian::big) count = __builtin_bswap32(count);
  if (84 + 50 * std::uint64_t(count) > size)
    fail(path, "binary STL claims " + std::to_string(count) + " triangles; the file holds " +
                   std::to_string((size - 84) / 50) + " (truncated or corrupt?)");
}

}  // namespace sinew
