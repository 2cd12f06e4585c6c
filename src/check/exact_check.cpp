#include "check/exact_check.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/box_intersection_d.h>
#include <CGAL/boost/graph/helpers.h>
#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <mutex>

namespace raycloth {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;

Point point(const DPoint& p) { return Point(p[0], p[1], p[2]); }
Point point(const Vec3& p) { return Point(double(p.x), double(p.y), double(p.z)); }
DPoint dpoint(const Vec3& p) { return DPoint{double(p.x), double(p.y), double(p.z)}; }

EdgeTriangle classify(const Point& p, const Point& q, const Point& a, const Point& b, const Point& c) {
  const CGAL::Orientation sp = CGAL::orientation(a, b, c, p), sq = CGAL::orientation(a, b, c, q);
  if (sp == CGAL::COPLANAR || sq == CGAL::COPLANAR) {
    // In the plane, or an end on it (a degenerate triangle is coplanar with everything): at most
    // contact. Which of Contact / Apart it is matters only to callers that ask for it.
    if (CGAL::collinear(a, b, c)) return EdgeTriangle::Apart;
    return CGAL::do_intersect(K::Segment_3(p, q), K::Triangle_3(a, b, c)) ? EdgeTriangle::Contact
                                                                          : EdgeTriangle::Apart;
  }
  if (sp == sq) return EdgeTriangle::Apart;
  // pq crosses the plane at one point strictly between p and q: it is in the closed triangle when
  // the line pq passes on the same side of (or through) each of the three edges.
  const CGAL::Orientation o1 = CGAL::orientation(p, q, a, b), o2 = CGAL::orientation(p, q, b, c),
                          o3 = CGAL::orientation(p, q, c, a);
  const bool any_pos = o1 == CGAL::POSITIVE || o2 == CGAL::POSITIVE || o3 == CGAL::POSITIVE;
  const bool any_neg = o1 == CGAL::NEGATIVE || o2 == CGAL::NEGATIVE || o3 == CGAL::NEGATIVE;
  return any_pos && any_neg ? EdgeTriangle::Apart : EdgeTriangle::Crossing;
}

using Box = CGAL::Box_intersection_d::Box_with_info_d<double, 3, uint32_t, CGAL::Box_intersection_d::ID_EXPLICIT>;

double coord(const Vec3& p, int d) { return double(d == 0 ? p.x : (d == 1 ? p.y : p.z)); }

Box box_of(const Vec3* const* p, int n, uint32_t info) {
  double lo[3], hi[3];
  for (int d = 0; d < 3; ++d) lo[d] = hi[d] = coord(*p[0], d);
  for (int k = 1; k < n; ++k)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], coord(*p[k], d));
      hi[d] = std::max(hi[d], coord(*p[k], d));
    }
  return Box(lo, hi, info);
}

// The vertex indices of a group's triangles, [first, last).
std::pair<uint32_t, uint32_t> group_range(const CheckMesh& m, size_t g) {
  const uint32_t first = m.group_first_triangle.empty() ? 0u : m.group_first_triangle[g];
  const uint32_t last = g + 1 < m.group_first_triangle.size() ? m.group_first_triangle[g + 1]
                                                              : uint32_t(m.num_triangles());
  return {first, last};
}

// Generalized winding number of the triangles [first, last) of m around p (Jacobson et al. 2013):
// the summed signed solid angles over 4 pi, by Van Oosterom and Strackee's formula.
double winding_number(const CheckMesh& m, uint32_t first, uint32_t last, const DPoint& p) {
  double sum = 0;
  for (uint32_t t = first; t < last; ++t) {
    double v[3][3], len[3];
    for (int k = 0; k < 3; ++k) {
      const Vec3& q = m.vertices[m.triangles[3 * t + k]];
      for (int d = 0; d < 3; ++d) v[k][d] = coord(q, d) - p[d];
      len[k] = std::sqrt(v[k][0] * v[k][0] + v[k][1] * v[k][1] + v[k][2] * v[k][2]);
    }
    auto dot = [&](int i, int j) { return v[i][0] * v[j][0] + v[i][1] * v[j][1] + v[i][2] * v[j][2]; };
    const double det = v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1]) -
                       v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0]) +
                       v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]);
    const double den = len[0] * len[1] * len[2] + dot(0, 1) * len[2] + dot(1, 2) * len[0] + dot(2, 0) * len[1];
    sum += 2.0 * std::atan2(det, den);
  }
  return sum / (4.0 * M_PI);
}

}  // namespace

EdgeTriangle classify_edge_triangle(const DPoint& p, const DPoint& q, const DPoint& a, const DPoint& b,
                                    const DPoint& c) {
  return classify(point(p), point(q), point(a), point(b), point(c));
}

const std::string& CheckMesh::group_of(uint32_t t) const {
  static const std::string none;
  if (group_names.empty()) return none;
  const auto it = std::upper_bound(group_first_triangle.begin(), group_first_triangle.end(), t);
  const size_t g = it == group_first_triangle.begin() ? 0 : size_t(it - group_first_triangle.begin()) - 1;
  return group_names[g];
}

void check_cloth_crossings(const CheckMesh& cloth, CheckReport& report) {
  const uint32_t nt = uint32_t(cloth.num_triangles());
  const std::vector<uint32_t>& tri = cloth.triangles;
  const std::vector<Vec3>& x = cloth.vertices;

  // The edges, each once, with one triangle holding it (for naming its panel).
  std::vector<std::array<uint32_t, 3>> edges;
  edges.reserve(3 * size_t(nt));
  for (uint32_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = tri[3 * t + k], b = tri[3 * t + (k + 1) % 3];
      if (a != b) edges.push_back({std::min(a, b), std::max(a, b), t});
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end(),
                          [](const auto& e, const auto& f) { return e[0] == f[0] && e[1] == f[1]; }),
              edges.end());

  std::vector<Box> edge_boxes, tri_boxes;
  edge_boxes.reserve(edges.size());
  tri_boxes.reserve(nt);
  for (uint32_t e = 0; e < edges.size(); ++e) {
    const Vec3* p[2] = {&x[edges[e][0]], &x[edges[e][1]]};
    edge_boxes.push_back(box_of(p, 2, e));
  }
  for (uint32_t t = 0; t < nt; ++t) {
    const Vec3* p[3] = {&x[tri[3 * t]], &x[tri[3 * t + 1]], &x[tri[3 * t + 2]]};
    tri_boxes.push_back(box_of(p, 3, t));
  }

  size_t tested = 0, crossings = 0;
  auto callback = [&](const Box& eb, const Box& tb) {
    const auto& e = edges[eb.info()];
    const uint32_t t = tb.info();
    const uint32_t a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2];
    if (e[0] == a || e[0] == b || e[0] == c || e[1] == a || e[1] == b || e[1] == c) return;
    ++tested;
    if (classify(point(x[e[0]]), point(x[e[1]]), point(x[a]), point(x[b]), point(x[c])) != EdgeTriangle::Crossing)
      return;
    ++crossings;
    if (report.first_crossings.size() < CheckReport::kMaxRecords)
      report.first_crossings.push_back({e[0], e[1], t, cloth.group_of(e[2]), cloth.group_of(t)});
  };
  // Closed boxes: an edge whose box only touches a triangle's box is still tested.
  CGAL::box_intersection_d(edge_boxes.begin(), edge_boxes.end(), tri_boxes.begin(), tri_boxes.end(), callback);
  report.edges += edges.size();
  report.triangles += nt;
  report.pairs_tested += tested;
  report.crossings += crossings;
}

void check_vertices_inside(const CheckMesh& cloth, const CheckMesh& obstacles, CheckReport& report) {
  std::vector<uint32_t> used;
  {
    std::vector<char> flag(cloth.vertices.size(), 0);
    for (uint32_t i : cloth.triangles) flag[i] = 1;
    for (uint32_t i = 0; i < flag.size(); ++i)
      if (flag[i]) used.push_back(i);
  }
  report.vertices_tested += used.size();
  const size_t groups = std::max<size_t>(1, obstacles.group_first_triangle.size());
  for (size_t g = 0; g < groups; ++g) {
    const auto [first, last] = group_range(obstacles, g);
    if (first >= last) continue;
    const std::string name = obstacles.group_names.empty() ? std::string("obstacle") : obstacles.group_names[g];

    // The group as a polygon soup with duplicate points merged (generated boxes repeat corners).
    std::vector<Point> points;
    std::vector<std::array<size_t, 3>> faces;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (uint32_t t = first; t < last; ++t) {
      std::array<size_t, 3> f;
      for (int k = 0; k < 3; ++k) {
        const Vec3& q = obstacles.vertices[obstacles.triangles[3 * t + k]];
        f[k] = points.size();
        points.push_back(point(q));
        for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], coord(q, d)), hi[d] = std::max(hi[d], coord(q, d));
      }
      faces.push_back(f);
    }
    CGAL::Polygon_mesh_processing::merge_duplicate_points_in_polygon_soup(points, faces);
    CGAL::Surface_mesh<Point> mesh;
    bool closed = false;
    if (CGAL::Polygon_mesh_processing::is_polygon_soup_a_polygon_mesh(faces)) {
      CGAL::Polygon_mesh_processing::polygon_soup_to_polygon_mesh(points, faces, mesh);
      closed = CGAL::is_closed(mesh) && CGAL::is_triangle_mesh(mesh);
    }
    auto in_box = [&](const DPoint& p) {
      return p[0] > lo[0] && p[0] < hi[0] && p[1] > lo[1] && p[1] < hi[1] && p[2] > lo[2] && p[2] < hi[2];
    };
    std::vector<char> inside(used.size(), 0);
    if (closed) {
      ++report.closed_obstacles;
      const CGAL::Side_of_triangle_mesh<CGAL::Surface_mesh<Point>, K> side(mesh);
      for (size_t k = 0; k < used.size(); ++k) {
        const DPoint p = dpoint(cloth.vertices[used[k]]);
        inside[k] = in_box(p) && side(point(p)) == CGAL::ON_BOUNDED_SIDE;
      }
    } else {
      ++report.open_obstacles;
      tbb::parallel_for(size_t(0), used.size(), [&](size_t k) {
        const DPoint p = dpoint(cloth.vertices[used[k]]);
        inside[k] = in_box(p) && std::abs(winding_number(obstacles, first, last, p)) >= 0.5;
      });
    }
    for (size_t k = 0; k < used.size(); ++k) {
      if (!inside[k]) continue;
      ++report.vertices_inside;
      if (report.first_inside.size() < CheckReport::kMaxRecords) report.first_inside.push_back({used[k], name});
    }
  }
}

CheckReport check_state(const CheckMesh& cloth, const CheckMesh& obstacles) {
  CheckReport r;
  check_cloth_crossings(cloth, r);
  if (obstacles.num_triangles() > 0) check_vertices_inside(cloth, obstacles, r);
  return r;
}

std::string describe(const CheckReport& r) {
  std::string s = fmt::format("{} crossings, {} vertices inside", r.crossings, r.vertices_inside);
  if (!r.first_crossings.empty()) {
    const CrossingRecord& c = r.first_crossings.front();
    s += fmt::format("; first: edge {}-{} of '{}' through triangle {} of '{}'", c.edge_a, c.edge_b, c.edge_group,
                     c.triangle, c.triangle_group);
  }
  if (!r.first_inside.empty())
    s += fmt::format("; first: vertex {} inside '{}'", r.first_inside.front().vertex, r.first_inside.front().obstacle);
  return s;
}

}  // namespace raycloth
