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

RC_HD ObstaclePoint nearest_obstacle_point(const StepView& s, Vec3 p, float reach) {
  ObstaclePoint best;
  const Vec3* ov = s.geom.obstacle_vertices;
  const uint32_t* oi = s.geom.obstacle_indices;
  const DVec3 dp = dvec(p);
  Aabb query = aabb_grow(point_box(p), reach);
  double limit2 = double(reach) * double(reach);
  bvh_for_each_overlap(s.obstacle_bvh, query, [&](uint32_t t) {
    const DVec3 a = dvec(ov[oi[3 * t]]), b = dvec(ov[oi[3 * t + 1]]), c = dvec(ov[oi[3 * t + 2]]);
    const TrianglePoint q = closest_on_triangle(dp, a, b, c);
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

}  // namespace raycloth
