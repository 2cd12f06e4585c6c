// Holes of an obstacle mesh, and the caps that close them for the step.
//
// A body made of open shells (a character whose arms, shirt and trousers are separate pieces, each
// with openings) has no inside that a nearest-face test can read near its openings: a cloth vertex
// can slip into an arm through the opening at the shoulder while the face nearest to it says it is
// outside. The exact check counts such a vertex inside (winding number >= 1/2). The step therefore
// sees each obstacle with its openings capped: every boundary loop whose spanning area is small
// against its piece (an opening, not the edge of a sheet) is triangulated (CGAL's hole filling on
// the loop's polyline, no new vertices), and the cap moves with the loop's own vertices, skinned or
// rigid. The caps are for the step alone: outputs and the exact check see the body as it is.
#pragma once
#include <cstdint>
#include <vector>

#include "raycloth/vec3.h"

namespace raycloth {

struct HoleCaps {
  std::vector<uint32_t> indices;  // 3 per cap triangle, into the mesh's vertices, oriented like the mesh
  uint32_t loops = 0;             // boundary loops found
  uint32_t capped = 0;            // of those, capped
};

// Boundary loops of (vertices, indices) get a cap when they are openings of a closed-looking piece
// that something closes: the loop's area (the length of its vector area) is below `max_share` of
// the area of the connected piece that holds it (not the edge of a sheet or a bowl), and either
// another piece of the mesh lies along its rim (an arm in a sleeve, a shirt over trousers: the
// median distance of its vertices to another piece at most kHoleCoverFactor of its mean radius) or
// it is tiny against its piece (below kHoleTinyShare: a mouth, a nostril). An open cup, a basket
// or a tube on their own keep their openings. Triangles that share an
// edge with more than one other (non-manifold edges) end no loop; loops that cannot be followed
// (a boundary vertex with several ways on) are followed edge by edge and capped all the same.
HoleCaps cap_holes(const std::vector<Vec3>& vertices, const std::vector<uint32_t>& indices, float max_share);

// The share cap_holes is called with for obstacles: a sheet's boundary spans all of its area (1), a
// hemisphere's half (0.5); an opening of a body part much less.
inline constexpr float kHoleMaxShare = 0.25f;
inline constexpr float kHoleTinyShare = 0.02f;
inline constexpr double kHoleCoverFactor = 0.5;

}  // namespace raycloth
