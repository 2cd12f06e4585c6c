// Generalized winding numbers of an open triangle surface (a body with holes): what the exact check
// asks of every cloth vertex against an obstacle that is not closed (check/exact_check.h).
//
// The winding number of triangles S around p is the sum of their signed solid angles at p over
// 4 pi (Jacobson, Kavan and Sorkine-Hornung, "Robust inside-outside segmentation using generalized
// winding numbers", TOG 32(4), 2013). Summed triangle by triangle it costs a cosine and an atan2 per
// triangle per point: a frame of a dress on the walking man (2,483 vertices, 6,174 faces) took
// 15 million. WindingTree sums it over a tree of the triangles with the same paper's exact
// shortcut: where p lies outside a node's box, the node's triangles S and the cone C from the
// box's centre over S's boundary (the edges S uses an unequal number of times each way) together
// form a closed surface inside the box, which does not wind around p; so S's winding number at p is
// C's, a solid angle per boundary edge instead of one per triangle. Nothing is approximated: the
// two sums differ only in float rounding.
//
// No library of Debian 12 gives this: CGAL's Side_of_triangle_mesh (used for closed obstacles)
// needs a closed mesh, and libigl's tree is not packaged.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "raycloth/vec3.h"

namespace raycloth {

using WPoint = std::array<double, 3>;

// The signed solid angle of triangle abc seen from p (Van Oosterom and Strackee's formula), in
// steradians, in (-2 pi, 2 pi]: summed over a closed surface whose faces turn counter-clockwise seen
// from outside, 4 pi where p is inside and 0 where it is outside.
double solid_angle(const WPoint& p, const WPoint& a, const WPoint& b, const WPoint& c);

// The winding number of triangles [first, last) of (vertices, triangles: 3 indices each) around
// p, triangle by triangle: what WindingTree must give, up to rounding (its tests compare them).
double winding_number_direct(const std::vector<Vec3>& vertices, const std::vector<uint32_t>& triangles, uint32_t first,
                             uint32_t last, const WPoint& p);

class WindingTree {
 public:
  // Triangles [first, last) of (vertices, triangles). Vertices at the same position count as one
  // (a body's mesh repeats them along its texture seams) when the boundaries are found.
  WindingTree(const std::vector<Vec3>& vertices, const std::vector<uint32_t>& triangles, uint32_t first, uint32_t last);

  // The winding number around p.
  double operator()(const WPoint& p) const;

  // How many solid angles the winding number around p sums (the work saved: the tests count it).
  size_t terms(const WPoint& p) const;

 private:
  struct Node {
    WPoint lo{}, hi{}, centre{};
    uint32_t tri_begin = 0, tri_end = 0;    // into tris_
    uint32_t edge_begin = 0, edge_end = 0;  // into edges_: the boundary, each edge directed as S uses it
    uint32_t child = 0;                     // first of two children (the second is child + 1); 0: a leaf
    bool closure = false;                   // the boundary is shorter than the triangle list
  };
  template <class F>
  void visit(const WPoint& p, F&& f) const;

  std::vector<Node> nodes_;
  std::vector<std::array<WPoint, 3>> tris_;
  std::vector<WPoint> points_;                    // positions of the merged ids
  std::vector<std::array<uint32_t, 2>> edges_;
};

}  // namespace raycloth
