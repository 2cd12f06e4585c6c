#include "sim/garment_fit.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/convex_hull_2.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <tuple>
#include <unordered_map>

#include "check/exact_check.h"
#include "collide/proximity.h"
#include "raycloth/error.h"
#include "sim/model.h"
#include "sim/model_check.h"

namespace raycloth {

namespace {

const Vec3 kUp = make_vec3(0, 1, 0);
using Point2 = CGAL::Exact_predicates_inexact_constructions_kernel::Point_2;

// Where a horizontal plane cuts a body: the extent of the cut across (side) and along (front).
struct Section {
  double side_lo = INFINITY, side_hi = -INFINITY, front_lo = INFINITY, front_hi = -INFINITY;
  bool empty() const { return !(side_hi >= side_lo); }
};

struct Body {
  const std::vector<Vec3>* x = nullptr;
  std::vector<uint32_t> tris;  // 3 per triangle, into *x
};

// Obstacle oi's triangles over the posed vertices.
Body obstacle_body(const ObstacleSet& obstacles, size_t oi, const std::vector<Vec3>& posed) {
  Body b;
  b.x = &posed;
  b.tris.assign(obstacles.world.indices.begin() + 3 * obstacles.first_triangle[oi],
                obstacles.world.indices.begin() + 3 * obstacles.end_triangle(oi));
  return b;
}

// Where edge p-q crosses the horizontal plane at height h, into c; false where it does not (an edge
// lying in the plane does not).
bool cut_point(Vec3 p, Vec3 q, double h, Vec3& c) {
  if ((double(p.y) - h) * (double(q.y) - h) > 0 || p.y == q.y) return false;
  const float u = float((h - double(p.y)) / (double(q.y) - double(p.y)));
  c = p + (q - p) * u;
  return true;
}

Section section(const Body& b, double h, const BodyFrame& f) {
  Section s;
  const std::vector<Vec3>& x = *b.x;
  for (size_t t = 0; t < b.tris.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      Vec3 c;
      if (!cut_point(x[b.tris[t + k]], x[b.tris[t + (k + 1) % 3]], h, c)) continue;
      const double side = double(dot(c, f.side)), front = double(dot(c, f.front));
      s.side_lo = std::min(s.side_lo, side), s.side_hi = std::max(s.side_hi, side);
      s.front_lo = std::min(s.front_lo, front), s.front_hi = std::max(s.front_hi, front);
    }
  return s;
}

// The central pieces of a body's cut at `mid` (metres along its side): the one across it, or the two
// either side of a gap across it (`legs`: the body stands on two legs there), from lo to hi. Not
// the arms. lo > hi where the cut has neither.
struct Stance {
  bool legs = false;
  double lo = INFINITY, hi = -INFINITY;
};

// The body's cut by the horizontal plane at height h, seen from above: a segment, (side, front) at
// each end, per triangle the plane cuts; the cut's pieces as seen from the front (the segments'
// extents across, merged where they touch), lowest side first; and its central pieces.
struct Cut {
  std::vector<std::array<Point2, 2>> segments;
  std::vector<std::pair<double, double>> pieces;
  Stance central;
};

Cut cut_at(const Body& b, double h, const BodyFrame& f, double mid) {
  Cut cut;
  const std::vector<Vec3>& x = *b.x;
  for (size_t t = 0; t < b.tris.size(); t += 3) {
    Point2 ends[2];
    int n = 0;
    for (int k = 0; k < 3 && n < 2; ++k) {
      Vec3 c;
      if (cut_point(x[b.tris[t + k]], x[b.tris[t + (k + 1) % 3]], h, c))
        ends[n++] = Point2(double(dot(c, f.side)), double(dot(c, f.front)));
    }
    if (n == 2) cut.segments.push_back({ends[0], ends[1]});
  }
  std::vector<std::pair<double, double>> spans;
  for (const auto& c : cut.segments) spans.emplace_back(std::min(c[0].x(), c[1].x()), std::max(c[0].x(), c[1].x()));
  std::sort(spans.begin(), spans.end());
  for (const auto& sp : spans)
    if (!cut.pieces.empty() && sp.first <= cut.pieces.back().second + 1e-3)
      cut.pieces.back().second = std::max(cut.pieces.back().second, sp.second);
    else
      cut.pieces.push_back(sp);
  const auto& pc = cut.pieces;
  for (size_t i = 0; i < pc.size(); ++i) {
    if (pc[i].first <= mid && pc[i].second >= mid) cut.central = {false, pc[i].first, pc[i].second};
    if (i + 1 < pc.size() && pc[i].second < mid && pc[i + 1].first > mid) cut.central = {true, pc[i].first, pc[i + 1].second};
  }
  return cut;
}

// A uniform grid of the body's triangles (each in every cell its box, grown by `margin`, touches).
class TriangleGrid {
 public:
  TriangleGrid(const Body& b, float cell, float margin) : cell_(cell) {
    const std::vector<Vec3>& x = *b.x;
    for (uint32_t t = 0; t < b.tris.size() / 3; ++t) {
      Vec3 lo = x[b.tris[3 * t]], hi = lo;
      for (int k = 1; k < 3; ++k) lo = vmin(lo, x[b.tris[3 * t + k]]), hi = vmax(hi, x[b.tris[3 * t + k]]);
      const auto a = key3(lo - make_vec3(margin, margin, margin)), z = key3(hi + make_vec3(margin, margin, margin));
      for (int64_t i = a[0]; i <= z[0]; ++i)
        for (int64_t j = a[1]; j <= z[1]; ++j)
          for (int64_t k = a[2]; k <= z[2]; ++k) cells_[hash(i, j, k)].push_back(t);
    }
  }
  // Triangles in p's cell (those within `margin` of p among them).
  const std::vector<uint32_t>* near(Vec3 p) const {
    const auto k = key3(p);
    const auto it = cells_.find(hash(k[0], k[1], k[2]));
    return it == cells_.end() ? nullptr : &it->second;
  }
  // Triangles in any cell that the box [lo, hi] touches (with repeats).
  void in_box(Vec3 lo, Vec3 hi, std::vector<uint32_t>& out) const {
    const auto a = key3(lo), z = key3(hi);
    for (int64_t i = a[0]; i <= z[0]; ++i)
      for (int64_t j = a[1]; j <= z[1]; ++j)
        for (int64_t k = a[2]; k <= z[2]; ++k)
          if (auto it = cells_.find(hash(i, j, k)); it != cells_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
  }

 private:
  std::array<int64_t, 3> key3(Vec3 p) const {
    return {int64_t(std::floor(p.x / cell_)), int64_t(std::floor(p.y / cell_)), int64_t(std::floor(p.z / cell_))};
  }
  static uint64_t hash(int64_t i, int64_t j, int64_t k) {
    return (uint64_t(i + (1 << 20)) << 42) ^ (uint64_t(j + (1 << 20)) << 21) ^ uint64_t(k + (1 << 20));
  }
  float cell_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> cells_;
};

DPoint dpoint(Vec3 v) { return {double(v.x), double(v.y), double(v.z)}; }

// Whether a panel (vertices `ids` moved by `move`, triangles `tris` over model vertex numbers) is
// clear of the body: no vertex inside or within `clearance` of its surface, no body edge through one
// of its triangles.
bool panel_clear(const ClothModel& m, const std::vector<uint32_t>& ids, const std::vector<uint32_t>& tris, Vec3 move,
                 const Body& body, const TriangleGrid& grid, const CheckMesh& body_mesh, float clearance) {
  const std::vector<Vec3>& bx = *body.x;
  std::unordered_map<uint32_t, uint32_t> local;
  CheckMesh panel;
  for (uint32_t i : ids) {
    local[i] = uint32_t(panel.vertices.size());
    panel.vertices.push_back(m.initial_positions[i] + move);
  }
  const double c2 = double(clearance) * double(clearance);
  for (const Vec3& p : panel.vertices)
    if (const auto* near = grid.near(p))
      for (uint32_t t : *near) {
        const TrianglePoint q =
            closest_on_triangle(dvec(p), dvec(bx[body.tris[3 * t]]), dvec(bx[body.tris[3 * t + 1]]), dvec(bx[body.tris[3 * t + 2]]));
        if (q.dist2 < c2) return false;
      }
  for (uint32_t v : tris) panel.triangles.push_back(local.at(v));
  if (!find_vertices_inside(panel, body_mesh).empty()) return false;
  std::vector<uint32_t> cand;
  for (size_t t = 0; t < panel.triangles.size(); t += 3) {
    const Vec3 a = panel.vertices[panel.triangles[t]], b = panel.vertices[panel.triangles[t + 1]],
               c = panel.vertices[panel.triangles[t + 2]];
    cand.clear();
    grid.in_box(vmin(a, vmin(b, c)), vmax(a, vmax(b, c)), cand);
    std::sort(cand.begin(), cand.end());
    cand.erase(std::unique(cand.begin(), cand.end()), cand.end());
    for (uint32_t bt : cand)
      for (int k = 0; k < 3; ++k) {
        const Vec3 p = bx[body.tris[3 * bt + k]], q = bx[body.tris[3 * bt + (k + 1) % 3]];
        if (classify_edge_triangle(dpoint(p), dpoint(q), dpoint(a), dpoint(b), dpoint(c)) != EdgeTriangle::Apart) return false;
      }
  }
  return true;
}

// How many stitches of a panel (its vertices `ids`, one range, moved by `move`) to panels facing its
// way (`same_way(v)` for the other side's vertex v: a flounce and the sleeve whose edge it continues,
// not a sleeve's front and back) start through the body: the segment between the stitch's two sides,
// the other side where it is now, meets a body triangle.
template <class SameWay>
size_t stitches_through_body(const ClothModel& m, const std::vector<uint32_t>& ids, Vec3 move, const Body& body,
                             const TriangleGrid& grid, SameWay&& same_way) {
  if (ids.empty()) return 0;
  const uint32_t lo = ids.front(), hi = ids.back();
  auto in = [&](uint32_t v) { return v >= lo && v <= hi; };
  const std::vector<Vec3>& bx = *body.x;
  size_t through = 0;
  std::vector<uint32_t> cand;
  for (size_t k = 0; k + 1 < m.stitches.size(); k += 2) {
    const uint32_t u = m.stitches[k], w = m.stitches[k + 1];
    if (in(u) == in(w) || !same_way(in(u) ? w : u)) continue;
    const Vec3 p = in(u) ? m.initial_positions[u] + move : m.initial_positions[u];
    const Vec3 q = in(w) ? m.initial_positions[w] + move : m.initial_positions[w];
    cand.clear();
    grid.in_box(vmin(p, q), vmax(p, q), cand);
    std::sort(cand.begin(), cand.end());
    cand.erase(std::unique(cand.begin(), cand.end()), cand.end());
    for (uint32_t t : cand)
      if (classify_edge_triangle(dpoint(p), dpoint(q), dpoint(bx[body.tris[3 * t]]), dpoint(bx[body.tris[3 * t + 1]]),
                                 dpoint(bx[body.tris[3 * t + 2]])) != EdgeTriangle::Apart) {
        ++through;
        break;
      }
  }
  return through;
}

// A panel's vertices and triangles (model vertex numbers) and its mean normal.
Vec3 panel_geometry(const ClothModel& m, const Piece& piece, std::vector<uint32_t>& pv, std::vector<uint32_t>& pt) {
  pv.clear(), pt.clear();
  for (uint32_t i = 0; i < piece.vertex_count; ++i) pv.push_back(piece.first_vertex + i);
  Vec3 normal = make_vec3(0, 0, 0);
  for (uint32_t t = piece.first_triangle; t < piece.first_triangle + piece.num_triangles; ++t) {
    const uint32_t a = m.triangles[3 * t], b = m.triangles[3 * t + 1], c = m.triangles[3 * t + 2];
    pt.insert(pt.end(), {a, b, c});
    normal += cross(m.initial_positions[b] - m.initial_positions[a], m.initial_positions[c] - m.initial_positions[a]);
  }
  return length(normal) > 0 ? normal / length(normal) : kUp;
}

// The points of a cut's central pieces, (side, front), appended to pts.
void central_points(const Cut& cut, std::vector<Point2>& pts) {
  for (const auto& c : cut.segments)
    for (const Point2& p : c)
      if (p.x() >= cut.central.lo && p.x() <= cut.central.hi) pts.push_back(p);
}

// One half of a body's hull at a height (its front or its back), grown by a margin, from its lowest
// side to its highest: a polyline with arc lengths measured from where it crosses `mid`.
struct HullHalf {
  std::vector<Point2> pts;
  std::vector<double> arc;  // signed arc length from the middle, increasing along pts
  Point2 centre;
  bool empty() const { return pts.size() < 2; }
  double length_left() const { return -arc.front(); }
  double length_right() const { return arc.back(); }
  // The point at signed arc length a, the whole half scaled by k about the hull's centre.
  Point2 at(double a, double k) const {
    a = std::clamp(a, arc.front(), arc.back());
    size_t i = size_t(std::upper_bound(arc.begin(), arc.end(), a) - arc.begin());
    i = std::clamp<size_t>(i, 1, pts.size() - 1);
    const double t = arc[i] > arc[i - 1] ? (a - arc[i - 1]) / (arc[i] - arc[i - 1]) : 0.0;
    const double px = pts[i - 1].x() + t * (pts[i].x() - pts[i - 1].x()), py = pts[i - 1].y() + t * (pts[i].y() - pts[i - 1].y());
    return Point2(centre.x() + k * (px - centre.x()), centre.y() + k * (py - centre.y()));
  }
};

HullHalf hull_half(std::vector<Point2> pts, bool front, double mid, double margin) {
  HullHalf half;
  std::vector<Point2> hull;
  CGAL::convex_hull_2(pts.begin(), pts.end(), std::back_inserter(hull));  // counter-clockwise
  const size_t n = hull.size();
  if (n < 3) return half;
  double cx = 0, cy = 0;
  for (const Point2& p : hull) cx += p.x(), cy += p.y();
  half.centre = Point2(cx / double(n), cy / double(n));
  // Grown: each corner out along the mean of its two edges' outward normals.
  std::vector<Point2> grown(n);
  for (size_t i = 0; i < n; ++i) {
    const Point2 &a = hull[(i + n - 1) % n], &p = hull[i], &b = hull[(i + 1) % n];
    auto normal = [](const Point2& u, const Point2& v) {
      const double dx = v.x() - u.x(), dy = v.y() - u.y(), l = std::hypot(dx, dy);
      return std::array<double, 2>{dy / l, -dx / l};  // outward for a counter-clockwise polygon
    };
    const auto n1 = normal(a, p), n2 = normal(p, b);
    double mx = n1[0] + n2[0], my = n1[1] + n2[1];
    const double ml = std::hypot(mx, my);
    if (ml > 1e-12) mx /= ml, my /= ml;
    grown[i] = Point2(p.x() + margin * mx, p.y() + margin * my);
  }
  // Split where the line through the centre, across the body, cuts it: the front half runs from that
  // cut's low side to its high side through the points in front of the centre, the back half through
  // those behind (counter-clockwise in (side, front), the front follows the high side's cut).
  const double line = half.centre.y();
  std::vector<std::pair<size_t, Point2>> cuts;  // after corner i, the point where the line crosses
  for (size_t i = 0; i < n; ++i) {
    const Point2 &a = grown[i], &b = grown[(i + 1) % n];
    if ((a.y() - line) * (b.y() - line) < 0 || (a.y() == line && b.y() != line)) {
      const double t = (line - a.y()) / (b.y() - a.y());
      cuts.emplace_back(i, Point2(a.x() + t * (b.x() - a.x()), line));
    }
  }
  if (cuts.size() != 2) return half;
  if (cuts[0].second.x() > cuts[1].second.x()) std::swap(cuts[0], cuts[1]);
  const auto& [lo_i, lo_p] = cuts[0];
  const auto& [hi_i, hi_p] = cuts[1];
  std::vector<Point2> chain;
  if (front) {  // hi -> corners hi_i+1 .. lo_i -> lo, then reversed
    chain.push_back(hi_p);
    for (size_t i = (hi_i + 1) % n;; i = (i + 1) % n) {
      chain.push_back(grown[i]);
      if (i == lo_i) break;
    }
    chain.push_back(lo_p);
    std::reverse(chain.begin(), chain.end());
  } else {  // lo -> corners lo_i+1 .. hi_i -> hi
    chain.push_back(lo_p);
    for (size_t i = (lo_i + 1) % n;; i = (i + 1) % n) {
      chain.push_back(grown[i]);
      if (i == hi_i) break;
    }
    chain.push_back(hi_p);
  }
  std::vector<double> arc(chain.size(), 0.0);
  for (size_t i = 1; i < chain.size(); ++i)
    arc[i] = arc[i - 1] + std::hypot(chain[i].x() - chain[i - 1].x(), chain[i].y() - chain[i - 1].y());
  // Arc length where the chain crosses the middle.
  double at_mid = 0;
  for (size_t i = 1; i < chain.size(); ++i)
    if (chain[i - 1].x() <= mid && chain[i].x() >= mid) {
      const double dx = chain[i].x() - chain[i - 1].x();
      at_mid = arc[i - 1] + (dx > 0 ? (mid - chain[i - 1].x()) / dx : 0.0) * (arc[i] - arc[i - 1]);
      break;
    }
  for (double& a : arc) a -= at_mid;
  half.pts = std::move(chain), half.arc = std::move(arc);
  return half;
}

// Panels that hang in front of or behind the legs and are narrower than the stance there (a pencil
// skirt on a body standing with its feet apart) start with their sides in front of and behind a
// leg: the stitch between a front and a back panel runs through the leg, and the panels, drawn
// together, close between the legs, or not at all. Each such panel is wrapped, height by height,
// around the front (or the back) of the body's hull there (its central pieces: the hips, or both
// legs, not the arms), grown by `margin`: its sides end kWrapGap short of the hull's sides, where
// the other panel's sides end, so the stitches start short and outside the legs. Where the panel is
// narrower than that it starts stretched (at most kMaxStanceWiden; its rest lengths ease from the
// stretched ones to the pattern's as the seams close, as every spring's do); where wider, the hull is
// scaled up to fit it. Panels are wrapped below `top`; a panel that reaches above it (a robe's) is
// eased from its wrapped place kWrapEase below `top` to its own at `top`; a robe's open half is laid
// from the middle. Panels on one side sewn to each other along the middle are wrapped as one, and a
// panel sewn to a wrapped one on its side (a flounce at its hem) with it. Returns the largest stretch
// per panel (at least 1 where wrapped, 0 where not).
template <class Panels>
std::vector<float> wrap_for_stance(ClothModel& m, const Panels& panels, const Body& body, const BodyFrame& f,
                                   double mid, double front_mid, float margin, double top) {
  const double bin = 0.01;  // metres of height
  std::unordered_map<int64_t, Cut> cuts;  // the body's cut per bin of height, made once
  auto key_of = [&](double y) { return int64_t(std::floor((y - f.floor) / bin)); };
  auto cut_of = [&](int64_t k) -> const Cut& {
    auto it = cuts.find(k);
    if (it == cuts.end()) it = cuts.emplace(k, cut_at(body, f.floor + (double(k) + 0.5) * bin, f, mid)).first;
    return it->second;
  };
  auto stance_at = [&](int64_t k) -> const Stance& { return cut_of(k).central; };
  // The front (or back) half of the hull of the cuts within two bins of k (so that it changes smoothly
  // from row to row), grown by `grow`, made once.
  std::map<std::tuple<int64_t, bool, float>, HullHalf> halves;
  auto half_at = [&](int64_t k, bool front, float grow) -> const HullHalf& {
    auto it = halves.find({k, front, grow});
    if (it == halves.end()) {
      std::vector<Point2> pts;
      for (int64_t j = k - 2; j <= k + 2; ++j) central_points(cut_of(j), pts);
      it = halves.emplace(std::make_tuple(k, front, grow), hull_half(std::move(pts), front, mid, grow)).first;
    }
    return it->second;
  };
  // A panel's vertices and its extent either side of the middle per bin of height.
  struct Rows {
    std::vector<uint32_t> pv;
    std::unordered_map<int64_t, std::pair<double, double>> extent;
    bool front = false, reaches_top = false;  // reaches above `top` (a robe's panel, eased back there)
    bool from_middle = false;  // reaches above `top` and the middle on the legs (a robe's open half)
    double depth = 0;  // mean distance in front of (behind) the body's middle
    std::pair<double, double> row(int64_t k) const {  // the extent within two bins of k
      double lo = INFINITY, hi = -INFINITY;
      for (int64_t j = k - 2; j <= k + 2; ++j)
        if (auto it = extent.find(j); it != extent.end()) lo = std::min(lo, it->second.first), hi = std::max(hi, it->second.second);
      return {lo, hi};
    }
  };
  std::vector<float> stretched(panels.size(), 0.0f);
  // Every panel that faces the front or the back, with its rows.
  std::vector<std::pair<size_t, Rows>> facing;  // (index into panels, rows)
  for (size_t n = 0; n < panels.size(); ++n) {
    Rows r;
    std::vector<uint32_t> pt;
    const Vec3 normal = panel_geometry(m, m.pieces[panels[n]], r.pv, pt);
    if (std::fabs(dot(normal, f.front)) < 0.7f) continue;
    double front_sum = 0;
    for (uint32_t i : r.pv) {
      const double s = double(dot(m.initial_positions[i], f.side)) - mid;
      front_sum += double(dot(m.initial_positions[i], f.front));
      auto [it, fresh] = r.extent.try_emplace(key_of(double(m.initial_positions[i].y)), s, s);
      it->second.first = std::min(it->second.first, s), it->second.second = std::max(it->second.second, s);
    }
    const double mean_front = front_sum / double(r.pv.size());
    r.front = mean_front > front_mid, r.depth = std::fabs(mean_front - front_mid);
    r.reaches_top = std::any_of(r.pv.begin(), r.pv.end(), [&](uint32_t i) { return double(m.initial_positions[i].y) > top; });
    facing.emplace_back(n, std::move(r));
  }
  // Panels on one side sewn along the middle, joined: their rows become the group's.
  std::vector<size_t> group(facing.size());
  for (size_t a = 0; a < facing.size(); ++a) group[a] = a;
  auto root = [&](size_t a) {
    while (group[a] != a) a = group[a] = group[group[a]];
    return a;
  };
  // Facing panels on one side sewn to each other -> whether every stitch between them is near the middle.
  std::map<std::pair<size_t, size_t>, bool> sewn_on_side;
  {
    std::unordered_map<uint32_t, size_t> panel_of;  // model vertex -> index into facing
    for (size_t a = 0; a < facing.size(); ++a)
      for (uint32_t i : facing[a].second.pv) panel_of[i] = a;
    for (size_t k = 0; k + 1 < m.stitches.size(); k += 2) {
      const auto ia = panel_of.find(m.stitches[k]), ib = panel_of.find(m.stitches[k + 1]);
      if (ia == panel_of.end() || ib == panel_of.end() || ia->second == ib->second) continue;
      if (facing[ia->second].second.front != facing[ib->second].second.front) continue;
      const auto key = std::minmax(ia->second, ib->second);
      const bool near = std::fabs(double(dot(m.initial_positions[m.stitches[k]], f.side)) - mid) < kMiddleSeam &&
                        std::fabs(double(dot(m.initial_positions[m.stitches[k + 1]], f.side)) - mid) < kMiddleSeam;
      auto [it, fresh] = sewn_on_side.try_emplace(key, near);
      it->second = it->second && near;
    }
    for (const auto& [key, near] : sewn_on_side)
      if (near) group[root(key.first)] = root(key.second);
  }
  std::unordered_map<size_t, Rows> group_rows;  // by root: the members' rows merged, whether one reaches `top`
  for (size_t a = 0; a < facing.size(); ++a) {
    Rows& g = group_rows[root(a)];
    g.reaches_top = g.reaches_top || facing[a].second.reaches_top;
    for (const auto& [k, e] : facing[a].second.extent) {
      auto [it, fresh] = g.extent.try_emplace(k, e);
      it->second.first = std::min(it->second.first, e.first), it->second.second = std::max(it->second.second, e.second);
    }
  }
  std::vector<std::pair<size_t, Rows>> wrapped;  // (index into facing, rows: the group's extent)
  for (size_t a = 0; a < facing.size(); ++a) {
    const Rows& g = group_rows[root(a)];
    // Wrapped where the group's whole rows (at least 0.8 of its median width on the legs: not where a
    // curved hem or waist leaves a short one) do not clear the legs' outer sides by the margin, over
    // kNarrowHeight of height at least.
    std::vector<double> widths;
    for (const auto& [k, e] : g.extent)
      if (stance_at(k).legs) widths.push_back(e.second - e.first);
    if (widths.empty()) continue;
    std::nth_element(widths.begin(), widths.begin() + widths.size() / 2, widths.end());
    const double median_width = widths[widths.size() / 2];
    size_t narrow_rows = 0;
    for (const auto& [k, e] : g.extent) {
      const Stance& st = stance_at(k);
      if (!st.legs || e.second - e.first < 0.8 * median_width) continue;
      const auto [lo, hi] = g.row(k);
      const double out_hi = st.hi - mid, out_lo = st.lo - mid;
      if ((hi > 0.5 * out_hi && hi < out_hi + margin) || (lo < 0.5 * out_lo && lo > out_lo - margin)) {
        ++narrow_rows;
      } else if (g.reaches_top) {
        // A panel from the shoulders hangs slack: it is wrapped unless its sides reach kWrapSlack times
        // the hull's half round the legs (a robe whose sides clear the legs by less: its seams, closing,
        // meet across them).
        const HullHalf& half = half_at(k, facing[a].second.front, margin);
        if (!half.empty() && ((hi > 0.5 * out_hi && hi < kWrapSlack * half.length_right()) ||
                              (lo < 0.5 * out_lo && -lo < kWrapSlack * half.length_left())))
          ++narrow_rows;
      }
    }
    if (double(narrow_rows) * bin < kNarrowHeight) continue;
    Rows r = facing[a].second;
    r.extent = g.extent;
    // A robe's open half, laid from the middle: a panel from above `top` whose rows where he stands on
    // two legs reach the middle, four fifths of them (its neckline leaves the middle higher up, its hem
    // may curve). A pant leg leaves the middle below the crotch; a flounce that reaches it does not
    // reach above `top`.
    size_t on_legs = 0, at_middle = 0;
    for (const auto& [k, e] : r.extent)
      if (stance_at(k).legs) {
        const auto [lo, hi] = r.row(k);
        ++on_legs;
        at_middle += std::min(std::fabs(lo), std::fabs(hi)) < kMiddleSeam || (lo < 0 && hi > 0);
      }
    r.from_middle = r.reaches_top && on_legs > 0 && 5 * at_middle >= 4 * on_legs;
    wrapped.emplace_back(a, std::move(r));
  }
  // A panel's wrapped place, vertex by vertex, on hulls grown by `grow`, and its largest stretch (0:
  // no vertex is moved, its rows neither cross the middle nor, for a robe's half, reach it).
  auto wrap = [&](const Rows& r, float grow, std::vector<Vec3>& moved) {
    moved.resize(r.pv.size());
    float most = 0.0f;
    for (size_t v = 0; v < r.pv.size(); ++v) {
      const Vec3 x = m.initial_positions[r.pv[v]];
      moved[v] = x;
      // Rows below the body's feet are laid on the hull of its lowest rows.
      const int64_t k = std::max<int64_t>(key_of(double(x.y)), 2);
      const HullHalf& half = half_at(k, r.front, grow);
      if (half.empty()) continue;
      const auto [lo, hi] = r.row(key_of(double(x.y)));
      const double room_r = half.length_right() - kWrapGap, room_l = half.length_left() - kWrapGap;
      // Only a panel (or a group) across the middle, or from the middle to one side (a robe's open
      // front half); a pant leg's, from near the middle to one side, is not.
      if (!(room_r > 0 && room_l > 0 && ((hi > 0 && lo < 0) || (r.from_middle && hi > -kMiddleSeam && lo < kMiddleSeam && hi - lo > kMiddleSeam)))) continue;
      // Scaled up where the panel is wider than the half; else stretched to reach its sides.
      const double scale = std::max({1.0, hi / room_r, -lo / room_l});
      const double s = double(dot(x, f.side)) - mid;
      const double reach = s >= 0 ? room_r * scale / std::max(hi, 1e-6) : room_l * scale / std::max(-lo, 1e-6);  // arc per metre
      // Stretched only where the body stands on two legs; above, a row narrower than the hull's
      // half (a waist's curve) is laid on it as it is; eased from one to the other over the five bins
      // about the crotch (a step there folds the panel where its rows curve round the hips).
      double legs = 0;
      for (int64_t j = k - 2; j <= k + 2; ++j) legs += stance_at(j).legs ? 0.2 : 0.0;
      const double factor = std::min(reach, 1.0 + legs * (kMaxStanceWiden - 1.0));
      const Point2 q = half.at(s * factor / scale, scale);
      // Eased back to its own place up to `top` (a panel that reaches above it).
      const float w = r.reaches_top ? float(std::clamp((top - double(x.y)) / kWrapEase, 0.0, 1.0)) : 1.0f;
      moved[v] = x + (f.side * float(q.x()) + f.front * float(q.y()) + kUp * x.y - x) * w;
      if (w > 0) most = std::max(most, float(factor));
    }
    return most;
  };
  // Only panels that the wrap moves; then a panel below `top` sewn to one of those on its side (a
  // flounce at a wrapped skirt's hem, its waistband) is wrapped too, else the wrapped panel's sides,
  // curved round the legs, go through it.
  std::vector<Vec3> moved;
  std::erase_if(wrapped, [&](const auto& w) { return wrap(w.second, margin, moved) == 0.0f; });
  std::vector<bool> is_wrapped(facing.size(), false), tried(facing.size(), false);
  for (const auto& [a, r] : wrapped) is_wrapped[a] = tried[a] = true;
  for (bool more = true; more;) {
    more = false;
    for (const auto& [key, near] : sewn_on_side)
      for (auto [a, b] : {key, std::pair<size_t, size_t>{key.second, key.first}})
        if (is_wrapped[a] && !tried[b] && !facing[b].second.reaches_top) {
          tried[b] = true;
          Rows r = facing[b].second;
          r.extent = group_rows[root(b)].extent;
          if (wrap(r, margin, moved) == 0.0f) continue;  // not moved: no panel follows it
          wrapped.emplace_back(b, std::move(r));
          is_wrapped[b] = more = true;
        }
  }
  // Layers keep their order: on each side, a panel placed farther out is wrapped kWrapLayer farther
  // out than the one inside it.
  std::vector<std::vector<Vec3>> places(wrapped.size());
  for (size_t w = 0; w < wrapped.size(); ++w) {
    const auto& [a, r] = wrapped[w];
    size_t inside = 0;
    for (const auto& [a2, r2] : wrapped) inside += r2.front == r.front && r2.depth < r.depth;
    stretched[facing[a].first] = wrap(r, margin + float(inside * kWrapLayer), places[w]);
  }
  for (size_t w = 0; w < wrapped.size(); ++w)
    for (size_t v = 0; v < wrapped[w].second.pv.size(); ++v) m.initial_positions[wrapped[w].second.pv[v]] = places[w][v];
  return stretched;
}

// Cloth edges through cloth triangles among the given panels (their collision triangles at x).
template <class Panels>
size_t crossings_among(const ClothModel& m, const std::vector<Vec3>& x, const Panels& panels) {
  CheckMesh mesh;
  mesh.vertices = x;
  for (uint32_t p : panels) {
    const Piece& piece = m.pieces[p];
    mesh.group_names.push_back(piece.name);
    mesh.group_first_triangle.push_back(uint32_t(mesh.num_triangles()));
    mesh.triangles.insert(mesh.triangles.end(), m.collision_triangles.begin() + 3 * piece.first_triangle,
                          m.collision_triangles.begin() + 3 * (piece.first_triangle + piece.num_triangles));
  }
  CheckReport r;
  check_cloth_crossings(mesh, r);
  return r.crossings;
}

// Whether panels a and b (their collision triangles at positions x) cross each other or themselves.
bool panels_cross(const ClothModel& m, const std::vector<Vec3>& x, uint32_t a, uint32_t b) {
  return crossings_among(m, x, std::array<uint32_t, 2>{std::min(a, b), std::max(a, b)}) > 0;
}

// Whether a vertex of panel a lies within `gap` of a triangle of panel b, or one of b within gap of
// one of a's (at positions x): the two overlap. A vertex on a panel's outline sewn to the other panel
// (`sewn_to(i, q)`) is left out: panels sewn edge to edge may start with their edges together.
template <class SewnTo>
bool panels_touch(const ClothModel& m, const std::vector<Vec3>& x, uint32_t a, uint32_t b, float gap,
                  const std::vector<bool>& outline, SewnTo&& sewn_to) {
  const double g2 = double(gap) * double(gap);
  for (auto [p, q] : {std::pair<uint32_t, uint32_t>{a, b}, {b, a}}) {
    Body other;
    other.x = &x;
    const Piece& pq = m.pieces[q];
    other.tris.assign(m.triangles.begin() + 3 * pq.first_triangle, m.triangles.begin() + 3 * (pq.first_triangle + pq.num_triangles));
    const TriangleGrid grid(other, 0.03f, gap);
    const Piece& pp = m.pieces[p];
    for (uint32_t i = pp.first_vertex; i < pp.first_vertex + pp.vertex_count; ++i) {
      if (outline[i] && sewn_to(i, q)) continue;
      if (const auto* near = grid.near(x[i]))
        for (uint32_t t : *near) {
          const TrianglePoint c = closest_on_triangle(dvec(x[i]), dvec(x[other.tris[3 * t]]), dvec(x[other.tris[3 * t + 1]]),
                                                      dvec(x[other.tris[3 * t + 2]]));
          if (c.dist2 < g2) return true;
        }
    }
  }
  return false;
}

// Panels of one garment that cross each other once each is clear of the body (a hood over a
// sleeve, both moved out of the shoulder), or that lie within `gap` of each other away from their
// seams (GarmentCodeData's rand_033UAN6C0K places its two legs' cuff flounces overlapping in one
// plane: touching everywhere, the displacement bound left their vertices no room to move, and the
// flounces stayed where they started, their seams 36 cm open; GarmentCode's jumpsuit lays the tips of
// its two back trouser panels 2 mm over each other where they are sewn to the front panels, not to
// each other, and those tips stayed put, the crotch 10 cm open): the panel whose edge goes through
// (or the first of a touching pair) moves on away from the body's axis along its normal, 5 mm at a
// time while it stays clear of the body, up to kMaxClearMove in all; failing that the other panel
// does. Pair by pair until none crosses or touches, or a pair cannot be parted (a crossing is then
// refused at the start, naming the two).
template <class Clear>
void separate_panels(ClothModel& m, const GarmentFitDef& g, std::vector<PanelFit>& fits, size_t first_fit, Vec3 axis,
                     float gap, Clear&& clear) {
  auto panel_index = [&](const std::string& name) {
    for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p)
      if (m.pieces[p].name == name) return int(p);
    return -1;
  };
  // Vertices on a panel's outline: on an edge of one of its triangles only.
  std::vector<bool> outline(m.num_vertices(), false);
  for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p) {
    std::unordered_map<uint64_t, int> uses;
    const Piece& piece = m.pieces[p];
    for (uint32_t t = piece.first_triangle; t < piece.first_triangle + piece.num_triangles; ++t)
      for (int k = 0; k < 3; ++k) {
        const uint32_t u = m.triangles[3 * t + k], v = m.triangles[3 * t + (k + 1) % 3];
        ++uses[(uint64_t(std::min(u, v)) << 32) | std::max(u, v)];
      }
    for (const auto& [e, n] : uses)
      if (n == 1) outline[uint32_t(e >> 32)] = outline[uint32_t(e & 0xffffffffu)] = true;
  }
  // The panels each vertex is sewn to: those of its seam group (welded partners) and of the groups
  // it is stitched to.
  std::unordered_map<uint32_t, std::vector<uint32_t>> group_panels;  // representative -> panels
  for (uint32_t p = 0; p < m.pieces.size(); ++p)
    for (uint32_t i = m.pieces[p].first_vertex; i < m.pieces[p].first_vertex + m.pieces[p].vertex_count; ++i) {
      std::vector<uint32_t>& ps = group_panels[m.alias[i]];
      if (std::find(ps.begin(), ps.end(), p) == ps.end()) ps.push_back(p);
    }
  std::unordered_multimap<uint32_t, uint32_t> stitched;  // representative -> representative
  for (size_t k = 0; k + 1 < m.stitches.size(); k += 2) {
    stitched.emplace(m.alias[m.stitches[k]], m.alias[m.stitches[k + 1]]);
    stitched.emplace(m.alias[m.stitches[k + 1]], m.alias[m.stitches[k]]);
  }
  auto sewn_to = [&](uint32_t i, uint32_t q) {
    auto has = [&](uint32_t rep) {
      const auto it = group_panels.find(rep);
      return it != group_panels.end() && std::find(it->second.begin(), it->second.end(), q) != it->second.end();
    };
    if (has(m.alias[i])) return true;
    const auto [lo, hi] = stitched.equal_range(m.alias[i]);
    for (auto it = lo; it != hi; ++it)
      if (has(it->second)) return true;
    return false;
  };
  auto touching = [&](int& pa, int& pb) {
    for (uint32_t a = g.first_panel; a < g.first_panel + g.num_panels; ++a)
      for (uint32_t b = a + 1; b < g.first_panel + g.num_panels; ++b)
        if (panels_touch(m, m.initial_positions, a, b, gap, outline, sewn_to)) {
          pa = int(a), pb = int(b);
          return true;
        }
    return false;
  };
  for (uint32_t round = 0; round < 2 * g.num_panels; ++round) {
    CheckReport r;
    check_cloth_crossings(cloth_check_mesh(m, m.initial_positions), r);
    int pa = -1, pb = -1;
    bool touch = false;
    if (r.crossings > 0) {
      const CrossingRecord& c = r.first_crossings.front();
      pa = panel_index(c.edge_group), pb = panel_index(c.triangle_group);
    } else {
      touch = touching(pa, pb);
      if (!touch) return;
    }
    if (pa < 0 || pb < 0 || pa == pb) return;
    bool parted = false;
    for (int p : {pa, pb}) {
      std::vector<uint32_t> pv, pt;
      Vec3 normal = panel_geometry(m, m.pieces[p], pv, pt);
      Vec3 centre = make_vec3(0, 0, 0);
      for (uint32_t i : pv) centre += m.initial_positions[i];
      centre = centre / float(pv.size());
      Vec3 out = centre - axis;
      out.y = 0;
      const float sign = dot(normal, out) < 0 ? -1.0f : 1.0f;  // away from the body's axis
      PanelFit& fit = fits[first_fit + size_t(p - int(g.first_panel))];
      const float step = 0.005f;
      for (float d = step; std::fabs(fit.moved) + d <= float(kMaxClearMove) + 1e-6f; d += step) {
        const Vec3 move = normal * (sign * d);
        if (!clear(pv, pt, move)) continue;
        std::vector<Vec3> x = m.initial_positions;
        for (uint32_t i : pv) x[i] += move;
        if (panels_cross(m, x, uint32_t(pa), uint32_t(pb))) continue;
        if (touch && panels_touch(m, x, uint32_t(pa), uint32_t(pb), gap, outline, sewn_to)) continue;
        m.initial_positions = x;
        fit.moved += sign * d;
        parted = true;
        break;
      }
      if (parted) break;
    }
    if (!parted) return;
  }
}

}  // namespace

BodyFrame body_frame(const ObstacleSet& obstacles, size_t oi, const std::vector<Vec3>& posed, const Float3& front) {
  BodyFrame f;
  const Vec3 fr = make_vec3(front[0], 0, front[2]);
  f.front = fr / length(fr);
  f.side = cross(kUp, f.front);
  const uint32_t v0 = obstacles.first_vertex[oi], nv = uint32_t(obstacles.local[oi].vertices.size());
  double lo = INFINITY, hi = -INFINITY;
  for (uint32_t v = v0; v < v0 + nv; ++v) lo = std::min(lo, double(posed[v].y)), hi = std::max(hi, double(posed[v].y));
  f.floor = lo, f.height = hi - lo;
  const Body b = obstacle_body(obstacles, oi, posed);
  double best = INFINITY;
  f.neck = lo + kGarmentCodeNeck / kGarmentCodeHeight * f.height;  // where no section is found
  for (double h = lo + 0.80 * f.height; h <= lo + 0.92 * f.height; h += 0.0025) {
    const Section s = section(b, h, f);
    if (!s.empty() && s.side_hi - s.side_lo < best) best = s.side_hi - s.side_lo, f.neck = h;
  }
  return f;
}

std::vector<PanelFit> fit_garments(ClothModel& m, const ObstacleSet& obstacles, const SceneDef& scene) {
  std::vector<PanelFit> fits;
  if (scene.garment_fits.empty()) return fits;
  std::vector<Vec3> posed, velocities;
  obstacles.pose_at(0.0, posed, velocities);
  const float clearance = 2.0f * scene.collision.thickness;
  for (const GarmentFitDef& g : scene.garment_fits) {
    size_t oi = 0;
    while (oi < obstacles.names.size() && obstacles.names[oi] != g.body) ++oi;
    if (oi == obstacles.names.size()) throw InputError(scene.source, g.field + "/body", "no obstacle named '" + g.body + "'");
    const BodyFrame f = body_frame(obstacles, oi, posed, obstacles.defs[oi].front);
    const Body body = obstacle_body(obstacles, oi, posed);

    // The garment's vertices, in the pattern's frame.
    std::vector<uint32_t> ids;
    for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p)
      for (uint32_t i = 0; i < m.pieces[p].vertex_count; ++i) ids.push_back(m.pieces[p].first_vertex + i);
    double top = -INFINITY;
    for (uint32_t i : ids) top = std::max(top, double(m.initial_positions[i].y));
    // The older generator's templates are placed around a body whose waist is at y = 0 (their tops
    // reach 0.3 to 0.7 m, trousers' hems -1.05 m): lifted by GarmentCode's waist height first.
    if (top < kOlderFrameTop) {
      for (uint32_t i : ids) m.initial_positions[i].y += float(kGarmentCodeWaist);
      top += kGarmentCodeWaist;
    }
    const bool by_neck = top > 1.30;
    const double scale = f.height / kGarmentCodeHeight;
    const double anchor_gc = by_neck ? kGarmentCodeNeck : kGarmentCodeWaist;
    const double anchor_body = by_neck ? f.neck : f.neck - (kGarmentCodeNeck - kGarmentCodeWaist) * scale;
    // The middles of the garment and of the body over a band of heights below the anchor.
    double gx_lo = INFINITY, gx_hi = -INFINITY, gz_lo = INFINITY, gz_hi = -INFINITY;
    for (uint32_t i : ids) {
      const Vec3 p = m.initial_positions[i];
      if (p.y < anchor_gc - 0.35 || p.y > anchor_gc - 0.05) continue;
      gx_lo = std::min(gx_lo, double(p.x)), gx_hi = std::max(gx_hi, double(p.x));
      gz_lo = std::min(gz_lo, double(p.z)), gz_hi = std::max(gz_hi, double(p.z));
    }
    if (!(gx_hi >= gx_lo)) gx_lo = gx_hi = gz_lo = gz_hi = 0;
    Section band;
    for (double h = anchor_body - 0.35 * scale; h <= anchor_body - 0.05 * scale; h += 0.01) {
      const Section s = section(body, h, f);
      if (s.empty()) continue;
      band.side_lo = std::min(band.side_lo, s.side_lo), band.side_hi = std::max(band.side_hi, s.side_hi);
      band.front_lo = std::min(band.front_lo, s.front_lo), band.front_hi = std::max(band.front_hi, s.front_hi);
    }
    const double side_mid = band.empty() ? 0.0 : 0.5 * (band.side_lo + band.side_hi);
    const double front_mid = band.empty() ? 0.0 : 0.5 * (band.front_lo + band.front_hi);
    const Vec3 garment_mid = make_vec3(float(0.5 * (gx_lo + gx_hi)), float(anchor_gc), float(0.5 * (gz_lo + gz_hi)));
    const Vec3 body_mid = f.side * float(side_mid) + f.front * float(front_mid) + kUp * float(anchor_body);
    // Pattern x, y, z to the body's side, up and front, then the user's turn and move.
    const double turn = double(g.rotation) * M_PI / 180.0;
    const float ct = float(std::cos(turn)), st = float(std::sin(turn));
    const Vec3 side = f.side * ct - f.front * st, front = f.front * ct + f.side * st;
    const Vec3 move = make_vec3(g.position[0], g.position[1], g.position[2]);
    for (uint32_t i : ids) {
      const Vec3 d = m.initial_positions[i] - garment_mid;
      m.initial_positions[i] = body_mid + side * d.x + kUp * d.y + front * d.z + move;
    }
    if (!g.clear) continue;

    // Clearance, panel by panel, then panels that cross or overlap each other parted. False where a panel
    // cannot be cleared (the reason in *refusal).
    const TriangleGrid grid(body, 0.03f, clearance);
    CheckMesh body_mesh;
    body_mesh.vertices = posed;
    body_mesh.triangles = body.tris;
    const size_t first_fit = fits.size();
    auto place = [&](const std::vector<float>& stretch, std::string& refusal) {
      // Each panel's mean normal.
      std::vector<Vec3> normals(g.num_panels);
      for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p) {
        std::vector<uint32_t> pv, pt;
        normals[p - g.first_panel] = panel_geometry(m, m.pieces[p], pv, pt);
      }
      for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p) {
        const Piece& piece = m.pieces[p];
        std::vector<uint32_t> pv, pt;
        const Vec3 normal = panel_geometry(m, piece, pv, pt);
        const float step = 0.005f;
        float moved = 0;
        bool clear = false;
        for (float d = 0; d <= float(kMaxClearMove) + 1e-6f && !clear; d += step)
          for (float sign : {1.0f, -1.0f}) {
            if (panel_clear(m, pv, pt, normal * (sign * d), body, grid, body_mesh, clearance)) {
              moved = sign * d, clear = true;
              break;
            }
            if (d == 0) break;
          }
        if (!clear) {
          refusal = fmt::format("panel '{}' starts inside or through obstacle '{}', and moving it up to {:g} m "
                                "either way along its normal did not clear it by {:g} m; place the garment "
                                "with position or the panel with panels.<name>.offset",
                                piece.name, g.body, kMaxClearMove, double(clearance));
          return false;
        }
        // A panel moved to clear the body may have gone through it (GarmentCodeData's rand_1KMN65OI4O:
        // a cuff flounce over the hand moved behind it, the sleeve's edge it is sewn to in front; the
        // stitches, drawn together through the wrist, left the seam 6 cm open): where some of its
        // stitches to panels facing its way then start through the body, the first clear place the
        // other way is taken if fewer do there. (A sleeve's front and back face apart: their stitches
        // go round the arm, and are not counted.)
        auto same_way = [&](uint32_t v) {
          const uint32_t q = uint32_t(&m.piece_of(v) - m.pieces.data());
          return q >= g.first_panel && q < g.first_panel + g.num_panels && dot(normals[q - g.first_panel], normal) > 0;
        };
        if (moved != 0)
          if (const size_t through = stitches_through_body(m, pv, normal * moved, body, grid, same_way); through > 0)
            for (float d = step; d <= float(kMaxClearMove) + 1e-6f; d += step) {
              const float other = moved > 0 ? -d : d;
              if (!panel_clear(m, pv, pt, normal * other, body, grid, body_mesh, clearance)) continue;
              if (stitches_through_body(m, pv, normal * other, body, grid, same_way) < through) moved = other;
              break;
            }
        for (uint32_t i : pv) m.initial_positions[i] += normal * moved;
        const float st = stretch[p - g.first_panel];
        fits.push_back({piece.name, moved, st > 0, std::max(st, 1.0f)});
      }
      separate_panels(m, g, fits, first_fit, body_mid, scene.collision.thickness,
                      [&](const std::vector<uint32_t>& pv, const std::vector<uint32_t>& pt, Vec3 move) {
        return panel_clear(m, pv, pt, move, body, grid, body_mesh, clearance);
      });
      return true;
    };
    // Panels narrower than the legs' stance are first wrapped around them. Where the wrapped garment
    // cannot be placed without a crossing (layers laid on one hull: a tiered skirt's flounce through
    // its skirt), it is placed flat, as if no panel had been wrapped.
    std::vector<uint32_t> garment_panels;
    for (uint32_t p = g.first_panel; p < g.first_panel + g.num_panels; ++p) garment_panels.push_back(p);
    const std::vector<Vec3> flat = m.initial_positions;
    std::vector<float> stretched =
        wrap_for_stance(m, garment_panels, body, f, side_mid, front_mid, clearance + float(kStanceMargin),
                        f.neck - (kGarmentCodeNeck - kGarmentCodeWaist) * scale + kWrapAboveWaist);
    std::string refusal;
    bool placed = place(stretched, refusal);
    if (std::any_of(stretched.begin(), stretched.end(), [](float w) { return w > 0; }) &&
        (!placed || crossings_among(m, m.initial_positions, garment_panels) > 0)) {
      m.initial_positions = flat;
      fits.resize(first_fit);
      stretched.assign(stretched.size(), 0.0f);
      placed = place(stretched, refusal);
    }
    if (!placed) throw InputError(scene.source, g.field, refusal);
  }
  // Seam partners follow their representatives; the springs start from the new lengths.
  for (uint32_t i = 0; i < m.num_vertices(); ++i) m.initial_positions[i] = m.initial_positions[m.alias[i]];
  if (m.sew_time > 0) {
    for (Spring& sp : m.springs) sp.rest_start = length(m.initial_positions[sp.b] - m.initial_positions[sp.a]);
    build_adjacency(m);
  }
  return fits;
}

}  // namespace raycloth
