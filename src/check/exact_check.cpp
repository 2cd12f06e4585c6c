#include "check/exact_check.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
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
#include <memory>
#include <mutex>

#include "check/winding.h"

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

namespace {

using Triangle = K::Triangle_3;
using TriangleIt = std::vector<Triangle>::const_iterator;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, CGAL::AABB_triangle_primitive<K, TriangleIt>>>;

DPoint sub(const DPoint& a, const DPoint& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const DPoint& a, const DPoint& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
DPoint cross(const DPoint& a, const DPoint& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
DPoint dpoint(const Point& p) { return DPoint{p.x(), p.y(), p.z()}; }

// The obstacles' faces for distance and ray queries: the non-degenerate triangles, each with its
// unit normal turned so that its obstacle as a whole winds outwards (the sign of the obstacle's
// signed volume about its box's centre; for an open body, its dominant winding), and the range of
// each group in them.
struct Surfaces {
  std::vector<Triangle> triangles;
  std::vector<DPoint> normals;
  std::vector<std::pair<size_t, size_t>> group_triangles;  // per group, into triangles: [first, last)
  explicit Surfaces(const CheckMesh& m) {
    const size_t groups = std::max<size_t>(1, m.group_first_triangle.size());
    for (size_t g = 0; g < groups; ++g) {
      const auto [first, last] = group_range(m, g);
      double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
      for (uint32_t t = first; t < last; ++t)
        for (int k = 0; k < 3; ++k)
          for (int d = 0; d < 3; ++d) {
            const double c = coord(m.vertices[m.triangles[3 * t + k]], d);
            lo[d] = std::min(lo[d], c), hi[d] = std::max(hi[d], c);
          }
      const DPoint o{0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
      double volume = 0;
      const size_t begin = triangles.size();
      for (uint32_t t = first; t < last; ++t) {
        DPoint v[3];
        for (int k = 0; k < 3; ++k) v[k] = dpoint(m.vertices[m.triangles[3 * t + k]]);
        volume += dot(sub(v[0], o), cross(sub(v[1], o), sub(v[2], o)));
        const Point a = point(v[0]), b = point(v[1]), c = point(v[2]);
        if (CGAL::collinear(a, b, c)) continue;
        DPoint n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
        const double len = std::sqrt(dot(n, n));
        if (len > 0) n = {n[0] / len, n[1] / len, n[2] / len};
        triangles.emplace_back(a, b, c);
        normals.push_back(n);
      }
      if (volume < 0)
        for (size_t t = begin; t < triangles.size(); ++t) normals[t] = {-normals[t][0], -normals[t][1], -normals[t][2]};
      group_triangles.push_back({begin, triangles.size()});
    }
  }
};

// A tree over triangles [first, last) of s, ready for queries from several threads.
std::unique_ptr<Tree> make_tree(const Surfaces& s, size_t first, size_t last) {
  auto tree = std::make_unique<Tree>(s.triangles.begin() + long(first), s.triangles.begin() + long(last));
  tree->build();
  tree->accelerate_distance_queries();
  return tree;
}

}  // namespace

std::vector<VertexInside> find_vertices_inside(const CheckMesh& cloth, const CheckMesh& obstacles, CheckReport* report) {
  std::vector<VertexInside> found;
  std::vector<uint32_t> used;
  {
    std::vector<char> flag(cloth.vertices.size(), 0);
    for (uint32_t i : cloth.triangles) flag[i] = 1;
    for (uint32_t i = 0; i < flag.size(); ++i)
      if (flag[i]) used.push_back(i);
  }
  if (report) report->vertices_tested += used.size();
  if (obstacles.num_triangles() == 0) return found;
  std::unique_ptr<Surfaces> surfaces;  // built when a vertex is inside
  const size_t groups = std::max<size_t>(1, obstacles.group_first_triangle.size());
  for (size_t g = 0; g < groups; ++g) {
    const auto [first, last] = group_range(obstacles, g);
    if (first >= last) continue;

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
      if (report) ++report->closed_obstacles;
      const CGAL::Side_of_triangle_mesh<CGAL::Surface_mesh<Point>, K> side(mesh);
      for (size_t k = 0; k < used.size(); ++k) {
        const DPoint p = dpoint(cloth.vertices[used[k]]);
        inside[k] = in_box(p) && side(point(p)) == CGAL::ON_BOUNDED_SIDE;
      }
    } else {
      if (report) ++report->open_obstacles;
      const WindingTree winding(obstacles.vertices, obstacles.triangles, first, last);
      tbb::parallel_for(size_t(0), used.size(), [&](size_t k) {
        const DPoint p = dpoint(cloth.vertices[used[k]]);
        inside[k] = in_box(p) && std::abs(winding(p)) >= 0.5;
      });
    }
    const size_t begin = found.size();
    for (size_t k = 0; k < used.size(); ++k)
      if (inside[k]) found.push_back({used[k], uint32_t(g)});
    if (found.size() == begin) continue;

    // The way out of each: the nearest point of the group's surface, and its face's normal.
    if (!surfaces) surfaces = std::make_unique<Surfaces>(obstacles);
    const auto [tri_first, tri_last] = surfaces->group_triangles[g];
    if (tri_first == tri_last) continue;  // only degenerate faces: no way out to name
    const std::unique_ptr<Tree> tree = make_tree(*surfaces, tri_first, tri_last);
    tbb::parallel_for(begin, found.size(), [&](size_t k) {
      VertexInside& v = found[k];
      const DPoint p = dpoint(cloth.vertices[v.vertex]);
      const auto [q, id] = tree->closest_point_and_primitive(point(p));
      v.nearest = dpoint(q);
      v.normal = surfaces->normals[size_t(id - surfaces->triangles.begin())];
      v.depth = std::sqrt(dot(sub(v.nearest, p), sub(v.nearest, p)));
    });
  }
  return found;
}

void measure_body_gaps(const CheckMesh& obstacles, std::vector<VertexInside>& inside) {
  if (inside.empty()) return;
  const Surfaces surfaces(obstacles);
  if (surfaces.triangles.empty()) return;
  const std::unique_ptr<Tree> tree = make_tree(surfaces, 0, surfaces.triangles.size());
  constexpr double kHair = 1e-6;  // metres: the ray starts this far behind q, inside its own face
  tbb::parallel_for(size_t(0), inside.size(), [&](size_t k) {
    VertexInside& v = inside[k];
    const DPoint& n = v.normal;
    v.gap = HUGE_VAL;
    if (!(dot(n, n) > 0)) return;
    const Point origin(v.nearest[0] - kHair * n[0], v.nearest[1] - kHair * n[1], v.nearest[2] - kHair * n[2]);
    const K::Ray_3 ray(origin, K::Vector_3(n[0], n[1], n[2]));
    // Faces the ray leaves from behind (or runs along) are skipped: q's own face, and outer layers.
    const auto skip = [&](TriangleIt t) { return !(dot(n, surfaces.normals[size_t(t - surfaces.triangles.begin())]) < 0); };
    const auto hit = tree->first_intersection(ray, skip);
    if (!hit) return;
    double t = HUGE_VAL;
    if (const Point* at = boost::get<Point>(&hit->first)) {
      t = std::sqrt(CGAL::squared_distance(origin, *at));
    } else if (const K::Segment_3* seg = boost::get<K::Segment_3>(&hit->first)) {
      t = std::sqrt(std::min(CGAL::squared_distance(origin, seg->source()), CGAL::squared_distance(origin, seg->target())));
    }
    v.gap = std::max(0.0, t - kHair);
  });
}

void check_vertices_inside(const CheckMesh& cloth, const CheckMesh& obstacles, CheckReport& report, double thickness) {
  std::vector<VertexInside> inside = find_vertices_inside(cloth, obstacles, &report);
  if (thickness > 0) measure_body_gaps(obstacles, inside);
  for (const VertexInside& v : inside) {
    const std::string name =
        obstacles.group_names.empty() ? std::string("obstacle") : obstacles.group_names[v.obstacle];
    if (v.gap < 2 * thickness) {
      ++report.vertices_pinched;
      report.min_pinch_gap = std::min(report.min_pinch_gap, v.gap);
      if (report.first_pinched.size() < CheckReport::kMaxRecords) report.first_pinched.push_back({v.vertex, name, v.gap});
    } else {
      ++report.vertices_inside;
      const DPoint p = dpoint(cloth.vertices[v.vertex]);
      if (dot(sub(p, v.nearest), v.normal) > 0) ++report.vertices_inside_overlap;
      if (report.first_inside.size() < CheckReport::kMaxRecords) report.first_inside.push_back({v.vertex, name, v.gap});
    }
  }
}

CheckReport check_state(const CheckMesh& cloth, const CheckMesh& obstacles, double thickness) {
  CheckReport r;
  check_cloth_crossings(cloth, r);
  if (obstacles.num_triangles() > 0) check_vertices_inside(cloth, obstacles, r, thickness);
  return r;
}

std::string describe(const CheckReport& r) {
  std::string s = fmt::format("{} crossings, {} vertices inside", r.crossings, r.vertices_inside);
  if (r.vertices_inside_overlap > 0)
    s += fmt::format(" ({} in front of the body's nearest face: its surfaces overlap there)", r.vertices_inside_overlap);
  if (r.vertices_pinched > 0)
    s += fmt::format(", {} vertices pinched (body gap {:.3g} mm)", r.vertices_pinched, 1e3 * r.min_pinch_gap);
  if (!r.first_crossings.empty()) {
    const CrossingRecord& c = r.first_crossings.front();
    s += fmt::format("; first: edge {}-{} of '{}' through triangle {} of '{}'", c.edge_a, c.edge_b, c.edge_group,
                     c.triangle, c.triangle_group);
  }
  if (!r.first_inside.empty())
    s += fmt::format("; first: vertex {} inside '{}'", r.first_inside.front().vertex, r.first_inside.front().obstacle);
  if (!r.first_pinched.empty())
    s += fmt::format("; first pinched: vertex {} inside '{}' (body gap {:.3g} mm)", r.first_pinched.front().vertex,
                     r.first_pinched.front().obstacle, 1e3 * r.first_pinched.front().gap);
  return s;
}

}  // namespace raycloth
