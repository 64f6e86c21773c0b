// Medial-axis approximations (paper 001 sections 2.3 and 4): the inscribed ball at each point of a
// closed surface (its medial radius: the local thickness), and the medial surface of a structure's
// reference shape with the weights and radii the radial force rebuilds the shape from
// (docs/medial.md).
#pragma once

#include "sinew/core/executor.h"
#include "sinew/core/triangle_mesh.h"

#include <span>
#include <vector>

namespace sinew {

struct InscribedBall {
  Vec3 centre = Vec3::Zero();
  float radius = 0.0f;
};

// Per sample of a closed surface (its vertices, dense enough that no ball passes between them),
// with its outward unit normal: the largest ball inside that touches the sample, by shrinking (Ma,
// Bai and Wu 2012): a ball on the inward normal as large as the samples' extent shrinks to the ball
// through the sample and the nearest other sample to its centre until no sample lies inside (by
// more than 2 % of the radius: normals of polygonal surfaces are slightly tilted). The
// centres lie on the medial axis. Each sample then takes the largest of these balls that touches
// it (the local thickness of Hildebrand and Ruegsegger over this set of balls), so that a sample
// whose normal is tilted (where a coarse mesh had a vertex of high valence) still gets its
// shape's thickness. Samples, not triangles: a polygon's facets leave every vertex's tangent ball
// (their kink at the vertex would shrink any ball to nothing).
std::vector<InscribedBall> inscribedBalls(std::span<const Vec3> samples, std::span<const Vec3> outwardNormals,
                                          const Executor& executor = Executor());

// Outward unit normals at the points of a closed, outward-oriented triangle mesh (area-weighted).
std::vector<Vec3> vertexNormals(const TriangleMesh& mesh);

// The medial radius at every point of a closed surface (the radius of its inscribed ball), mm: the
// per-vertex thickness written on output meshes (twice it is the local diameter).
std::vector<float> medialRadii(const TriangleMesh& surface, const Executor& executor = Executor());

// Area-free percentiles of a structure's medial radii, for the report.
struct RadiusSummary {
  double mean = 0.0, p5 = 0.0, median = 0.0, p95 = 0.0, max = 0.0;
};
RadiusSummary summariseRadii(std::span<const float> radii);

struct MedialOptions {
  float spacingMm = 2.0f;  // the medial surface's resolution: one medial vertex per cube of this edge
  int neighbours = 4;      // medial vertices each surface vertex is interpolated from
  bool operator==(const MedialOptions&) const = default;
};

// A structure's medial surface (paper 001 section 2.3): medial vertices Q_j with radii R_j, and for
// each surface vertex i the weights w_ij (summing to 1) of its medial point P_i_perp = sum w_ij Q_j
// and of its radius r_i = sum w_ij R_j. Built from a reference state: the inscribed balls' centres
// are clustered on a grid of spacingMm (Q_j: each cluster's mean), each vertex takes the clusters
// nearest its ball's centre by inverse squared distance, and R_j is the weighted mean of |P_i P_i_perp|.
struct MedialSurface {
  std::vector<Vec3> vertices;  // Q_j
  std::vector<float> radii;    // R_j
  // Per surface vertex i: its medial vertices and weights in [offsets[i], offsets[i + 1]).
  std::vector<Index> offsets{0}, medial;
  std::vector<float> weights;
  std::vector<float> vertexRadius;  // r_i
  // mean |r_i - |P_i P_i_perp|| over the surface vertices in the reference state (paper: 0.6 mm).
  double reconstructionErrorMm = 0.0;

  Index surfaceVertexCount() const { return Index(offsets.size()) - 1; }
  Vec3 foot(Index i, std::span<const Vec3> medialVertices) const;  // P_i_perp
};

// The inverse of a medial surface's weights: per medial vertex j, the surface vertices interpolated
// from it and their weights w_ij in [offsets[j], offsets[j + 1]), in surface-vertex order (so sums
// over them are deterministic). What the reaction on the medial vertices gathers.
struct MedialVoters {
  std::vector<Index> offsets{0}, vertex;
  std::vector<float> weight;
};
MedialVoters votersOf(const MedialSurface& medial);

// `points` are one structure's vertices (the samples of its closed surface), `normals` their
// outward unit normals. Throws InputError for an empty structure or bad options.
MedialSurface buildMedialSurface(std::span<const Vec3> points, std::span<const Vec3> normals,
                                 const MedialOptions& options, const Executor& executor = Executor());

// mean |r_i - |x_i P_i_perp|| for the surface in `positions` against medial vertices `medialVertices`.
double reconstructionError(const MedialSurface& medial, std::span<const Vec3> positions,
                           std::span<const Vec3> medialVertices);

}  // namespace sinew
