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

// Subdivided icosahedron projected onto a sphere: 20 * 4^level triangles.
TriangleMesh icosphere(int level, float radius = 1.0f, const Vec3& centre = Vec3::Zero());
// Subdivided octahedron and tetrahedron projected onto a sphere: 8 * 4^level and 4 * 4^level
// triangles; useful when a total vertex count must be met exactly.
TriangleMesh octasphere(int level, float radius = 1.0f, const Vec3& centre = Vec3::Zero());
TriangleMesh tetrasphere(int level, float radius = 1.0f, const Vec3& centre = Vec3::Zero());

// One 1-to-4 midpoint subdivision (new points are edge midpoints, not projected).
TriangleMesh subdivideMidpoint(const TriangleMesh& mesh);

}  // namespace sinew
