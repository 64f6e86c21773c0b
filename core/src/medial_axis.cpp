#include "sinew/core/medial_axis.h"

#include "point_tree.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <vector>

namespace sinew {

namespace {

float boundingRadius(std::span<const Vec3> points) {
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (const Vec3& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return std::max(0.5f * (hi - lo).norm(), 1e-3f);
}

constexpr float kInsideTolerance = 0.02f;  // of the radius

// The ball at sample i (point p, outward normal n) of radius r shrinks to the one through p and the
// nearest other sample q to its centre, tangent at p: |p - r n - q| = r gives
// r = |p - q|^2 / (2 n.(p - q)), smaller than r whenever q lies inside (and then n.(p - q) > 0).
// A sample without a usable normal (collapsed cells), or whose ball never shrank below the samples'
// extent or did not settle, gets no ball (radius 0): such a ball would claim the whole structure.
InscribedBall shrinkBall(const PointTree& tree, std::span<const Vec3> samples, std::size_t i, const Vec3& n, float maxRadius) {
  const Vec3& p = samples[i];
  if (!n.allFinite() || std::abs(n.squaredNorm() - 1.0f) > 1e-3f || !p.allFinite()) return {p, 0.0f};
  float r = maxRadius;
  bool settled = false;
  for (int iteration = 0; iteration < 100; ++iteration) {
    const Vec3 c = p - r * n;
    std::uint32_t index[2];
    float distance2[2];
    const std::size_t found = tree.knnSearch(c.data(), 2, index, distance2);
    std::size_t k = 0;
    while (k < found && (index[k] == i || (samples[index[k]] - p).squaredNorm() < 1e-12f)) ++k;
    // No other sample inside, or one barely inside: a polygonal surface's normals are a degree or so
    // off, and a ball along a tilted normal sticks out of a sphere by about r times the tilt, so
    // an exact test would shrink it far below the shape's thickness.
    if (k == found || std::sqrt(distance2[k]) >= r * (1.0f - kInsideTolerance)) {
      settled = true;
      break;
    }
    const Vec3 pq = p - samples[index[k]];
    const float below = n.dot(pq);
    const float next = below > 0.0f ? pq.squaredNorm() / (2.0f * below) : r;
    if (!(next < r)) {
      settled = true;  // cannot shrink further: the ball through p and q tangent at p
      break;
    }
    r = next;
  }
  if (!settled || !(r < maxRadius)) return {p, 0.0f};
  return {p - r * n, r};
}

// How many of the samples nearest a ball's centre may take that ball (the touching pass): bounded,
// so that a sphere, whose every ball touches every sample, costs N K and not N^2.
constexpr std::size_t kTouchingCandidates = 128;
}  // namespace

std::vector<InscribedBall> inscribedBalls(std::span<const Vec3> samples, std::span<const Vec3> outwardNormals,
                                          const Executor& executor) {
  std::vector<InscribedBall> balls(samples.size());
  if (samples.empty()) return balls;
  const PointCloud cloud{samples};
  const PointTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  const float maxRadius = boundingRadius(samples);
  executor.forEach(Index(samples.size()), [&](Index i) { balls[i] = shrinkBall(tree, samples, std::size_t(i), outwardNormals[i], maxRadius); }, 64);
  // Each sample takes the largest of the balls that touch it (Hildebrand's local thickness over
  // this set of inscribed balls): its own ball may be small where its normal is tilted. The choice
  // is a maximum of (radius, -ball index), so it does not depend on the threads' order.
  std::vector<std::atomic<std::uint64_t>> best(samples.size());
  for (auto& b : best) b.store(0, std::memory_order_relaxed);
  const auto keyOf = [](float radius, std::size_t ball) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &radius, sizeof bits);  // positive floats order as their bits
    return (std::uint64_t(bits) << 32) | std::uint64_t(~std::uint32_t(ball));
  };
  executor.forEach(Index(samples.size()), [&](Index j) {
    if (!(balls[j].radius > 0.0f)) return;
    const float reach = balls[j].radius * (1.0f + kInsideTolerance);
    std::uint32_t index[kTouchingCandidates];
    float distance2[kTouchingCandidates];
    const std::size_t found = tree.knnSearch(balls[j].centre.data(), kTouchingCandidates, index, distance2);
    const std::uint64_t key = keyOf(balls[j].radius, std::size_t(j));
    for (std::size_t k = 0; k < found; ++k) {
      if (distance2[k] > reach * reach) break;  // sorted nearest first
      std::atomic<std::uint64_t>& slot = best[index[k]];
      std::uint64_t seen = slot.load(std::memory_order_relaxed);
      while (seen < key && !slot.compare_exchange_weak(seen, key, std::memory_order_relaxed)) {
      }
    }
  }, 64);
  std::vector<InscribedBall> largest(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const std::uint64_t key = best[i].load(std::memory_order_relaxed);
    largest[i] = key == 0 ? balls[i] : balls[~std::uint32_t(key & 0xffffffffu)];
  }
  return largest;
}

std::vector<Vec3> vertexNormals(const TriangleMesh& mesh) {
  std::vector<Vec3> normals(mesh.points.size(), Vec3::Zero());
  for (const auto& t : mesh.triangles) {
    // The cross product's length is twice the area: the sum is area-weighted.
    const Vec3 n = (mesh.points[t[1]] - mesh.points[t[0]]).cross(mesh.points[t[2]] - mesh.points[t[0]]);
    for (Index k : t) normals[k] += n;
  }
  for (Vec3& n : normals) {
    const float length = n.norm();
    n = length > 0.0f ? Vec3(n / length) : Vec3::Zero();
  }
  return normals;
}

std::vector<float> medialRadii(const TriangleMesh& surface, const Executor& executor) {
  const auto balls = inscribedBalls(surface.points, vertexNormals(surface), executor);
  std::vector<float> radii(balls.size());
  std::transform(balls.begin(), balls.end(), radii.begin(), [](const InscribedBall& b) { return b.radius; });
  return radii;
}

RadiusSummary summariseRadii(std::span<const float> radii) {
  RadiusSummary s;
  if (radii.empty()) return s;
  std::vector<float> sorted(radii.begin(), radii.end());
  std::sort(sorted.begin(), sorted.end());
  double sum = 0.0;
  for (float r : sorted) sum += r;
  const auto at = [&](double q) { return double(sorted[std::size_t(std::lround(q * double(sorted.size() - 1)))]); };
  s.mean = sum / double(sorted.size());
  s.p5 = at(0.05);
  s.median = at(0.5);
  s.p95 = at(0.95);
  s.max = sorted.back();
  return s;
}

MedialVoters votersOf(const MedialSurface& ms) {
  MedialVoters t;
  std::vector<Index> count(ms.vertices.size() + 1, 0);
  for (Index j : ms.medial) ++count[j + 1];
  for (std::size_t j = 1; j < count.size(); ++j) count[j] += count[j - 1];
  t.offsets = count;
  t.vertex.assign(ms.medial.size(), 0);
  t.weight.assign(ms.medial.size(), 0.0f);
  for (Index i = 0; i < ms.surfaceVertexCount(); ++i)
    for (Index k = ms.offsets[i]; k < ms.offsets[i + 1]; ++k) {
      const Index at = count[ms.medial[k]]++;
      t.vertex[at] = i;
      t.weight[at] = ms.weights[k];
    }
  return t;
}

Vec3 MedialSurface::foot(Index i, std::span<const Vec3> medialVertices) const {
  Vec3 f = Vec3::Zero();
  for (Index k = offsets[i]; k < offsets[i + 1]; ++k) f += weights[k] * medialVertices[medial[k]];
  return f;
}

namespace {
using Cell = std::array<int, 3>;
Cell cellOf(const Vec3& p, float spacing) {
  return {int(std::floor(p.x() / spacing)), int(std::floor(p.y() / spacing)), int(std::floor(p.z() / spacing))};
}
}  // namespace

MedialSurface buildMedialSurface(std::span<const Vec3> points, std::span<const Vec3> normals, const MedialOptions& options,
                                 const Executor& executor) {
  if (points.empty()) throw InputError("medial surface: the structure has no vertices");
  if (!(options.spacingMm > 0.0f) || options.neighbours < 1) throw InputError("medial surface: spacing and neighbours must be positive");
  const auto balls = inscribedBalls(points, normals, executor);

  // Medial vertices: the balls' centres clustered on the grid, in the grid's order (deterministic).
  const float h = options.spacingMm;
  std::map<Cell, std::pair<Vec3, int>> clusters;
  for (const auto& b : balls) {
    if (!(b.radius > 0.0f)) continue;  // no ball: no medial point
    auto [it, added] = clusters.try_emplace(cellOf(b.centre, h), Vec3::Zero(), 0);
    auto& c = it->second;
    c.first += b.centre;
    ++c.second;
  }
  MedialSurface m;
  for (const auto& [cell, c] : clusters) m.vertices.push_back(c.first / float(c.second));
  if (m.vertices.empty()) throw InputError("medial surface: no inscribed ball could be found (are the normals outward and finite?)");
  // Each surface vertex: the medial vertices nearest its ball's centre (its own point where it has
  // no ball), weighted by inverse squared distance.
  const Index n = Index(points.size());
  const std::size_t k = std::min<std::size_t>(std::size_t(options.neighbours), m.vertices.size());
  const PointCloud medialCloud{m.vertices};
  const PointTree medialTree(3, medialCloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  std::vector<std::vector<std::pair<float, Index>>> nearest(n);
  executor.forEach(n, [&](Index i) {
    std::vector<std::uint32_t> index(k);
    std::vector<float> distance2(k);
    const std::size_t found = medialTree.knnSearch(balls[i].centre.data(), k, index.data(), distance2.data());
    for (std::size_t q = 0; q < found; ++q) nearest[i].emplace_back(distance2[q], Index(index[q]));
  }, 64);
  for (Index i = 0; i < n; ++i) {
    float sum = 0.0f;
    const Index begin = Index(m.medial.size());
    for (const auto& [d2, j] : nearest[i]) {
      const float w = 1.0f / (d2 + 0.01f * h * h);
      m.medial.push_back(j);
      m.weights.push_back(w);
      sum += w;
    }
    for (Index q = begin; q < Index(m.weights.size()); ++q) m.weights[q] /= sum;
    m.offsets.push_back(Index(m.medial.size()));
  }

  // R_j: the weighted mean of the distances from the surface to its medial points.
  std::vector<double> radiusSum(m.vertices.size(), 0.0), weightSum(m.vertices.size(), 0.0);
  for (Index i = 0; i < n; ++i) {
    const float d = (points[i] - m.foot(i, m.vertices)).norm();
    for (Index q = m.offsets[i]; q < m.offsets[i + 1]; ++q) {
      radiusSum[m.medial[q]] += double(m.weights[q]) * d;
      weightSum[m.medial[q]] += double(m.weights[q]);
    }
  }
  m.radii.resize(m.vertices.size());
  for (std::size_t j = 0; j < m.radii.size(); ++j) m.radii[j] = weightSum[j] > 0.0 ? float(radiusSum[j] / weightSum[j]) : 0.0f;
  m.vertexRadius.resize(n);
  for (Index i = 0; i < n; ++i) {
    float r = 0.0f;
    for (Index q = m.offsets[i]; q < m.offsets[i + 1]; ++q) r += m.weights[q] * m.radii[m.medial[q]];
    m.vertexRadius[i] = r;
  }
  m.reconstructionErrorMm = reconstructionError(m, points, m.vertices);
  return m;
}

double reconstructionError(const MedialSurface& medial, std::span<const Vec3> positions, std::span<const Vec3> medialVertices) {
  const Index n = medial.surfaceVertexCount();
  if (n == 0) return 0.0;
  double sum = 0.0;
  for (Index i = 0; i < n; ++i)
    sum += std::abs(double(medial.vertexRadius[i]) - double((positions[i] - medial.foot(i, medialVertices)).norm()));
  return sum / double(n);
}

}  // namespace sinew
