#include "sim/body_reach.h"

#include <CGAL/Fuzzy_sphere.h>
#include <CGAL/Kd_tree.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/Search_traits_adapter.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/property_map.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <numeric>
#include <tuple>

#include "sim/model.h"

namespace raycloth {

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
// The cloth's vertices by index, searched by position (CGAL's kd-tree).
using Indexed = std::tuple<Point, uint32_t>;
using Traits = CGAL::Search_traits_adapter<Indexed, CGAL::Nth_of_tuple_property_map<0, Indexed>, CGAL::Search_traits_3<Kernel>>;
using Tree = CGAL::Kd_tree<Traits>;
using Sphere = CGAL::Fuzzy_sphere<Traits>;

// The longest edge of triangle t of `indices` (3 per triangle) over `x`.
float triangle_edge(const std::vector<uint32_t>& indices, const std::vector<Vec3>& x, size_t t) {
  float longest = 0;
  for (size_t k = 0; k < 3; ++k) longest = std::max(longest, length(x[indices[3 * t + k]] - x[indices[3 * t + (k + 1) % 3]]));
  return longest;
}

}  // namespace

// A body point p that touches a cloth point q lies in a body triangle T, within T's longest edge of
// each of T's corners b; q lies within the cloth's longest edge of a cloth vertex c. So at that moment
// |b - c| <= edge(T) + the cloth's edge + the margin, and at t, |b - c| is at most that plus both
// ways. p's way is at most the longest of T's corners'. Each body vertex therefore carries the longest
// edge and the longest way among the triangles it is a corner of.
BodyReach::BodyReach(const ClothModel& model, const ObstacleSet& obstacles, float margin) : obstacles_(obstacles) {
  // A skinned body's triangles stretch as it moves, and the cloth's as it hangs: a quarter more.
  std::vector<Vec3> body, velocity;
  obstacles.pose_at(0.0, body, velocity);
  const std::vector<uint32_t>& tri = obstacles.collision_indices;
  edge_.assign(body.size(), 0.0f);
  for (size_t t = 0; 3 * t + 2 < tri.size(); ++t) {
    const float longest = 1.25f * triangle_edge(tri, body, t);
    for (size_t k = 3 * t; k < 3 * t + 3; ++k) edge_[tri[k]] = std::max(edge_[tri[k]], longest);
  }
  float cloth_edge = 0;
  for (size_t t = 0; 3 * t + 2 < model.triangles.size(); ++t)
    cloth_edge = std::max(cloth_edge, triangle_edge(model.triangles, model.initial_positions, t));
  margin_ = margin + 1.25f * cloth_edge;
}

double BodyReach::way_near_cloth(const ClothState& cloth, double t, double dt, double gravity, double enough) {
  if (!obstacles_.any_moving) return 0.0;
  obstacles_.pose_at(t, b0_, w0_);
  obstacles_.pose_at(t + dt, b1_, w1_);
  const size_t nb = b0_.size();
  own_.resize(nb);
  way_.assign(nb, 0.0);
  for (size_t i = 0; i < nb; ++i)
    own_[i] = std::max({double(length(b1_[i] - b0_[i])), double(length(w0_[i])) * dt, double(length(w1_[i])) * dt});
  const std::vector<uint32_t>& tri = obstacles_.collision_indices;
  for (size_t k = 0; k + 2 < tri.size(); k += 3) {
    const double longest = std::max({own_[tri[k]], own_[tri[k + 1]], own_[tri[k + 2]]});
    for (size_t j = k; j < k + 3; ++j) way_[tri[j]] = std::max(way_[tri[j]], longest);
  }
  order_.resize(nb);
  std::iota(order_.begin(), order_.end(), 0u);
  const std::vector<double>& way = way_;
  std::sort(order_.begin(), order_.end(), [&](uint32_t a, uint32_t b) { return way[a] > way[b] || (way[a] == way[b] && a < b); });
  if (order_.empty() || way[order_[0]] <= enough) return order_.empty() ? 0.0 : way[order_[0]];
  const std::vector<Vec3>* xp = nullptr;
  const std::vector<Vec3>* vp = nullptr;
  cloth(xp, vp);
  const std::vector<Vec3>& x = *xp;
  const std::vector<Vec3>& v = *vp;
  if (x.empty()) return 0.0;

  // How far each cloth vertex can go: twice its way at its speed at t, plus gravity's dt^2.
  std::vector<double>& cloth_way = cloth_way_;
  cloth_way.resize(x.size());
  double farthest = 0;
  Vec3 lo = x[0], hi = x[0];
  std::vector<Indexed> points;
  points.reserve(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    cloth_way[i] = 2.0 * double(length(v[i])) * dt + std::abs(gravity) * dt * dt;
    farthest = std::max(farthest, cloth_way[i]);
    lo = vmin(lo, x[i]);
    hi = vmax(hi, x[i]);
    points.emplace_back(Point(x[i].x, x[i].y, x[i].z), uint32_t(i));
  }
  const Tree tree(points.begin(), points.end());
  std::vector<Indexed> found;
  for (uint32_t i : order_) {
    if (way[i] <= enough) return way[i];
    const double reach = way[i] + double(edge_[i]) + double(margin_);  // without the cloth's way
    const Vec3 p = b0_[i];
    // Outside the cloth's box grown by the reach: not near (no search needed).
    const double box = reach + farthest;
    if (p.x < lo.x - box || p.y < lo.y - box || p.z < lo.z - box || p.x > hi.x + box || p.y > hi.y + box ||
        p.z > hi.z + box)
      continue;
    found.clear();
    tree.search(std::back_inserter(found), Sphere(Point(p.x, p.y, p.z), box, 0.0));
    for (const Indexed& c : found) {
      const uint32_t j = std::get<1>(c);
      if (double(length(x[j] - p)) <= reach + cloth_way[j]) return way[i];
    }
  }
  return 0.0;
}

}  // namespace raycloth
