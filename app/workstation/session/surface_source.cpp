#include "surface_source.h"

namespace sinew {

Index surfacePointCount(const MeshStore& store, Index mesh) {
  const MeshRange& r = store.range(mesh);
  return r.vertexCount() + (r.cellEnd - r.cellBegin);
}

std::vector<std::array<Index, 3>> surfaceTriangles(const MeshStore& store, Index mesh) {
  const MeshRange& r = store.range(mesh);
  const auto offsets = store.cellOffsets();
  const auto cv = store.cellVertices();
  std::vector<std::array<Index, 3>> out;
  out.reserve(offsets[r.cellEnd] - offsets[r.cellBegin]);
  const Index centres = r.vertexCount();
  for (Index c = r.cellBegin; c < r.cellEnd; ++c)
    for (Index i = offsets[c]; i < offsets[c + 1]; ++i) {
      const Index next = i + 1 == offsets[c + 1] ? offsets[c] : i + 1;
      out.push_back({cv[i] - r.vertexBegin, cv[next] - r.vertexBegin, centres + (c - r.cellBegin)});
    }
  return out;
}

void hostSurfacePoints(MeshStore& store, Index mesh, std::span<Vec3> out) {
  const MeshRange& r = store.range(mesh);
  const auto x = store.positions();
  const auto centres = store.cellCentres();
  std::copy(x.begin() + r.vertexBegin, x.begin() + r.vertexEnd, out.begin());
  std::copy(centres.begin() + r.cellBegin, centres.begin() + r.cellEnd, out.begin() + r.vertexCount());
}

std::vector<ContourSegment> hostContour(MeshStore& store, Index mesh, const SlicePlane& plane) {
  const MeshRange& r = store.range(mesh);
  const auto x = store.positions();
  const auto centres = store.cellCentres();
  const auto offsets = store.cellOffsets();
  const auto cv = store.cellVertices();
  std::vector<ContourSegment> out;
  auto crossing = [&](const Vec3& p, float dp, const Vec3& q, float dq) { return Vec3(p + (q - p) * (dp / (dp - dq))); };
  for (Index c = r.cellBegin; c < r.cellEnd; ++c) {
    const Vec3& centre = centres[c];
    const float dc = plane.normal.dot(centre) - plane.offset;
    for (Index i = offsets[c]; i < offsets[c + 1]; ++i) {
      const Index next = i + 1 == offsets[c + 1] ? offsets[c] : i + 1;
      const Vec3 &a = x[cv[i]], &b = x[cv[next]];
      const float da = plane.normal.dot(a) - plane.offset, db = plane.normal.dot(b) - plane.offset;
      const bool sa = da >= 0, sb = db >= 0, sc = dc >= 0;
      if (sa == sb && sb == sc) continue;
      // Exactly two edges change side; the lone vertex is the one whose side differs.
      if (sa == sb) out.push_back({crossing(b, db, centre, dc), crossing(centre, dc, a, da)});
      else if (sb == sc) out.push_back({crossing(a, da, b, db), crossing(centre, dc, a, da)});
      else out.push_back({crossing(a, da, b, db), crossing(b, db, centre, dc)});
    }
  }
  return out;
}

}  // namespace sinew
