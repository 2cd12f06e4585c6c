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

// The longest edge of the triangles `indices` (3 per triangle) over `x`.
double longest_edge(const std::vector<uint32_t>& indices, const std::vector<Vec3>& x) {
  double longest = 0;
  for (size_t t = 0; t + 2 < indices.size(); t += 3)
    for (int k = 0; k < 3; ++k)
      longest = std::max(longest, double(length(x[indices[t + size_t(k)]] - x[indices[t + size_t((k + 1) % 3)]])));
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
  for (size_t t = 0; t + 2 < tri.size(); t += 3) {
    float longest = 0;
    for (int k = 0; k < 3; ++k) longest = std::max(longest, length(body[tri[t + size_t(k)]] - body[tri[t + size_t((k + 1) % 3)]]));
    for (int k = 0; k < 3; ++k) edge_[tri[t + size_t(k)]] = std::max(edge_[tri[t + size_t(k)]], 1.25f * longest);
  }
  margin_ = margin + 1.25f * float(longest_edge(model.triangles, model.initial_positions));
}

double BodyReach::way_near_cloth(const std::vector<Vec3>& x, const std::vector<Vec3>& v, double t, double dt,
                                 double gravity, double enough) const {
  if (!obstacles_.any_moving || x.empty()) return 0.0;
  std::vector<Vec3> b0, w0, b1, w1;
  obstacles_.pose_at(t, b0, w0);
  obstacles_.pose_at(t + dt, b1, w1);
  std::vector<double> own(b0.size()), way(b0.size(), 0.0);
  for (size_t i = 0; i < b0.size(); ++i)
    own[i] = std::max({double(length(b1[i] - b0[i])), double(length(w0[i])) * dt, double(length(w1[i])) * dt});
  const std::vector<uint32_t>& tri = obstacles_.collision_indices;
  for (size_t k = 0; k + 2 < tri.size(); k += 3) {
    const double longest = std::max({own[tri[k]], own[tri[k + 1]], own[tri[k + 2]]});
    for (size_t j = k; j < k + 3; ++j) way[tri[j]] = std::max(way[tri[j]], longest);
  }
  std::vector<uint32_t> order(b0.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return way[a] > way[b] || (way[a] == way[b] && a < b); });
  if (order.empty() || way[order[0]] <= enough) return order.empty() ? 0.0 : way[order[0]];

  // How far each cloth vertex can go: twice its way at its speed at t, plus gravity's dt^2.
  std::vector<double> cloth_way(x.size());
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
  for (uint32_t i : order) {
    if (way[i] <= enough) return way[i];
    const double reach = way[i] + double(edge_[i]) + double(margin_);  // without the cloth's way
    const Vec3 p = b0[i];
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
