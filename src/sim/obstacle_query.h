// Queries of the obstacles at t + dt that stages share: the nearest surface point to a point (with
// the faces it lies straight under), and the body's own gap in front of a surface point.
#pragma once
#include <cstdint>

#include "sim/step_view.h"

namespace raycloth {

// The nearest point of the obstacles (at t + dt) to p within `reach`. Among triangles equally near
// (p nearest to a shared edge or vertex) the one whose plane p lies most squarely in front of or
// behind wins, so that the side (inside or outside) is read off the right face; then the lowest id.
struct ObstaclePoint {
  bool found = false;
  uint32_t prim = 0;
  DVec3 point;
  double dist2 = 0;
  double squareness = -1;  // |cos| between the face normal and p - point
  double wa = 1, wb = 0, wc = 0;
  // Faces p lies straight under (behind the face's plane, p - point along its normal) within
  // reach: on a body of overlapping layers (clothes over skin) the nearest surface can be an inner
  // layer while p is also under an outer one. Up to kUnderFaces of them, in the order found.
  uint32_t num_under = 0;
  uint32_t under[4] = {0, 0, 0, 0};
};

inline constexpr uint32_t kUnderFaces = 4;

// With `look` above reach and `nearest2` given, the faces within `look` are visited too, and
// *nearest2 becomes the squared distance to the nearest of them (infinite where none is); the point
// returned is the same as without.
RC_HD ObstaclePoint nearest_obstacle_point(const StepView& s, Vec3 p, float reach, float look = 0.0f,
                                           double* nearest2 = nullptr) {
  ObstaclePoint best;
  const Vec3* ov = s.geom.obstacle_vertices;
  const uint32_t* oi = s.geom.obstacle_indices;
  const DVec3 dp = dvec(p);
  Aabb query = aabb_grow(point_box(p), nearest2 ? fmaxf(reach, look) : reach);
  double limit2 = double(reach) * double(reach);
  if (nearest2) *nearest2 = INFINITY;
  bvh_for_each_overlap(s.obstacle_bvh, query, [&](uint32_t t) {
    const DVec3 a = dvec(ov[oi[3 * t]]), b = dvec(ov[oi[3 * t + 1]]), c = dvec(ov[oi[3 * t + 2]]);
    const TrianglePoint q = closest_on_triangle(dp, a, b, c);
    if (nearest2 && q.dist2 < *nearest2) *nearest2 = q.dist2;
    if (q.dist2 > limit2) return;
    const DVec3 point = a * q.wa + b * q.wb + c * q.wc;
    const DVec3 e1 = b - a, e2 = c - a;
    const DVec3 n{e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
    const DVec3 d = dp - point;
    const double nn = ddot(n, n), dd = ddot(d, d);
    const double square = nn > 0.0 && dd > 0.0 ? fabs(ddot(n, d)) / sqrt(nn * dd) : 0.0;
    const double tie = 1e-12 + 1e-9 * q.dist2;
    if (ddot(n, d) < 0.0 && square > 1.0 - 1e-6 && best.num_under < kUnderFaces) best.under[best.num_under++] = t;
    bool take = !best.found || q.dist2 < best.dist2 - tie;
    if (!take && q.dist2 <= best.dist2 + tie)
      take = square > best.squareness + 1e-12 || (square >= best.squareness - 1e-12 && t < best.prim);
    if (!take) return;
    best.found = true;
    best.prim = t;
    best.point = point;
    best.dist2 = q.dist2;
    best.squareness = square;
    best.wa = q.wa, best.wb = q.wb, best.wc = q.wc;
  });
  return best;
}

// Accepts an obstacle face that a ray along `dir` enters from its front side (not `skip`, the face
// the ray leaves from).
struct EnteredFromFront {
  const Vec3* vertices;
  const uint32_t* indices;
  Vec3 dir;
  uint32_t skip;
  RC_HD bool operator()(uint32_t prim) const {
    return prim != skip && dot(triangle_normal(vertices, indices, prim), dir) < 0.0f;
  }
};

// The body's own gap in front of a surface point: the distance along the outward direction `out`
// to the first obstacle face it enters from the front (another part of the body, or another
// body), or `reach` when there is none within it. The same measure as the exact check's pinch.
RC_HD float pinch_gap_along(const StepView& s, Vec3 from, Vec3 out, float reach, uint32_t skip) {
  Ray ray;
  ray.org = from;
  ray.dir = out;
  ray.tmax = reach;
  const EnteredFromFront front{s.geom.obstacle_vertices, s.geom.obstacle_indices, out, skip};
  const RawHit hit = trace_nearest(s.obstacle_bvh, s.geom.obstacle_vertices, s.geom.obstacle_indices, ray, front,
                                   kHitObstacle);
  return hit.kind == kHitNone ? reach : hit.t;
}

// ---- Where the body's parts overlap ---------------------------------------------------------------
// A skinned body passes into itself where it bends (his upper arm into his torso at the armpit): a
// surface of one part then lies inside another, and a point pushed the thickness out of the nearest
// face can still be inside the body. What is outside is read off rays: the obstacles' winding number
// about p along a ray is the sum, over the faces the ray crosses, of +1 where it leaves through a
// face's back and -1 where it enters through a front (the caps close the openings, sim/holes). It is
// 0 outside every part; inside, +1 or more, or -1 in a pocket where a part folds through itself
// inside out (his shirt at his hip): inside too, as for the exact check (|w| >= 1/2). A ray through
// a shared edge may count a face twice, and an opening left open miscounts, so a point is taken as
// inside only where at least two of three rays say so.

// Counts one crossing of the ray along `dir` and rejects the face, so that the ray goes on through
// every face to the end.
struct CountCrossing {
  const Vec3* vertices;
  const uint32_t* indices;
  Vec3 dir;
  int* winding;
  RC_HD bool operator()(uint32_t prim) const {
    *winding += dot(triangle_normal(vertices, indices, prim), dir) > 0.0f ? 1 : -1;
    return false;
  }
};

// The obstacles' winding number about p read off the ray along `dir`.
RC_HD int winding_along(const StepView& s, Vec3 p, Vec3 dir) {
  int winding = 0;
  Ray ray;
  ray.org = p;
  ray.dir = dir;
  ray.tmax = 1e30f;
  const CountCrossing count{s.geom.obstacle_vertices, s.geom.obstacle_indices, dir, &winding};
  trace_nearest(s.obstacle_bvh, s.geom.obstacle_vertices, s.geom.obstacle_indices, ray, count, kHitObstacle);
  return winding;
}

// Two directions of no particular axis, for the second and third rays. Both point up (+y, against
// gravity in every shipped scene): an open floor (a plane obstacle, one sheet with no inside) under
// the cloth gives -1 to any ray through it alone, and a push out of a body's underside points down
// through it; two rays up keep such a push outside by two of three (Overlap.ClothOverABallAboveAnOpenFloor*).
RC_HD Vec3 other_ray_direction(int k) {
  return k == 0 ? make_vec3(0.5377f, 0.8315f, 0.1392f) : make_vec3(-0.6247f, 0.2914f, 0.7245f);
}

// Whether p is inside the obstacles (the union of the body's parts): two of three rays, the first
// along `dir`, say so.
RC_HD bool inside_parts(const StepView& s, Vec3 p, Vec3 dir) {
  int inside = winding_along(s, p, dir) != 0 ? 1 : 0;
  for (int k = 0; k < 2 && inside < 2 && inside + (2 - k) >= 2; ++k)
    inside += winding_along(s, p, other_ray_direction(k)) != 0 ? 1 : 0;
  return inside >= 2;
}

// The same for a push out of the nearest surface along `dir`: where the ray along the push leaves
// every part (nearly every push) it is taken as outside at once, with one ray; otherwise one of the
// two others must say inside too.
RC_HD bool push_inside_parts(const StepView& s, Vec3 p, Vec3 dir) {
  if (winding_along(s, p, dir) == 0) return false;
  return winding_along(s, p, other_ray_direction(0)) != 0 || winding_along(s, p, other_ray_direction(1)) != 0;
}

// How far (metres) a vertex pushed into another part of the body looks for the nearest way out, and
// how many of the nearest candidates it tries.
inline constexpr float kOverlapExitRadius = 0.05f;
inline constexpr int kOverlapExitTries = 32;

// A way out of the body where its parts overlap: the point `offset` in front of the face nearest to
// p among those whose point there is outside every part.
struct OverlapExit {
  bool found = false;
  uint32_t prim = 0;
  Vec3 point;
  Vec3 normal;
  double wa = 1, wb = 0, wc = 0;
};

// The nearest way out of the body from p: each obstacle face within kOverlapExitRadius offers the
// point `offset` in front of its point nearest to p; the kOverlapExitTries nearest offers are tried in
// order of distance (ties: the lower face), and the first outside every part (inside_parts) is taken.
RC_HD OverlapExit overlap_exit(const StepView& s, Vec3 p, float offset) {
  const Vec3* ov = s.geom.obstacle_vertices;
  const uint32_t* oi = s.geom.obstacle_indices;
  const DVec3 dp = dvec(p);
  // The nearest offers so far, nearest first (a face and its offer's squared distance): a few
  // hundred bytes, so that the GPU's per-thread stack stays small; the points are found again below.
  uint32_t face[kOverlapExitTries] = {};
  double dist2[kOverlapExitTries] = {};
  int count = 0;
  auto offer_of = [&](uint32_t t, TrianglePoint& q) {
    const DVec3 a = dvec(ov[oi[3 * t]]), b = dvec(ov[oi[3 * t + 1]]), c = dvec(ov[oi[3 * t + 2]]);
    q = closest_on_triangle(dp, a, b, c);
    return a * q.wa + b * q.wb + c * q.wc + dvec(triangle_normal(ov, oi, t)) * double(offset);
  };
  Aabb query = aabb_grow(point_box(p), kOverlapExitRadius + offset);
  bvh_for_each_overlap(s.obstacle_bvh, query, [&](uint32_t t) {
    TrianglePoint q;
    const DVec3 offer = offer_of(t, q);
    if (q.dist2 > double(kOverlapExitRadius) * double(kOverlapExitRadius)) return;
    const double d2 = ddot(offer - dp, offer - dp);
    auto nearer = [&](int k) { return d2 < dist2[k] || (d2 == dist2[k] && t < face[k]); };
    if (count == kOverlapExitTries && !nearer(kOverlapExitTries - 1)) return;
    int k = count < kOverlapExitTries ? count++ : kOverlapExitTries - 1;
    for (; k > 0 && nearer(k - 1); --k) face[k] = face[k - 1], dist2[k] = dist2[k - 1];
    face[k] = t, dist2[k] = d2;
  });
  OverlapExit e;
  for (int k = 0; k < count; ++k) {
    TrianglePoint q;
    const DVec3 o = offer_of(face[k], q);
    const Vec3 offer = make_vec3(float(o.x), float(o.y), float(o.z));
    const Vec3 n = triangle_normal(ov, oi, face[k]);
    if (inside_parts(s, offer, n)) continue;
    e.found = true;
    e.prim = face[k];
    e.point = offer;
    e.normal = n;
    e.wa = q.wa, e.wb = q.wb, e.wc = q.wc;
    break;
  }
  return e;
}

}  // namespace raycloth
