// Host-side pieces of the engine's device mirror of a mesh store (cuda_engine.cpp): typed uploads,
// image views, the connectivity as the kernels read it, the global prolongation between levels, and
// the coarser levels of the multi-resolution forces. Host C++ only; no device code.
#pragma once

#include "cuda_check.h"
#include "kernels.h"
#include "sinew/core/simulation.h"

#include <cmath>
#include <memory>
#include <span>
#include <vector>

namespace sinew::cuda {

template <class T, class U>
void uploadAs(DeviceArray<T>& dst, std::span<const U> src, cudaStream_t stream) {
  static_assert(sizeof(T) == sizeof(U));
  dst.upload(reinterpret_cast<const T*>(src.data()), src.size(), stream);
}

// A volume's world-to-index transform as the kernels take it: the same float matrix as Volume<T>
// (the inverse in double, then cast).
inline VolumeView viewOf(const ImageGeometry& g) {
  VolumeView v{};
  v.sx = g.size[0];
  v.sy = g.size[1];
  v.sz = g.size[2];
  const Eigen::Matrix3f m = g.indexToWorldMatrix().inverse().cast<float>();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) v.m[r * 3 + c] = m(r, c);
  const Vec3 o = g.origin.cast<float>();
  v.origin = make_float3(o.x(), o.y(), o.z());
  return v;
}

// One prolongation for the whole store, from `level` to level + 1: global fine rows, global coarse
// indices (coarseBegin: each structure's first vertex at `level`).
struct GlobalProlongation {
  std::vector<int> rows{0}, index;
  std::vector<float> weight;
};
inline GlobalProlongation globalProlongation(const Simulation& sim, int level, const std::vector<int>& coarseBegin) {
  GlobalProlongation g;
  for (Index m = 0; m < sim.structureCount(); ++m) {
    const Prolongation& p = sim.structure(m).levels.prolongations[level];
    for (Index r = 0; r < p.fineCount(); ++r) {
      for (Index k = p.rowOffsets[r]; k < p.rowOffsets[r + 1]; ++k) {
        g.index.push_back(coarseBegin[m] + p.coarseIndex[k]);
        g.weight.push_back(p.weight[k]);
      }
      g.rows.push_back(static_cast<int>(g.index.size()));
    }
  }
  return g;
}

// Each structure's first vertex at a level, in the store's order.
inline std::vector<int> meshBegins(const Simulation& sim, int level) {
  std::vector<int> begin;
  int next = 0;
  for (Index m = 0; m < sim.structureCount(); ++m) {
    begin.push_back(next);
    next += sim.structure(m).levels.levels[level].vertexCount();
  }
  return begin;
}

// A store's connectivity on the device, as the kernels read it through a MeshView.
struct DeviceTopology {
  DeviceArray<int3> neighbours, vertexCells;
  DeviceArray<int> cellOffsets, cellVertices, meshOf;
  DeviceArray<int4> cellSpans;  // per vertex, where its cells' vertices are (cellSpansOf)

  void upload(const MeshStore& s, cudaStream_t stream) {
    uploadAs(neighbours, s.neighbours(), stream);
    uploadAs(vertexCells, s.vertexCells(), stream);
    uploadAs(cellOffsets, s.cellOffsets(), stream);
    uploadAs(cellVertices, s.cellVertices(), stream);
    uploadAs(meshOf, s.meshOfVertex(), stream);
    if (geometryReadsCellSpans(int(s.vertexCount()))) cellSpans.upload(cellSpansOf(s), stream);
    else cellSpans.resize(0);
  }
  void bind(const MeshStore& s, MeshView& v) const {
    v.vertices = s.vertexCount();
    v.cells = s.cellCount();
    v.neighbours = neighbours.get();
    v.vertexCells = vertexCells.get();
    v.cellOffsets = cellOffsets.get();
    v.cellVertices = cellVertices.get();
    v.meshOf = meshOf.get();
  }
  std::size_t bytes() const {
    return neighbours.bytes() + vertexCells.bytes() + cellOffsets.bytes() + cellVertices.bytes() + meshOf.bytes() +
           cellSpans.bytes();
  }

  // Each vertex's three cells as their first entries in cellVertices (x, y, z) and their sizes (w:
  // kCellSpanBits bits each), so that the small scenes' geometry reads a cell's vertices without
  // first reading its offsets: one dependent load fewer (geometryReadsCellSpans). Empty where a
  // cell is too large to pack (the geometry then reads the offsets).
  static std::vector<int4> cellSpansOf(const MeshStore& s) {
    const auto offsets = s.cellOffsets();
    const auto cells = s.vertexCells();
    std::vector<int4> out(cells.size());
    for (std::size_t v = 0; v < cells.size(); ++v) {
      int begin[3], sizes = 0;
      for (int j = 0; j < 3; ++j) {
        const Index c = cells[v][j], n = offsets[c + 1] - offsets[c];
        if (n >= (Index(1) << kCellSpanBits)) return {};
        begin[j] = int(offsets[c]);
        sizes |= int(n) << (kCellSpanBits * j);
      }
      out[v] = make_int4(begin[0], begin[1], begin[2], sizes);
    }
    return out;
  }
};

// The reference parameters as the shape prior's kernels read them: (eps1, eps2, sin phi, cos phi).
inline void uploadReference(DeviceArray<float4>& dst, std::span<const SimplexParams> rp, const Executor& executor,
                            cudaStream_t stream) {
  std::vector<float4> r(rp.size());
  executor.forEach(Index(rp.size()), [&](Index v) {
    r[v] = make_float4(rp[v].eps1, rp[v].eps2, std::sin(rp[v].phi), std::cos(rp[v].phi));
  }, 4096);
  dst.upload(r, stream);
}

// A coarser level for the multi-resolution forces: its topology, geometry and forces on the device,
// where its positions are gathered from the current level and whence its forces go up a level.
struct CoarseLevel {
  DeviceTopology topology;
  DeviceArray<int> gatherIndex, upRows, upIndex;
  DeviceArray<float> density, elevation, area, upWeight;
  DeviceArray<float3> x, force, normal, centre;
  DeviceArray<float4> reference;
  MeshView view;
  int upCount = 0;  // vertices of the level above

  // Level l below the simulation's current one, from its host store: topology, reference
  // parameters, the gather and prolongation indices. fineBegin: meshBegins at the current level.
  static std::unique_ptr<CoarseLevel> upload(Simulation& sim, int l, const std::vector<int>& fineBegin,
                                             cudaStream_t stream) {
    MeshStore& cs = sim.coarseStore(l);
    auto c = std::make_unique<CoarseLevel>();
    c->topology.upload(cs, stream);
    std::vector<int> gather;
    std::vector<float> dens;
    const int stride = 1 << (2 * (sim.level() - l));
    for (Index m = 0; m < cs.meshCount(); ++m) {
      for (Index t = 0; t < cs.range(m).vertexCount(); ++t) gather.push_back(fineBegin[m] + t * stride);
      dens.push_back(1.0f);
    }
    c->gatherIndex.upload(gather, stream);
    c->density.upload(dens, stream);
    const Index n = cs.vertexCount();
    c->x.resize(n);
    c->force.resize(n);
    c->normal.resize(n);
    c->elevation.resize(n);
    c->area.resize(n);
    c->centre.resize(cs.cellCount());
    uploadReference(c->reference, cs.referenceParams(), cs.executor(), stream);
    const GlobalProlongation up = globalProlongation(sim, l, meshBegins(sim, l));
    c->upRows.upload(up.rows, stream);
    c->upIndex.upload(up.index, stream);
    c->upWeight.upload(up.weight, stream);
    c->upCount = static_cast<int>(up.rows.size()) - 1;
    MeshView& v = c->view;
    c->topology.bind(cs, v);
    v.density = c->density.get();
    v.x = c->x.get();
    v.force = c->force.get();
    v.normal = c->normal.get();
    v.elevation = c->elevation.get();
    v.area = c->area.get();
    v.cellCentre = c->centre.get();
    return c;
  }
};
}  // namespace sinew::cuda
