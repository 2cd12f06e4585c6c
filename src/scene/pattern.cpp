#include "scene/pattern.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Constrained_triangulation_plus_2.h>
#include <CGAL/Delaunay_mesh_face_base_2.h>
#include <CGAL/Delaunay_mesh_size_criteria_2.h>
#include <CGAL/Delaunay_mesh_vertex_base_2.h>
#include <CGAL/Delaunay_mesher_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2.h>

#include <cmath>
#include <map>
#include <set>

namespace raycloth {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Delaunay_mesh_vertex_base_2<K>;
using Fb = CGAL::Delaunay_mesh_face_base_2<K>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<K, Tds, CGAL::Exact_predicates_tag>;
using CdtPlus = CGAL::Constrained_triangulation_plus_2<Cdt>;
using Criteria = CGAL::Delaunay_mesh_size_criteria_2<CdtPlus>;
using P2 = std::array<double, 2>;

// More vertices than this in one pattern piece is refused (the estimate is area / edge_length^2).
constexpr double kMaxPatternVertices = double(1 << 22);

P2 lerp(const P2& a, const P2& b, double t) { return {a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t}; }
double dist(const P2& a, const P2& b) { return std::hypot(b[0] - a[0], b[1] - a[1]); }
P2 p2(const std::array<float, 2>& a) { return {double(a[0]), double(a[1])}; }

// A segment from a to b (a line, a quadratic or cubic Bezier, or a circular arc) as a fine polyline.
std::vector<P2> fine_curve(const P2& a, const P2& b, const OutlineSegment& seg) {
  if (!seg.control && !seg.arc) return {a, b};
  std::vector<P2> pts;
  constexpr int kFine = 256;
  if (seg.arc) {
    const double chord = dist(a, b);
    const double r = std::max(double(seg.arc->radius), 0.5 * chord);
    // Centre on the chord's bisector: left of the direction of travel for a small counter-clockwise
    // arc or a large clockwise one.
    const P2 mid = lerp(a, b, 0.5);
    const P2 left = {-(b[1] - a[1]) / chord, (b[0] - a[0]) / chord};
    const double h = std::sqrt(std::max(0.0, r * r - 0.25 * chord * chord));
    const double side = (seg.arc->ccw != seg.arc->large) ? 1.0 : -1.0;
    const P2 c = {mid[0] + side * h * left[0], mid[1] + side * h * left[1]};
    const double t0 = std::atan2(a[1] - c[1], a[0] - c[0]);
    double sweep = std::atan2(b[1] - c[1], b[0] - c[0]) - t0;
    if (seg.arc->ccw) {
      while (sweep <= 0) sweep += 2 * M_PI;
    } else {
      while (sweep >= 0) sweep -= 2 * M_PI;
    }
    for (int i = 0; i <= kFine; ++i) {
      const double t = t0 + sweep * double(i) / kFine;
      pts.push_back({c[0] + r * std::cos(t), c[1] + r * std::sin(t)});
    }
    pts.front() = a;
    pts.back() = b;
    return pts;
  }
  const P2 c = p2(*seg.control);
  for (int i = 0; i <= kFine; ++i) {
    const double t = double(i) / kFine;
    if (seg.control2) {
      const P2 d = p2(*seg.control2);
      const P2 ab = lerp(a, c, t), bc = lerp(c, d, t), cd = lerp(d, b, t);
      pts.push_back(lerp(lerp(ab, bc, t), lerp(bc, cd, t), t));
    } else {
      pts.push_back(lerp(lerp(a, c, t), lerp(c, b, t), t));
    }
  }
  return pts;
}

// Points along a fine polyline at n equal arc-length steps, from its start up to (excluding) its end.
std::vector<P2> resample(const std::vector<P2>& fine, int n) {
  std::vector<double> s(fine.size(), 0.0);
  for (size_t i = 1; i < fine.size(); ++i) s[i] = s[i - 1] + dist(fine[i - 1], fine[i]);
  std::vector<P2> out;
  size_t k = 1;
  for (int i = 0; i < n; ++i) {
    const double target = s.back() * double(i) / double(n);
    while (k + 1 < fine.size() && s[k] < target) ++k;
    const double span = s[k] - s[k - 1];
    out.push_back(span > 0 ? lerp(fine[k - 1], fine[k], (target - s[k - 1]) / span) : fine[k - 1]);
  }
  return out;
}

double fine_length(const std::vector<P2>& fine) {
  double l = 0;
  for (size_t i = 1; i < fine.size(); ++i) l += dist(fine[i - 1], fine[i]);
  return l;
}

// The share of the edge length below which an outline segment is merged into a point: its two
// ends become one, at the centre of the corners it joined (with every short segment next to it).
// CGAL's mesher refines towards every constrained segment, so a segment far shorter than the edge
// length leaves a fan of tiny triangles at its corner: GarmentCodeData's rand_2CRQTA16NZ has two of
// 0.45 mm and two of 0.75 mm (strap tops), which gave sub-millimetre edges and vertices of a
// hundredth of the mean mass; GarmentCode's jumpsuit has ten of 0.9 to 1.8 mm where its trousers meet
// its torso. On a walking body such a corner, crushed against its own seam, held the vertices beside
// it in the displacement bound's planes (sim/bound.h) while the body moved on through them.
constexpr double kMinSegmentShare = 0.2;

// Merges the outline's short segments (kMinSegmentShare) into points, moving the corners they join
// to their centre: which segments are points now. None is merged where fewer than 3 would be left.
std::vector<char> merge_short_segments(PatternDef& p) {
  const size_t n = p.outline.size();
  std::vector<char> point(n, 0);
  const double least = kMinSegmentShare * double(p.edge_length);
  size_t kept = n;
  for (size_t k = 0; k < n; ++k) {
    const OutlineSegment& seg = p.outline[k];
    if (fine_length(fine_curve(p2(seg.from), p2(p.outline[(k + 1) % n].from), seg)) < least) point[k] = 1, --kept;
  }
  if (kept == n || kept < 3) return std::vector<char>(n, 0);
  // Runs of corners joined by merged segments, each from a corner whose segment before it is kept
  // (the runs share no corner, so each reads its corners before any run moves them).
  for (size_t c = 0; c < n; ++c) {
    if (point[(c + n - 1) % n] || !point[c]) continue;
    std::vector<size_t> run{c};
    while (point[run.back()]) run.push_back((run.back() + 1) % n);
    double x = 0, y = 0;
    for (size_t k : run) x += double(p.outline[k].from[0]), y += double(p.outline[k].from[1]);
    const std::array<float, 2> centre{float(x / double(run.size())), float(y / double(run.size()))};
    for (size_t k : run) p.outline[k].from = centre;
  }
  return point;
}

}  // namespace

std::vector<std::vector<P2>> sample_outline(const PatternDef& pattern) {
  const size_t n = pattern.outline.size();
  std::vector<std::vector<P2>> out(n);
  for (size_t k = 0; k < n; ++k) {
    const OutlineSegment& seg = pattern.outline[k];
    const auto fine = fine_curve(p2(seg.from), p2(pattern.outline[(k + 1) % n].from), seg);
    const int pieces = std::max(1, int(std::ceil(fine_length(fine) / double(pattern.edge_length) - 1e-9)));
    out[k] = resample(fine, pieces);
  }
  return out;
}

std::vector<P2> fine_outline(const PatternDef& pattern) {
  const size_t n = pattern.outline.size();
  std::vector<P2> out;
  for (size_t k = 0; k < n; ++k) {
    const auto fine = fine_curve(p2(pattern.outline[k].from), p2(pattern.outline[(k + 1) % n].from), pattern.outline[k]);
    out.insert(out.end(), fine.begin(), fine.end() - 1);
  }
  return out;
}

bool outline_is_simple(const PatternDef& pattern) {
  CGAL::Polygon_2<K> polygon;
  for (const P2& p : fine_outline(pattern)) polygon.push_back(K::Point_2(p[0], p[1]));
  return polygon.size() >= 3 && polygon.is_simple();
}

PatternMesh mesh_pattern(const PatternDef& pattern,
                         const std::function<void(const std::string&, const std::string&)>& fail) {
  const size_t n = pattern.outline.size();
  if (n < 3) fail("outline", "needs at least 3 segments (got " + std::to_string(n) + ")");
  if (!(std::isfinite(pattern.edge_length) && pattern.edge_length > 0))
    fail("edge_length", "must be a positive number of metres");
  if (pattern.wrap_radius && !(std::isfinite(*pattern.wrap_radius) && *pattern.wrap_radius > 0))
    fail("wrap_radius", "must be a positive number of metres");
  std::set<std::string> names;
  for (size_t k = 0; k < n; ++k) {
    const OutlineSegment& seg = pattern.outline[k];
    const std::string f = "outline/" + std::to_string(k);
    if (!std::isfinite(seg.from[0]) || !std::isfinite(seg.from[1])) fail(f + "/from", "must be finite");
    if (seg.control && (!std::isfinite((*seg.control)[0]) || !std::isfinite((*seg.control)[1])))
      fail(f + "/control", "must be finite");
    if (seg.control2 && !seg.control) fail(f + "/control2", "a cubic segment needs control as well");
    if (seg.control2 && (!std::isfinite((*seg.control2)[0]) || !std::isfinite((*seg.control2)[1])))
      fail(f + "/control2", "must be finite");
    if (seg.arc && seg.control) fail(f + "/arc", "a segment is a curve (control) or an arc, not both");
    if (seg.arc && !(std::isfinite(seg.arc->radius) && seg.arc->radius > 0))
      fail(f + "/arc/radius", "must be a positive number of metres");
    if (!seg.name.empty() && !names.insert(seg.name).second)
      fail(f + "/name", "duplicate segment name '" + seg.name + "'");
    if (dist(p2(seg.from), p2(pattern.outline[(k + 1) % n].from)) < 1e-9)
      fail(f + "/from", "the segment has no length (it starts where the next one does)");
  }
  // Short segments become points (kMinSegmentShare); the rest is meshed from `merged`.
  PatternDef merged = pattern;
  const std::vector<char> point = merge_short_segments(merged);
  // The outline as a fine polygon: it must be simple (no crossing, no touching), and its area
  // bounds the vertex count.
  CGAL::Polygon_2<K> polygon;
  double perimeter = 0;
  for (size_t k = 0; k < n; ++k) {
    if (point[k]) continue;
    const auto fine = fine_curve(p2(merged.outline[k].from), p2(merged.outline[(k + 1) % n].from),
                                 merged.outline[k]);
    perimeter += fine_length(fine);
    for (size_t i = 0; i + 1 < fine.size(); ++i) polygon.push_back(K::Point_2(fine[i][0], fine[i][1]));
  }
  const double e = double(pattern.edge_length);
  const double estimate = std::abs(CGAL::to_double(polygon.area())) / (0.43 * e * e) + perimeter / e;
  if (!(estimate < kMaxPatternVertices))
    fail("edge_length", "an edge length of " + std::to_string(e) + " m gives about " +
                            std::to_string(int64_t(std::min(estimate, 1e15))) + " vertices, more than " +
                            std::to_string(int64_t(kMaxPatternVertices)) + "; make it longer");
  if (!polygon.is_simple()) fail("outline", "the outline crosses or touches itself");

  const auto samples = sample_outline(merged);
  CdtPlus cdt;
  std::vector<CdtPlus::Constraint_id> ids(n);
  for (size_t k = 0; k < n; ++k) {
    if (point[k]) continue;
    std::vector<K::Point_2> pts;
    for (const P2& p : samples[k]) pts.emplace_back(p[0], p[1]);
    const P2& end = samples[(k + 1) % n].front();
    pts.emplace_back(end[0], end[1]);
    ids[k] = cdt.insert_constraint(pts.begin(), pts.end());
  }
  // Triangles with no angle under ~20.7 degrees (B = 0.125) and no edge longer than 1.2 edge lengths.
  CGAL::refine_Delaunay_mesh_2(cdt, Criteria(0.125, 1.2 * e));

  PatternMesh m;
  std::map<CdtPlus::Vertex_handle, uint32_t> index;
  auto id = [&](CdtPlus::Vertex_handle v) {
    auto [it, inserted] = index.emplace(v, uint32_t(m.points.size()));
    if (inserted) m.points.push_back({v->point().x(), v->point().y()});
    return it->second;
  };
  // Number vertices along the outline first (in order), then the interior ones as faces meet them.
  for (size_t k = 0; k < n; ++k) {
    std::vector<uint32_t> path;
    if (!point[k])
      for (auto it = cdt.vertices_in_constraint_begin(ids[k]); it != cdt.vertices_in_constraint_end(ids[k]); ++it)
        path.push_back(id(*it));
    m.segments.push_back(std::move(path));
  }
  // A segment merged into a point is that one vertex: where the next kept segment starts.
  for (size_t k = 0; k < n; ++k) {
    if (!point[k]) continue;
    size_t j = (k + 1) % n;
    while (point[j]) j = (j + 1) % n;
    m.segments[k] = {m.segments[j].front()};
  }
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    if (!f->is_in_domain()) continue;
    for (int c = 0; c < 3; ++c) m.triangles.push_back(id(f->vertex(c)));
  }
  if (m.triangles.empty()) fail("outline", "the outline encloses no area");
  return m;
}

}  // namespace raycloth
