#include "sinew/core/attachments.h"

#include "sinew/core/simplex_mesh.h"
#include "sinew/core/surface_distance.h"
#include "point_tree.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace sinew {

namespace {
// Barycentric coordinates of q (on the triangle a b c) by least squares, clamped and renormalised.
std::array<float, 3> barycentric(const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e0 = b - a, e1 = c - a, d = q - a;
  const float d00 = e0.dot(e0), d01 = e0.dot(e1), d11 = e1.dot(e1), d20 = d.dot(e0), d21 = d.dot(e1);
  const float det = d00 * d11 - d01 * d01;
  if (!(std::abs(det) > 0.0f)) return {1.0f, 0.0f, 0.0f};
  float v = (d11 * d20 - d01 * d21) / det, w = (d00 * d21 - d01 * d20) / det;
  v = std::clamp(v, 0.0f, 1.0f), w = std::clamp(w, 0.0f, 1.0f);
  if (v + w > 1.0f) {
    const float s = v + w;
    v /= s, w /= s;
  }
  return {1.0f - v - w, v, w};
}

// A point of structure m's tessellation as weights over its vertices (global indices): a vertex
// itself, or a cell centre (the mean of the cell's vertices).
void addPointWeights(const MeshStore& store, Index m, Index point, float weight, std::map<Index, float>& out) {
  const MeshRange& r = store.range(m);
  const Index vertices = r.vertexCount();
  if (point < vertices) {
    out[r.vertexBegin + point] += weight;
    return;
  }
  const Index cell = r.cellBegin + (point - vertices);
  const auto offsets = store.cellOffsets();
  const auto members = store.cellVertices();
  const float share = weight / float(offsets[cell + 1] - offsets[cell]);
  for (Index k = offsets[cell]; k < offsets[cell + 1]; ++k) out[members[k]] += share;
}
}  // namespace

void Attachments::build(MeshStore& store, const Executor& executor) {
  attached_.clear();
  merged_.clear();
  fixed_.clear();
  const auto x = store.positions();
  std::vector<char> taken(store.vertexCount(), 0);  // a vertex is attached, merged or fixed once
  for (const AttachmentSpec& spec : specs_) {
    const MeshRange& own = store.range(spec.structure);
    if (spec.kind == AttachmentSpec::Kind::Fixed) {
      for (Index v = own.vertexBegin; v < own.vertexEnd; ++v)
        if (!taken[v] && (x[v] - spec.centre).norm() <= spec.radiusMm) {
          taken[v] = 1;
          fixed_.push_back({v, x[v]});
        }
      continue;
    }
    const auto otherPoints = store.mesh(x, spec.other);
    const TriangleMesh surface = tessellate(store.topologyOf(spec.other), {otherPoints.begin(), otherPoints.end()});
    if (spec.kind == AttachmentSpec::Kind::Merge) {
      // Each vertex pairs with the nearest free vertex of the other structure within the distance
      // (the candidates from a k-d tree, in the vertices' order: deterministic).
      const MeshRange& other = store.range(spec.other);
      const PointCloud cloud{store.mesh(x, spec.other)};
      const PointTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
      nanoflann::SearchParams params;
      params.sorted = true;
      std::vector<std::pair<std::uint32_t, float>> found;
      for (Index v = own.vertexBegin; v < own.vertexEnd; ++v) {
        if (taken[v]) continue;
        found.clear();
        tree.radiusSearch(x[v].data(), spec.distanceMm * spec.distanceMm, found, params);
        for (const auto& [local, d2] : found) {
          const Index u = other.vertexBegin + Index(local);
          if (taken[u]) continue;
          taken[v] = taken[u] = 1;
          merged_.push_back({v, u, x[u] - x[v]});
          break;
        }
      }
      continue;
    }
    // Surface: the closest point of the other tessellation (its hierarchy's search), as weights
    // over its vertices.
    const SurfaceDistanceQuery query(surface);
    const Index count = own.vertexCount();
    std::vector<std::optional<Attached>> found(static_cast<std::size_t>(count));
    executor.forEach(count, [&](Index k) {
      const Index v = own.vertexBegin + k;
      if (taken[v]) return;
      const SurfaceDistanceQuery::Closest c = query.closest(x[v]);
      if (!(c.distance <= spec.distanceMm)) return;
      const auto& tri = c.triangle;
      const auto b = barycentric(c.point, surface.points[tri[0]], surface.points[tri[1]], surface.points[tri[2]]);
      std::map<Index, float> weights;
      for (int corner = 0; corner < 3; ++corner) addPointWeights(store, spec.other, tri[corner], b[corner], weights);
      Attached a{v, {weights.begin(), weights.end()}, Vec3::Zero()};
      Vec3 on = Vec3::Zero();
      for (const auto& [u, w] : a.weights) on += w * x[u];
      a.offset = x[v] - on;
      found[std::size_t(k)] = std::move(a);
    });
    for (std::optional<Attached>& a : found)
      if (a) {
        taken[a->vertex] = 1;
        attached_.push_back(std::move(*a));
      }
  }
}

AttachmentArrays Attachments::arrays() const {
  AttachmentArrays a;
  for (const Merged& p : merged_) {
    a.mergedA.push_back(int(p.a));
    a.mergedB.push_back(int(p.b));
    a.mergedOffset.push_back(p.offset);
  }
  for (const Fixed& f : fixed_) {
    a.fixedVertex.push_back(int(f.vertex));
    a.fixedAt.push_back(f.at);
  }
  std::vector<char> attached;
  for (const Attached& v : attached_) {
    if (std::size_t(v.vertex) >= attached.size()) attached.resize(std::size_t(v.vertex) + 1, 0);
    attached[std::size_t(v.vertex)] = 1;
  }
  for (const Attached& v : attached_) {
    a.attachedVertex.push_back(int(v.vertex));
    for (const auto& [u, w] : v.weights) {
      a.attachedSource.push_back(int(u));
      a.attachedWeight.push_back(w);
      a.attachedInOrder = a.attachedInOrder || (std::size_t(u) < attached.size() && attached[std::size_t(u)]);
    }
    a.attachedOffsets.push_back(int(a.attachedSource.size()));
    a.attachedOffset.push_back(v.offset);
  }
  return a;
}

void Attachments::validate(const MeshStore& store) const {
  for (std::size_t k = 0; k < specs_.size(); ++k) {
    const AttachmentSpec& a = specs_[k];
    const auto bad = [&](const std::string& why) { throw InputError("attachment " + std::to_string(k) + ": " + why); };
    if (a.structure < 0 || a.structure >= store.meshCount()) bad("no structure " + std::to_string(a.structure));
    if (a.kind == AttachmentSpec::Kind::Fixed) {
      if (!(a.radiusMm > 0.0f) || !a.centre.allFinite()) bad("the fixed sphere needs a finite centre and a positive radius");
      continue;
    }
    if (a.other < 0 || a.other >= store.meshCount()) bad("no structure " + std::to_string(a.other));
    if (a.other == a.structure) bad("a structure cannot be attached to itself");
    if (!(a.distanceMm > 0.0f)) bad("the distance must be positive");
  }
}

void Attachments::shareForces(MeshStore& store) {
  const auto f = store.forces();
  const auto m = store.masses();
  for (Merged& p : merged_) {
    const Index a = p.a, b = p.b;
    const Vec3 total = f[a] + f[b];
    const float mass = m[a] + m[b];
    p.shareA = mass > 0.0f ? m[a] / mass : 0.5f;
    f[a] = p.shareA * total;
    f[b] = (1.0f - p.shareA) * total;
  }
  for (const Fixed& v : fixed_) f[v.vertex] = Vec3::Zero();
  for (const Attached& v : attached_) f[v.vertex] = Vec3::Zero();
}

void Attachments::project(MeshStore& store) const {
  if (fixed_.empty() && attached_.empty() && merged_.empty()) return;
  const bool hasPrevious = store.has(Attribute::PreviousPosition);
  auto x = store.positionsForWrite();
  std::span<Vec3> prev = hasPrevious ? store.previousPositions() : std::span<Vec3>{};
  // A merged pair at its offset about its centre of mass (which the step moved), so that the two
  // never drift apart (different velocities carried from a coarser level, implicit Euler's blocks).
  // The masses' shares are shareForces' (this step's geometry): asking the store for masses here
  // would recompute every structure's geometry for the positions the integrator just wrote.
  for (const Merged& p : merged_) {
    const float wa = p.shareA, wb = 1.0f - p.shareA;
    const auto place = [&](std::span<Vec3> at) {
      const Vec3 centre = wa * at[p.a] + wb * at[p.b];
      at[p.a] = centre - wb * p.offset;
      at[p.b] = centre + wa * p.offset;
    };
    place(x);
    if (hasPrevious) place(prev);
  }
  for (const Fixed& v : fixed_) {
    x[v.vertex] = v.at;
    if (hasPrevious) prev[v.vertex] = v.at;
  }
  // A vertex is attached once; a surface vertex that is itself attached elsewhere is moved in the
  // scene's order of the attachments.
  for (const Attached& v : attached_) {
    Vec3 on = v.offset, before = v.offset;
    for (const auto& [u, w] : v.weights) {
      on += w * x[u];
      if (hasPrevious) before += w * prev[u];
    }
    x[v.vertex] = on;
    if (hasPrevious) prev[v.vertex] = before;
  }
}

}  // namespace sinew
