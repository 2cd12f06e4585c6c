#include "collide/holes.h"

#include "collide/proximity.h"

// CGAL's 2D polygon code trips GCC 12's -Wmaybe-uninitialized from inside its own headers.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/utility.h>
#pragma GCC diagnostic pop

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>

namespace raycloth {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

uint32_t find_root(std::vector<uint32_t>& parent, uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

double triangle_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5 * double(length(cross(b - a, c - a)));
}

// Whether another piece of the mesh lies along the loop's rim: the median distance of its vertices
// to the nearest triangle of another piece is at most kHoleCoverFactor of the loop's mean radius.
bool rim_covered(const std::vector<Vec3>& vertices, const std::vector<uint32_t>& indices, std::vector<uint32_t>& parent,
                 uint32_t piece, const std::vector<uint32_t>& loop) {
  DVec3 centre{0, 0, 0};
  for (uint32_t v : loop) centre = centre + dvec(vertices[v]);
  centre = centre * (1.0 / double(loop.size()));
  double radius = 0;
  for (uint32_t v : loop) radius += sqrt(ddot(dvec(vertices[v]) - centre, dvec(vertices[v]) - centre));
  radius /= double(loop.size());
  const double reach = kHoleCoverFactor * radius;
  // Triangles of other pieces within reach of the loop's box.
  DVec3 lo = dvec(vertices[loop[0]]), hi = lo;
  for (uint32_t v : loop) {
    const DVec3 p = dvec(vertices[v]);
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  std::vector<size_t> near;
  for (size_t t = 0; t < indices.size() / 3; ++t) {
    if (find_root(parent, indices[3 * t]) == piece) continue;
    bool overlap = true;
    const double tl[3] = {lo.x - reach, lo.y - reach, lo.z - reach}, th[3] = {hi.x + reach, hi.y + reach, hi.z + reach};
    for (int axis = 0; axis < 3 && overlap; ++axis) {
      double mn = 1e300, mx = -1e300;
      for (int k = 0; k < 3; ++k) {
        const Vec3& q = vertices[indices[3 * t + k]];
        const double c = axis == 0 ? q.x : (axis == 1 ? q.y : q.z);
        mn = std::min(mn, c), mx = std::max(mx, c);
      }
      overlap = mx >= tl[axis] && mn <= th[axis];
    }
    if (overlap) near.push_back(t);
  }
  if (near.empty()) return false;
  std::vector<double> dist;
  dist.reserve(loop.size());
  for (uint32_t v : loop) {
    double best = 1e300;
    for (size_t t : near) {
      const TrianglePoint q = closest_on_triangle(dvec(vertices[v]), dvec(vertices[indices[3 * t]]),
                                                  dvec(vertices[indices[3 * t + 1]]), dvec(vertices[indices[3 * t + 2]]));
      best = std::min(best, q.dist2);
    }
    dist.push_back(sqrt(best));
  }
  std::nth_element(dist.begin(), dist.begin() + long(dist.size() / 2), dist.end());
  return dist[dist.size() / 2] <= reach;
}

}  // namespace

HoleCaps cap_holes(const std::vector<Vec3>& vertices, const std::vector<uint32_t>& indices, float max_share) {
  HoleCaps caps;
  const size_t nt = indices.size() / 3;
  // Directed edges of the faces; an undirected edge used once is on the boundary, and its direction
  // in its face is the loop's direction.
  std::map<std::pair<uint32_t, uint32_t>, int> uses;  // undirected edge -> count
  for (size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = indices[3 * t + k], b = indices[3 * t + (k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  std::multimap<uint32_t, uint32_t> next;  // boundary edge a -> b, as its face has it
  for (size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = indices[3 * t + k], b = indices[3 * t + (k + 1) % 3];
      if (a != b && uses[{std::min(a, b), std::max(a, b)}] == 1) next.emplace(a, b);
    }
  if (next.empty()) return caps;
  // Pieces (connected by shared vertices) and their areas.
  std::vector<uint32_t> parent(vertices.size());
  std::iota(parent.begin(), parent.end(), 0u);
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t r0 = find_root(parent, indices[3 * t]);
    for (int k = 1; k < 3; ++k) {
      const uint32_t r = find_root(parent, indices[3 * t + k]);
      if (r != r0) parent[r] = r0;
    }
  }
  std::vector<double> area(vertices.size(), 0.0);
  for (size_t t = 0; t < nt; ++t)
    area[find_root(parent, indices[3 * t])] +=
        triangle_area(vertices[indices[3 * t]], vertices[indices[3 * t + 1]], vertices[indices[3 * t + 2]]);
  // Follow the loops, each boundary edge once.
  const size_t boundary_edges = next.size();
  while (!next.empty()) {
    std::vector<uint32_t> loop;
    auto it = next.begin();
    const uint32_t start = it->first;
    uint32_t at = it->second;
    loop.push_back(start);
    next.erase(it);
    bool closed = false;
    while (loop.size() <= boundary_edges) {
      if (at == start) {
        closed = true;
        break;
      }
      loop.push_back(at);
      auto n = next.find(at);
      if (n == next.end()) break;
      at = n->second;
      next.erase(n);
    }
    if (!closed || loop.size() < 3) continue;
    ++caps.loops;
    // The loop's vector area against its piece's area.
    Vec3 sum = make_vec3(0, 0, 0);
    const Vec3 o = vertices[loop[0]];
    for (size_t k = 1; k + 1 < loop.size(); ++k) sum += cross(vertices[loop[k]] - o, vertices[loop[k + 1]] - o);
    const double spanned = 0.5 * double(length(sum));
    const uint32_t piece = find_root(parent, loop[0]);
    if (!(spanned < double(max_share) * area[piece])) continue;
    if (!(spanned < double(kHoleTinyShare) * area[piece]) && !rim_covered(vertices, indices, parent, piece, loop)) continue;
    std::vector<Kernel::Point_3> points;
    points.reserve(loop.size());
    for (uint32_t v : loop) points.emplace_back(vertices[v].x, vertices[v].y, vertices[v].z);
    std::vector<CGAL::Triple<int, int, int>> patch;
    CGAL::Polygon_mesh_processing::triangulate_hole_polyline(points, std::back_inserter(patch));
    if (patch.empty()) continue;
    // The mesh's faces run each boundary edge loop[k] -> loop[k + 1]; the cap must run it the other
    // way. CGAL orients the patch consistently, so one edge tells which way round it is.
    bool along = false, found = false;
    const int m = int(loop.size());
    for (const auto& f : patch) {
      const int c[3] = {f.first, f.second, f.third};
      for (int k = 0; k < 3 && !found; ++k) {
        const int a = c[k], b = c[(k + 1) % 3];
        if ((a + 1) % m == b) found = true, along = true;
        else if ((b + 1) % m == a) found = true, along = false;
      }
      if (found) break;
    }
    for (const auto& f : patch) {
      const uint32_t a = loop[size_t(f.first)], b = loop[size_t(f.second)], c = loop[size_t(f.third)];
      if (along) caps.indices.insert(caps.indices.end(), {a, c, b});
      else caps.indices.insert(caps.indices.end(), {a, b, c});
    }
    ++caps.capped;
  }
  return caps;
}

}  // namespace raycloth
