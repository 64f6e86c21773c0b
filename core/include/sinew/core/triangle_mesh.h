// Closed triangle meshes: the input from which simplex meshes are built (their dual), and the
// output of tessellation for export and drawing.
#pragma once

#include "sinew/core/types.h"

#include <array>
#include <string>
#include <vector>

namespace sinew {

// A named value per point (e.g. "medial_radius_mm"), written as point data where the format has it.
struct PointArray {
  std::string name;
  std::vector<float> values;  // one per point
};

struct TriangleMesh {
  std::vector<Vec3> points;
  std::vector<std::array<Index, 3>> triangles;
  std::vector<PointArray> pointData;  // optional; readers leave it empty

  // Signed volume (positive for an outward-oriented closed mesh).
  double volume() const;
  double area() const;
};

// Throws InputError naming the first problem found when the mesh is not closed, manifold and
// consistently oriented: an open edge, an edge shared by more than two triangles, an edge used
// twice in the same direction, a vertex whose triangles form more than one fan, an unused vertex,
// a degenerate triangle or an out-of-range index.
void validateClosedManifold(const TriangleMesh& mesh);

// Flips edges of a closed triangle mesh, in passes over its triangles, to lower the valences of
// highValence and above: a flip must bring the four vertices' valences closer to 6 (their squared
// differences from 6 summed), raise no vertex to highValence, leave none below minValence, and keep
// the surface's shape (the two triangles within maxFoldDegrees of coplanar, and the two new ones
// likewise). Points do not move; the mesh stays closed, manifold and consistently oriented.
// Returns the number of flips. Model building applies it to a label's decimated surface before
// taking its dual: a vertex of valence n becomes a cell of n vertices, and at the finest level a
// cell of 8 or more is 2-2.8 mm across among hexagons of 1 mm, so its flat middle sags into a
// neighbouring structure where no vertex is to be pushed back (docs/collisions.md).
int lowerHighValences(TriangleMesh& mesh, int highValence = 8, int minValence = 4, float maxFoldDegrees = 30.0f,
                      int maxPasses = 20);

// Subdivided icosahedron projected onto a sphere: 20 * 4^level triangles.
TriangleMesh icosphere(int level, float radius = 1.0f, const Vec3& centre = Vec3::Zero());
// Subdivided octahedron and tetrahedron projected onto a sphere: 8 * 4^level and 4 * 4^level
// triangles; useful when a total vertex count must be met exactly.
TriangleMesh octasphere(int level, float radius = 1.0f, const Vec3& centre = Vec3::Zero());
TriangleMesh tetrasphere(int level, float radius = 1.0f, const Vec3& centre = Vec3::Zero());

// One 1-to-4 midpoint subdivision (new points are edge midpoints, not projected).
TriangleMesh subdivideMidpoint(const TriangleMesh& mesh);

}  // namespace sinew
