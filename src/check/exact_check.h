// The exact penetration check: what run.json's "check" and `raycloth check DIR` report, and what
// the tests assert on every frame.
//
// - Cloth self-crossing: every edge of the cloth surface against every cloth triangle that shares
//   no vertex with it (seams welded, so triangles on either side of a seam share the seam
//   vertices). Candidates come from CGAL's box_intersection_d; the yes/no is decided by CGAL's
//   filtered exact orientation predicates on the stored float coordinates, so degenerate cases are
//   classified correctly: an edge through a triangle's interior, edge or corner is a crossing; an
//   edge touching the triangle's plane or lying in it is contact.
// - Cloth vertices inside obstacles: for a closed obstacle (every edge on two faces once duplicate
//   points are merged) CGAL's Side_of_triangle_mesh, exact, on the boundary counting as contact;
//   for an open one (a body with holes) the generalized winding number >= 1/2, in double.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "raycloth/vec3.h"

namespace raycloth {

enum class EdgeTriangle { Apart, Contact, Crossing };

using DPoint = std::array<double, 3>;

// Segment pq against the closed triangle abc (exact).
EdgeTriangle classify_edge_triangle(const DPoint& p, const DPoint& q, const DPoint& a, const DPoint& b,
                                    const DPoint& c);

// A triangle mesh with named groups of triangles (panels of a cloth, obstacles of a scene).
struct CheckMesh {
  std::vector<Vec3> vertices;
  std::vector<uint32_t> triangles;           // 3 per triangle
  std::vector<std::string> group_names;      // empty: one unnamed group
  std::vector<uint32_t> group_first_triangle;  // per group, ascending
  size_t num_triangles() const { return triangles.size() / 3; }
  // The group holding triangle t ("" when there are no groups).
  const std::string& group_of(uint32_t t) const;
};

struct CrossingRecord {
  uint32_t edge_a = 0, edge_b = 0;  // vertices of the crossing edge
  uint32_t triangle = 0;            // the triangle it passes through
  std::string edge_group, triangle_group;
};

struct InsideRecord {
  uint32_t vertex = 0;
  std::string obstacle;
};

struct CheckReport {
  size_t edges = 0, triangles = 0;
  size_t pairs_tested = 0;      // edge-triangle pairs sharing no vertex whose boxes overlap
  size_t crossings = 0;         // of those, edges through triangles
  size_t vertices_tested = 0;   // cloth vertices (those used by a triangle) against obstacles
  size_t vertices_inside = 0;   // (vertex, obstacle) pairs with the vertex strictly inside
  size_t closed_obstacles = 0, open_obstacles = 0;
  std::vector<CrossingRecord> first_crossings;  // at most kMaxRecords
  std::vector<InsideRecord> first_inside;
  static constexpr size_t kMaxRecords = 8;
  bool clean() const { return crossings == 0 && vertices_inside == 0; }
};

// Edges of the cloth through cloth triangles.
void check_cloth_crossings(const CheckMesh& cloth, CheckReport& report);
// Cloth vertices (those a triangle uses) strictly inside each obstacle group of `obstacles`.
void check_vertices_inside(const CheckMesh& cloth, const CheckMesh& obstacles, CheckReport& report);
// Both.
CheckReport check_state(const CheckMesh& cloth, const CheckMesh& obstacles);

// One line: "0 crossings, 0 vertices inside" or the counts with the first offender named.
std::string describe(const CheckReport& r);

}  // namespace raycloth
