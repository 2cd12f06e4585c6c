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
//   for an open one (a body with holes) the generalized winding number >= 1/2, in double, summed
//   over a tree (check/winding.h).
// - Pinches: where the body itself brings two of its surfaces closer than twice the cloth's
//   thickness (a hand against a hip), no position of the cloth between them is outside both. A
//   vertex strictly inside an obstacle is *pinched* when the body's own gap at its way out is below
//   twice the thickness, else it is a failure. The gap is a float measure of the body alone (not an
//   exact predicate): from the nearest point q of the obstacle's surface, along the outward normal
//   n of the face holding q, the distance to the first obstacle face (of any obstacle) that the ray
//   enters from its front side (n . face normal < 0); faces it leaves from behind are layers of the
//   same body (clothes over skin) and are skipped. The ray starts 1 um behind q, so a surface
//   touching q counts with gap 0; no such face: the gap is infinite (a failure).
#pragma once
#include <array>
#include <cmath>
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
  double gap = HUGE_VAL;  // the body's own gap at the vertex's way out, metres (infinite: none measured)
};

// A cloth vertex strictly inside an obstacle, and its way out.
struct VertexInside {
  uint32_t vertex = 0;    // into the cloth's vertices
  uint32_t obstacle = 0;  // group of the obstacle mesh
  DPoint nearest{};       // the nearest point of the obstacle's surface
  DPoint normal{};        // unit outward normal of the face holding it (the obstacle's faces' winding,
                          // turned so that the obstacle as a whole winds outwards)
  double depth = 0;       // distance from the vertex to `nearest`
  double gap = HUGE_VAL;  // the body's own gap there (measure_body_gaps)
};

struct CheckReport {
  size_t edges = 0, triangles = 0;
  size_t pairs_tested = 0;      // edge-triangle pairs sharing no vertex whose boxes overlap
  size_t crossings = 0;         // of those, edges through triangles
  size_t vertices_tested = 0;   // cloth vertices (those used by a triangle) against obstacles
  // (vertex, obstacle) pairs with the vertex strictly inside: failures (vertices_inside) and, where
  // the body's own gap there is below twice the cloth thickness, pinches (vertices_pinched).
  size_t vertices_inside = 0;
  size_t vertices_pinched = 0;
  // Of vertices_inside, those in front of the body's face nearest to them, inside it all the same
  // (by the winding number): where the body's own surfaces pass through each other (an arm swung
  // into the torso) or its mesh is open. Told apart in the one-line summary; failures all the same.
  size_t vertices_inside_overlap = 0;
  double min_pinch_gap = HUGE_VAL;  // metres, the smallest body gap of a pinched vertex
  size_t closed_obstacles = 0, open_obstacles = 0;
  std::vector<CrossingRecord> first_crossings;  // at most kMaxRecords
  std::vector<InsideRecord> first_inside;
  std::vector<InsideRecord> first_pinched;
  static constexpr size_t kMaxRecords = 8;
  // A failure: a crossing or a vertex inside that no pinch explains.
  bool failed() const { return crossings > 0 || vertices_inside > 0; }
  // Only pinches: not clean, not a failure.
  bool pinched_only() const { return !failed() && vertices_pinched > 0; }
  bool clean() const { return !failed() && vertices_pinched == 0; }
};

// Edges of the cloth through cloth triangles.
void check_cloth_crossings(const CheckMesh& cloth, CheckReport& report);
// Cloth vertices (those a triangle uses) strictly inside each obstacle group of `obstacles`, in the
// order of the groups and then of the vertices, with their nearest surface points (gap not
// measured). `report` (optional) counts the closed and open obstacles and the vertices tested.
std::vector<VertexInside> find_vertices_inside(const CheckMesh& cloth, const CheckMesh& obstacles,
                                               CheckReport* report = nullptr);
// Fills each one's `gap`: the body's own gap at its way out (see the top of this file), against
// every obstacle of `obstacles`.
void measure_body_gaps(const CheckMesh& obstacles, std::vector<VertexInside>& inside);
// Cloth vertices strictly inside obstacles: pinched where the body gap is below 2 * thickness,
// failures otherwise. thickness 0: every vertex inside is a failure (no gap measured).
void check_vertices_inside(const CheckMesh& cloth, const CheckMesh& obstacles, CheckReport& report,
                           double thickness = 0);
// Both. `thickness`: the cloth's (scene collision.thickness), for telling pinches from failures.
CheckReport check_state(const CheckMesh& cloth, const CheckMesh& obstacles, double thickness = 0);

// One line: "0 crossings, 0 vertices inside" or the counts with the first offender named;
// pinches add ", N vertices pinched (body gap G mm)".
std::string describe(const CheckReport& r);

}  // namespace raycloth
