// Sewing-pattern pieces: a closed outline in metres (straight segments, sampled quadratic and cubic
// Bezier curves and circular arcs) triangulated to a target edge length by CGAL's 2D Delaunay mesher.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "raycloth/scene.h"

namespace raycloth {

struct PatternMesh {
  std::vector<std::array<double, 2>> points;      // the pattern's plane, metres
  std::vector<uint32_t> triangles;                // 3 per triangle, counter-clockwise in the plane
  // Per outline segment, its vertices in the outline's order, both ends included (the end is the
  // next segment's first vertex). A segment shorter than a fifth of the edge length is merged into
  // a point with the corners it joins: its path is that one vertex.
  std::vector<std::vector<uint32_t>> segments;
};

// The outline sampled into points: per segment, its points from `from` up to (not including) the
// next segment's `from`, spaced at most `edge_length` apart along straight lines and curves.
std::vector<std::vector<std::array<double, 2>>> sample_outline(const PatternDef& pattern);

// The whole outline as a fine closed polygon (each curve as 256 pieces), the last point not repeated.
std::vector<std::array<double, 2>> fine_outline(const PatternDef& pattern);

// Whether that polygon is simple (CGAL's Polygon_2::is_simple: no crossing, no touching).
bool outline_is_simple(const PatternDef& pattern);

// Checks the outline (at least 3 segments, finite points, distinct segment names, a simple polygon
// without crossings, a vertex count that fits) and meshes it. fail(field, reason) must throw; field
// is relative to the pattern ("outline/2/from", "edge_length", ...).
PatternMesh mesh_pattern(const PatternDef& pattern,
                         const std::function<void(const std::string&, const std::string&)>& fail);

}  // namespace raycloth
