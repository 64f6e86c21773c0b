#include "device_step_blocks.h"

#include "sinew/core/mesh_store.h"

#include <algorithm>

namespace sinew::cuda {

namespace {
constexpr std::size_t kMaxIndex = 0xffff;            // the kernel's 16-bit slots and cell indices
constexpr std::size_t kMaxSharedBytes = 48 * 1024;  // what a block gets without opting in for more
}  // namespace

std::optional<StepBlockArrays> buildStepBlocks(const MeshStore& s) {
  const auto next = s.neighbours();
  const auto cellsOf = s.vertexCells();
  const auto offsets = s.cellOffsets();
  const auto members = s.cellVertices();
  const int n = int(s.vertexCount()), blocks = (n + kStepBlock - 1) / kStepBlock;
  StepBlockArrays a;
  // Reserved at the level-of-detail meshes' sizes (1.19 geometries, 0.79 listed vertices, 0.79
  // cells and 4.7 cell entries a vertex), so that the arrays are not copied as they grow.
  a.start.reserve(blocks + 1);
  a.vertices.reserve(n);
  a.geometry.reserve(n + n / 4);
  a.cellEnd.reserve(n);
  a.cellSlots.reserve(5 * std::size_t(n));
  // A vertex's (a cell's) slot in the block that last marked it: tag == the block's index.
  std::vector<int> tag(n, -1), slot(n), cellTag(s.cellCount(), -1), cellIndex(s.cellCount());
  std::vector<int> outside, extra, cells;
  std::array<int, 4> most{};  // the largest block's positions, cells, geometries and cell entries
  const auto mark = [&] {
    return std::array<int, 4>{int(a.vertices.size()), int(a.geometry.size()), int(a.cellEnd.size()), int(a.cellSlots.size())};
  };
  for (int k = 0; k < blocks; ++k) {
    a.start.push_back(mark());
    const int first = k * kStepBlock, last = std::min(n, first + kStepBlock), count = last - first;
    for (int v = first; v < last; ++v) tag[v] = k, slot[v] = v - first;
    // Vertices outside the block get slots after its own, in ascending order within each group:
    // first the geometry's (the block's neighbours), then the others its positions need.
    const auto addOutside = [&](std::vector<int>& group, Index q) {
      if (tag[q] != k) tag[q] = k, group.push_back(int(q));
    };
    const auto giveSlots = [&](std::vector<int>& group, int from) {
      std::sort(group.begin(), group.end());
      for (std::size_t i = 0; i < group.size(); ++i) slot[group[i]] = from + int(i);
      a.vertices.insert(a.vertices.end(), group.begin(), group.end());
    };
    outside.clear();
    for (int v = first; v < last; ++v)
      for (const Index q : next[v]) addOutside(outside, q);
    giveSlots(outside, count);
    const auto forGeometry = [&](auto&& f) {
      for (int v = first; v < last; ++v) f(v);
      for (const int v : outside) f(v);
    };
    cells.clear();
    forGeometry([&](int v) {
      for (const Index c : cellsOf[v])
        if (cellTag[c] != k) cellTag[c] = k, cellIndex[c] = int(cells.size()), cells.push_back(int(c));
    });
    extra.clear();
    for (const int v : outside)
      for (const Index q : next[v]) addOutside(extra, q);
    for (const int c : cells)
      for (Index i = offsets[c]; i < offsets[c + 1]; ++i) addOutside(extra, members[i]);
    const std::size_t positions = count + outside.size() + extra.size(), geometries = count + outside.size();
    if (positions > kMaxIndex || cells.size() > kMaxIndex) return std::nullopt;
    giveSlots(extra, count + int(outside.size()));
    forGeometry([&](int v) {
      std::array<int, 3> packed;
      for (int j = 0; j < 3; ++j) packed[j] = slot[next[v][j]] | cellIndex[cellsOf[v][j]] << 16;
      a.geometry.push_back(packed);
    });
    const std::size_t cellSlotsBegin = a.cellSlots.size();
    for (const int c : cells) {
      for (Index i = offsets[c]; i < offsets[c + 1]; ++i) a.cellSlots.push_back((unsigned short)slot[members[i]]);
      if (a.cellSlots.size() - cellSlotsBegin > kMaxIndex) return std::nullopt;
      a.cellEnd.push_back((unsigned short)(a.cellSlots.size() - cellSlotsBegin));
    }
    most[0] = std::max(most[0], int(positions));
    most[1] = std::max(most[1], int(cells.size()));
    most[2] = std::max(most[2], int(geometries));
    most[3] = std::max(most[3], int(a.cellSlots.size() - cellSlotsBegin));
  }
  a.start.push_back(mark());
  a.layout = stepBlockLayout(most[0], most[1], most[2], most[3]);
  if (4 * std::size_t(a.layout.words) > kMaxSharedBytes) return std::nullopt;
  return a;
}

bool DeviceStepBlocks::upload(const MeshStore& s, cudaStream_t stream) {
  clear();
  const std::optional<StepBlockArrays> a = buildStepBlocks(s);
  if (!a) return false;
  static_assert(sizeof(int4) == sizeof(a->start[0]) && sizeof(int3) == sizeof(a->geometry[0]));
  start_.upload(reinterpret_cast<const int4*>(a->start.data()), a->start.size(), stream);
  vertices_.upload(a->vertices, stream);
  // The kernel copies a block's geometry and cell entries as the 16-byte span that holds them: 16
  // bytes more, so that the last block's span lies inside the arrays.
  std::vector<std::array<int, 3>> geometry = a->geometry;
  std::vector<unsigned short> cellEnd = a->cellEnd, cellSlots = a->cellSlots;
  geometry.resize(geometry.size() + 2);
  cellEnd.resize(cellEnd.size() + 8);
  cellSlots.resize(cellSlots.size() + 8);
  geometry_.upload(reinterpret_cast<const int3*>(geometry.data()), geometry.size(), stream);
  cellEnd_.upload(cellEnd, stream);
  cellSlots_.upload(cellSlots, stream);
  layout_ = a->layout;
  return true;
}

void DeviceStepBlocks::clear() {
  start_.resize(0);
  vertices_.resize(0);
  geometry_.resize(0);
  cellEnd_.resize(0);
  cellSlots_.resize(0);
  layout_ = {};
}

}  // namespace sinew::cuda
