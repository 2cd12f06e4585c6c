// The displacement bound: what keeps cloth from ever crossing cloth (docs/collision.md, step 5).
// Every free vertex lives in a ball around where it was at the last refresh, of radius kBoundFactor
// of its distance then to the nearest cloth feature it shares no vertex with; the clamp keeps it
// there, so two features that were apart cannot meet. Here: the constants, the decision to refresh
// (none, partial, full), the refresh itself (per triangle, on the cloth's LBVH), the clamp, and the
// further passes of a step whose pushed vertices the clamp held back. The sequence is in sim/step.h.
#pragma once
#include <cstdint>
#include <vector>

#include "sim/stages.h"

namespace raycloth {

// The share of the distance to the nearest non-adjacent feature that a vertex may move in one step.
// Two features each move at most this share, so below 1/2 they cannot meet; 0.4 leaves 20 % of the
// gap for rounding (distances are computed in double from the float positions).
inline constexpr float kBoundFactor = 0.4f;
// Absolute slack taken off every bound (metres): covers float rounding of the new position.
inline constexpr float kBoundSlack = 1e-6f;
// On a refresh each vertex looks for features within kBoundLookahead of its current move (scaled
// by 1/kBoundFactor), at least kBoundMinRadius and at most kBoundMaxRadius mean cloth edges: a
// bound that lasts this many steps at the present speed before the next refresh.
inline constexpr float kBoundLookahead = 8.0f;
inline constexpr float kBoundMinRadius = 0.05f;
inline constexpr float kBoundMaxRadius = 1.5f;
inline constexpr uint32_t kBoundMaxAge = 8;
inline constexpr uint32_t kBoundCrowd = 16;
// With the swept bound (StepView::swept, sim/swept_bound.h) a vertex its ball cannot hold is checked
// over the step, not held back: the balls are refreshed in full only when a quarter of the vertices
// want more room or the last refresh is kSweptMaxAge steps old, and never in part.
inline constexpr uint32_t kSweptCrowd = 4;
inline constexpr uint32_t kSweptMaxAge = 32;
inline constexpr float kBoundNear = 0.25f;

// Planes instead of balls. A ball of kBoundFactor of a pair's distance, less the slack, lets two
// features that come within a few micrometres of each other (cloth pulled into a tight fold, the two
// sides of a seam folded back on each other) approach until the slack leaves their vertices no room
// at all: they stop where they are, for good, and a body moving on walks into them. A pair nearer
// than kBoundPlaneShare of the thickness (and farther than plane_min, above the rounding of float
// positions) gives its vertices planes instead: the two features are convex, so the plane
// through their closest points' midpoint, normal to the line between them, has the one on its one
// side and the other on its other; each vertex may move anywhere that does not take it towards the
// other side (measured from its ball's centre), so the two can never meet, and they may part at
// once (where a body moves or seams are sewn: StepView::bound_planes). The pair's distance then
// does not bound their balls. A vertex with more than kBoundPlanes planes keeps none of them: the
// nearest pair that gave one bounds its ball (plane_near), as without planes, whatever the order
// the pairs were found in.
inline constexpr float kBoundPlaneShare = 0.1f;
// How far behind one of its planes (metres) a vertex may end up after keep_to_planes rounds its
// position to float (farther: it goes back to x).
inline constexpr double kBoundPlaneRounding = 1e-7;
// The nearest pair that gets planes: each side has half of it to the plane between them, and may end
// up behind its own by kBoundPlaneRounding and then the rounding of the ball's clamp along its move
// (half a float ulp per coordinate: at most 1.03e-7 m along the plane's normal where every
// coordinate is under 2 m). 0.5 um leaves each side 0.25 um against those 0.2 um, where the pair's
// vertices are within kBoundPlaneNear of the origin; farther out, 2 um (the minimum everywhere until
// 0.5.2). Below it a ball of kBoundFactor of the distance less the slack is empty and the pair's
// vertices stand still: at 2 um, GarmentCodeData's rand_176L9DT8YW had two features of its top 1.6 um
// apart at the walking man's armpit from 2.76 s and the vertex between them stood still for over 500
// steps while his closing arm and torso moved through it (docs/collision.md, step 5).
inline constexpr double kBoundPlaneMin = 5e-7;
inline constexpr double kBoundPlaneMinFar = 2e-6;
inline constexpr float kBoundPlaneNear = 2.0f;

// The largest |coordinate| of a feature's vertices (v[0..n)) at their balls' centres.
RC_HD float farthest_coordinate(const StepView& s, const uint32_t* v, int n) {
  float m = 0.0f;
  for (int k = 0; k < n; ++k) {
    const Vec3 p = s.x_ref[v[k]];
    m = fmaxf(m, fmaxf(fabsf(p.x), fmaxf(fabsf(p.y), fabsf(p.z))));
  }
  return m;
}

// The nearest a pair of features (vertex lists a[0..na), b[0..nb)) may be and get planes.
RC_HD double plane_min(const StepView& s, const uint32_t* a, int na, const uint32_t* b, int nb) {
  const float m = fmaxf(farthest_coordinate(s, a, na), farthest_coordinate(s, b, nb));
  return m < kBoundPlaneNear ? kBoundPlaneMin : kBoundPlaneMinFar;
}

// The radius of vertex i's ball: kBoundFactor of the nearest non-adjacent distance at x_ref (or of
// the radius it was looked for within, when nothing was nearer), less the slack. Pairs that gave
// the vertex a plane are not among them, unless it has more planes than it keeps.
RC_HD float allowance_of(const StepView& s, uint32_t i) {
  float nearest = fminf(float_from_bits(s.bound[i]), s.bound_radius[i]);
  if (s.plane_count[i] > kBoundPlanes) nearest = fminf(nearest, float_from_bits(s.plane_near[i]));
  return fmaxf(0.0f, kBoundFactor * nearest - kBoundSlack);
}

// The planes vertex i keeps (0 when it has none, or more than it keeps), into n, in an order that
// does not depend on the order they were found in (the threads').
RC_HD uint32_t planes_of(const StepView& s, uint32_t i, Vec3* n) {
  const uint32_t count = s.plane_count[i];
  if (count == 0u || count > kBoundPlanes) return 0u;
  for (uint32_t k = 0; k < count; ++k) {
    const Vec3 p = s.planes[i].n[k];
    uint32_t j = k;
    for (; j > 0 && (p.x < n[j - 1].x || (p.x == n[j - 1].x && (p.y < n[j - 1].y || (p.y == n[j - 1].y && p.z < n[j - 1].z)))); --j)
      n[j] = n[j - 1];
    n[j] = p;
  }
  return count;
}

// Every vertex's planes (host): what the backends give Simulator::bound_balls.
inline void planes_by_vertex(const StepView& s, uint32_t n, std::vector<std::vector<Vec3>>& out) {
  out.assign(n, {});
  Vec3 dirs[kBoundPlanes];
  for (uint32_t i = 0; i < n; ++i) out[i].assign(dirs, dirs + planes_of(s, i, dirs));
}

// Whether position p of vertex i lies behind one of its planes.
RC_HD bool behind_a_plane(const StepView& s, uint32_t i, Vec3 p) {
  Vec3 n[kBoundPlanes];
  const uint32_t count = planes_of(s, i, n);
  const DVec3 d = dvec(p) - dvec(s.x_ref[i]);
  for (uint32_t k = 0; k < count; ++k)
    if (ddot(d, dvec(n[k])) < -kBoundPlaneRounding) return true;
  return false;
}

RC_HD bool is_free(const StepView& s, uint32_t i) {
  return is_representative(s.model, i) && s.model.inv_mass[i] != 0.0f;
}

// 1 when vertex i's proposed position leaves its ball.
RC_HD uint32_t stage_wants_refresh(const StepView& s, uint32_t i) {
  if (!is_free(s, i)) return 0u;
  const Vec3 x = s.x_next[i];
  if (!is_finite(x)) return 0u;
  return length(x - s.x_ref[i]) > allowance_of(s, i) || behind_a_plane(s, i, x) ? 1u : 0u;
}

// 1 when vertex i leaves a ball that a new bound would likely widen: one that its look-ahead
// radius set (nothing nearer was found), or one that a feature farther than kBoundNear mean edges
// set (its own panel's neighbours in a smooth region: they move with it). Such a vertex is marked
// for a partial refresh. Balls set by a feature nearer than that (a layer lying on it, a fold) wait
// for the next full refresh: the nearby feature's own ball holds the rest of their gap, so only a
// refresh of both sides gives them room. A vertex an obstacle pushed out from inside, or pushed
// hard, does not wait either: held in its old ball it could end inside the body before the next
// refresh. (Vertices merely kept at the thickness, cloth resting on a body, wait as before.)
RC_HD uint32_t stage_wants_refresh_now(const StepView& s, uint32_t i) {
  const float d = float_from_bits(s.bound[i]);
  // Pushed by a body, or by cloth a body pushed (the contact solve): held in its old ball it would
  // stop the push from going through the layers.
  const bool was_inside = (s.flags[i] & (kFlagInside | kFlagContact)) != 0u;
  if (!(was_inside || d >= fminf(s.bound_radius[i], kBoundNear * s.mean_edge)) || !stage_wants_refresh(s, i)) return 0u;
  s.flags[i] |= kFlagRefresh;
  return 1u;
}

// Whether and how this step recomputes the bound (one thread). All vertices (a full refresh) when
// more than 1/kBoundCrowd of them need more room, or when any does and the last full refresh is
// kBoundMaxAge steps old. Otherwise the marked vertices (a partial refresh, stage_bound) when there
// are any; the few vertices that want more room, all held by a nearby feature, stay in their balls
// (stage_clamp) for at most kBoundMaxAge - 1 steps.
RC_HD void stage_decide_refresh(const StepView& s) {
  StepCounters* c = s.counters;
  const uint32_t age = *s.bound_age + 1u;
  const uint32_t crowd = s.swept ? kSweptCrowd : kBoundCrowd, max_age = s.swept ? kSweptMaxAge : kBoundMaxAge;
  if (c->wants * crowd > s.model.num_vertices || (c->wants > 0u && age >= max_age))
    c->refresh = kRefreshFull;
  else if (c->wants_now > 0u && !s.swept)
    c->refresh = kRefreshPartial;
  else
    c->refresh = kRefreshNone;
  c->refresh_made = c->refresh;
  *s.bound_age = c->refresh == kRefreshFull ? 0u : age;
}

// The refresh that pass 0 (decided by stage_decide_refresh) or pass 1 (a starved partial refresh
// redone as a full one, stage_escalate_refresh) runs.
RC_HD uint32_t refresh_in_pass(const StepView& s, uint32_t pass) {
  if (pass == 0u) return s.counters->refresh;
  return s.counters->escalate ? kRefreshFull : kRefreshNone;
}

RC_HD bool refreshing(const StepView& s, uint32_t i) { return (s.flags[i] & kFlagRefresh) != 0u; }

// During a partial refresh: how far vertex j may move from its ball's centre, at most. Its present
// ball radius, or for a vertex being refreshed the most its new ball can get.
RC_HD float bound_pad(const StepView& s, uint32_t j) {
  return refreshing(s, j) ? kBoundFactor * s.bound_radius[j] : allowance_of(s, j);
}

// The farthest vertex i's look-ahead need reach on a refresh (a hair beyond its distance to its witness,
// RAYCLOTH_MODEL_ARRAYS: bound_witness, with every vertex at its ball's new centre), INFINITY without
// a witness. The refresh measures i against its witness, a triangle sharing no vertex with it, so i's
// nearest non-adjacent feature is never farther; a larger radius finds more pairs, none of them
// nearer (on cloth lying smooth its own panel's next ring is that near: about 0.7 of an edge, where
// the look-ahead reached 1.5 mean edges). Any radius keeps the invariant (stage_bound).
RC_HD float witness_radius(const StepView& s, uint32_t i, bool partial) {
  const uint32_t t = s.model.bound_witness ? s.model.bound_witness[i] : kNoWitness;
  if (t == kNoWitness) return INFINITY;
  const uint32_t* c = s.model.triangles + 3 * t;
  // A partial refresh leaves the balls of unmarked vertices where they were.
  auto centre = [&](uint32_t j) { return dvec(!partial || refreshing(s, j) ? s.x[j] : s.x_ref[j]); };
  const double d2 = closest_on_triangle(dvec(s.x[i]), centre(c[0]), centre(c[1]), centre(c[2])).dist2;
  return float(sqrt(d2) * (1.0 + 1e-4) + 1e-9);
}

// On a refresh: the ball's centre moves to x and the look-ahead radius follows the vertex's move.
// A full refresh does this for every vertex, a partial one for the marked vertices; a partial
// refresh also finds the largest pad over the vertices of the welded surface.
RC_HD void stage_bound_reset(const StepView& s, uint32_t i, uint32_t pass) {
  const uint32_t mode = refresh_in_pass(s, pass);
  if (mode == kRefreshNone) return;
  const bool partial = mode == kRefreshPartial;
  if (!partial) {
    s.plane_count[i] = 0u;
    s.plane_near[i] = bits_from_float(INFINITY);
  }
  // A partial refresh keeps a marked vertex's planes: measured from x, where it is now on their
  // allowed side, they only ask more of it.
  if (!partial || refreshing(s, i)) {
    s.x_ref[i] = s.x[i];
    s.bound[i] = bits_from_float(INFINITY);
    const float move = length(s.x_next[i] - s.x[i]);
    const float lo = kBoundMinRadius * s.mean_edge, hi = kBoundMaxRadius * s.mean_edge;
    const float want = is_finite(s.x_next[i]) ? kBoundLookahead * move / kBoundFactor : lo;
    s.bound_radius[i] = fminf(fminf(hi, fmaxf(lo, want)), witness_radius(s, i, partial));
  }
  // A further pass: a vertex at its goal stays where it is for the rest of the step, its ball of
  // radius 0 (no pair need be measured for it).
  if (mode == kRefreshPass && !(s.flags[i] & kFlagPassMove)) {
    s.bound[i] = 0u;
    s.bound_radius[i] = 0.0f;
  }
  if (partial && is_representative(s.model, i)) atomic_max_nonneg(&s.counters->pad_max, bound_pad(s, i));
}

// After a partial refresh: 1 when a marked vertex's new ball is too small for its proposed move
// (the balls of the features near it hold most of their gaps). A full refresh would centre those
// balls too and give it room; without one it would be held back, losing speed at every step.
RC_HD uint32_t stage_partial_short(const StepView& s, uint32_t i) {
  if (s.counters->refresh != kRefreshPartial || !refreshing(s, i)) return 0u;
  return length(s.x_next[i] - s.x_ref[i]) > allowance_of(s, i) ? 1u : 0u;
}

// A starved partial refresh (a vertex whose neighbours' balls left it no room, or less than its
// move) is redone as a full one in the same step (one thread).
RC_HD void stage_escalate_refresh(const StepView& s) {
  StepCounters* c = s.counters;
  if (c->refresh != kRefreshPartial || c->starved == 0u) return;
  c->escalate = 1u;
  c->refresh = kRefreshFull;
  c->refresh_made = kRefreshFull;
  *s.bound_age = 0u;
}

// Bound (on a refresh), per triangle t. The invariant the bound keeps: for every pair of features
// that share no vertex (a vertex and a triangle, two edges), the distance between them with every
// vertex at its ball's centre exceeds the largest ball radius among the first feature's vertices
// plus the largest among the second's. Since every point of a feature stays within its vertices'
// largest ball radius of where it is with the vertices at the centres, two such features cannot
// meet while every vertex stays in its ball.
//
// Full refresh: every cloth triangle t2 whose box comes within t's radius (the largest look-ahead
// radius of its corners) is a candidate pair, and each unordered pair is measured once, by the side
// with the larger radius (ties: the lower index), so that a pair nearer than either side's radius
// is always measured. A pair is measured feature by feature, features that share a vertex left
// out, each feature once over the whole mesh: a vertex against the other triangle only from the
// triangle that owns that vertex (the lowest-numbered one holding it), an edge against an edge only
// from the triangles owning both. Each distance d bounds the vertices of both features (ball radius
// kBoundFactor d at most, so the two sides sum to 0.8 d). A pair farther apart than a vertex's
// radius cannot limit it: its ball is kBoundFactor of that radius at most.
//
// Partial refresh: only triangles with a marked vertex look, within their largest pad plus twice
// the largest pad of any vertex (the tree holds the cloth at x, at most that far from the centres);
// a pair found from both sides is measured by the lower index. A measured pair at distance d whose
// unmarked vertices have largest ball radii A and B (per feature) gives each of its marked vertices
// d - (A + B) / (2 kBoundFactor) as its distance: with both sides' ball radii at most 0.8 d as
// above, the invariant holds afterwards. When that is not positive the vertex is starved and the
// step redoes the refresh as a full one.
RC_HD float triangle_radius(const StepView& s, uint32_t t) {
  const uint32_t* tri = s.model.triangles + 3 * t;
  return max_of(s.bound_radius[tri[0]], max_of(s.bound_radius[tri[1]], s.bound_radius[tri[2]]));
}

RC_HD bool triangle_refreshing(const StepView& s, uint32_t t) {
  const uint32_t* tri = s.model.triangles + 3 * t;
  return refreshing(s, tri[0]) || refreshing(s, tri[1]) || refreshing(s, tri[2]);
}

// Partial refresh: the distance d between two features (vertex lists a[0..na), b[0..nb)) bounds
// their marked vertices.
RC_HD void bound_partial_pair(const StepView& s, const uint32_t* a, int na, const uint32_t* b, int nb, double d2) {
  float pa = 0.0f, pb = 0.0f;
  bool any = false;
  for (int k = 0; k < na; ++k) {
    if (refreshing(s, a[k])) any = true;
    else pa = fmaxf(pa, allowance_of(s, a[k]));
  }
  for (int k = 0; k < nb; ++k) {
    if (refreshing(s, b[k])) any = true;
    else pb = fmaxf(pb, allowance_of(s, b[k]));
  }
  if (!any) return;
  const double room = sqrt(d2) - (double(pa) + double(pb)) / (2.0 * double(kBoundFactor));
  if (!(room > 0.0)) {
    atomic_store_one(&s.counters->starved);
    return;
  }
  const float r = float(room);
  for (int k = 0; k < na; ++k)
    if (refreshing(s, a[k]) && r < s.bound_radius[a[k]]) atomic_min_nonneg(&s.bound[a[k]], r);
  for (int k = 0; k < nb; ++k)
    if (refreshing(s, b[k]) && r < s.bound_radius[b[k]]) atomic_min_nonneg(&s.bound[b[k]], r);
}

// Full refresh: a plane for vertex i, which may not move against n (see kBoundPlaneShare). Past
// kBoundPlanes the pair's distance d bounds its ball instead (allowance_of).
RC_HD void add_plane(const StepView& s, uint32_t i, Vec3 n, float d) {
  const uint32_t slot = atomic_fetch_add_u32(&s.plane_count[i], 1u);
  if (slot < kBoundPlanes) s.planes[i].n[slot] = n;
  atomic_min_nonneg(&s.plane_near[i], d);
}

// Full refresh: a pair of features a[0..na) and b[0..nb) at squared distance d2, pa and pb their
// closest points, bounds their vertices: by their balls, or where it is near enough, by planes.
// `radius`: a pair this far or farther limits nothing (see stage_bound).
RC_HD void bound_full_pair(const StepView& s, const uint32_t* a, int na, const uint32_t* b, int nb, DVec3 pa, DVec3 pb,
                           double d2, float radius) {
  const double dd = sqrt(d2);
  const float d = float(dd);
  if (!(d < radius)) return;
  const double least = s.bound_planes ? plane_min(s, a, na, b, nb) : kBoundPlaneMinFar;
  if (s.bound_planes && dd > least && d < kBoundPlaneShare * s.coll.thickness) {
    const DVec3 g = pa - pb;
    const double len = sqrt(ddot(g, g));
    if (len > 0.5 * least) {
      const Vec3 n = make_vec3(float(g.x / len), float(g.y / len), float(g.z / len));
      for (int k = 0; k < na; ++k) add_plane(s, a[k], n, d);
      for (int k = 0; k < nb; ++k) add_plane(s, b[k], -n, d);
      return;
    }
  }
  for (int k = 0; k < na; ++k) atomic_min_nonneg(&s.bound[a[k]], d);
  for (int k = 0; k < nb; ++k) atomic_min_nonneg(&s.bound[b[k]], d);
}

RC_HD void stage_bound(const StepView& s, uint32_t t, uint32_t pass) {
  const uint32_t mode = refresh_in_pass(s, pass);
  if (mode == kRefreshNone) return;
  const bool partial = mode == kRefreshPartial;
  if (partial && !triangle_refreshing(s, t)) return;
  const uint32_t* tri = s.model.triangles;
  const Vec3* x = s.x_ref;  // the balls' centres (x itself for every vertex on a full refresh)
  const uint32_t v[3] = {tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]};
  const float radius = triangle_radius(s, t);
  // A further pass: a triangle whose corners all stay (radius 0) limits nothing, and a pair with a
  // corner that moves is measured from that corner's side (the larger radius).
  if (mode == kRefreshPass && radius == 0.0f) return;
  // How far from t's box a feature can limit t's vertices: the radius (full), or the pads (partial).
  float grow = radius;
  if (partial) {
    const float pad_t = max_of(bound_pad(s, v[0]), max_of(bound_pad(s, v[1]), bound_pad(s, v[2])));
    grow = pad_t + 2.0f * float_from_bits(s.counters->pad_max);
  }
  const DVec3 p[3] = {dvec(x[v[0]]), dvec(x[v[1]]), dvec(x[v[2]])};
  const uint32_t own = s.model.tri_edge_owner[t];
  const Aabb box = aabb_union(segment_box(x[v[0]], x[v[1]]), point_box(x[v[2]]));
  Aabb query = aabb_grow(box, grow);
  bvh_for_each_overlap(s.cloth_bvh, query, [&](uint32_t t2) {
    if (t2 == t) return;
    if (partial) {
      if (t2 < t && triangle_refreshing(s, t2)) return;  // measured from t2's side
    } else {
      const float r2 = triangle_radius(s, t2);
      if (r2 > radius || (r2 == radius && t2 < t)) return;  // measured from t2's side
    }
    const uint32_t w[3] = {tri[3 * t2], tri[3 * t2 + 1], tri[3 * t2 + 2]};
    const uint32_t own2 = s.model.tri_edge_owner[t2];
    const DVec3 q[3] = {dvec(x[w[0]]), dvec(x[w[1]]), dvec(x[w[2]])};
    const Aabb box2 = aabb_union(segment_box(x[w[0]], x[w[1]]), point_box(x[w[2]]));
    const Aabb query2 = aabb_grow(box2, grow);
    auto in_t = [&](uint32_t k) { return k == v[0] || k == v[1] || k == v[2]; };
    auto in_t2 = [&](uint32_t k) { return k == w[0] || k == w[1] || k == w[2]; };
    for (int k = 0; k < 3; ++k) {
      // Corner k of t against t2; corner k of t2 against t.
      if ((own & (8u << k)) && !in_t2(v[k]) && aabb_overlap(query2, point_box(x[v[k]]))) {
        const TrianglePoint c = closest_on_triangle(p[k], q[0], q[1], q[2]);
        if (partial) bound_partial_pair(s, &v[k], 1, w, 3, c.dist2);
        else bound_full_pair(s, &v[k], 1, w, 3, p[k], q[0] * c.wa + q[1] * c.wb + q[2] * c.wc, c.dist2, radius);
      }
      if ((own2 & (8u << k)) && !in_t(w[k]) && aabb_overlap(query, point_box(x[w[k]]))) {
        const TrianglePoint c = closest_on_triangle(q[k], p[0], p[1], p[2]);
        if (partial) bound_partial_pair(s, &w[k], 1, v, 3, c.dist2);
        else bound_full_pair(s, &w[k], 1, v, 3, q[k], p[0] * c.wa + p[1] * c.wb + p[2] * c.wc, c.dist2, radius);
      }
    }
    for (int k = 0; k < 3; ++k) {
      if (!(own & (1u << k))) continue;
      const uint32_t a = v[k], b = v[(k + 1) % 3];
      const Aabb ea = aabb_grow(segment_box(x[a], x[b]), grow);
      for (int l = 0; l < 3; ++l) {
        if (!(own2 & (1u << l))) continue;
        const uint32_t c = w[l], d = w[(l + 1) % 3];
        if (c == a || c == b || d == a || d == b) continue;
        if (!aabb_overlap(ea, segment_box(x[c], x[d]))) continue;
        const DVec3 &pa = p[k], &pb = p[(k + 1) % 3], &qc = q[l], &qd = q[(l + 1) % 3];
        double u, w2;
        closest_segment_params(pa, pb, qc, qd, u, w2);
        const DVec3 ca = pa + (pb - pa) * u, cb = qc + (qd - qc) * w2;
        const double d2 = ddot(ca - cb, ca - cb);
        const uint32_t e1[2] = {a, b}, e2[2] = {c, d};
        if (partial) bound_partial_pair(s, e1, 2, e2, 2, d2);
        else bound_full_pair(s, e1, 2, e2, 2, ca, cb, d2, radius);
      }
    }
  });
}

// Vertex i's planes: a proposed position behind one is moved onto it (the velocity against it
// removed), plane by plane; one that is then still behind one goes back to x, which every plane
// allows. Returns 1 when it changed the move.
RC_HD uint32_t keep_to_planes(const StepView& s, uint32_t i) {
  Vec3 n[kBoundPlanes];
  const uint32_t count = planes_of(s, i, n);
  if (count == 0u) return 0u;
  const DVec3 r = dvec(s.x_ref[i]);
  DVec3 p = dvec(s.x_next[i]);
  Vec3 v = s.v_next[i];
  bool moved = false;
  for (uint32_t k = 0; k < count; ++k) {
    const double c = ddot(p - r, dvec(n[k]));
    if (!(c < 0.0)) continue;
    p = p - dvec(n[k]) * c;
    const float vn = dot(v, n[k]);
    if (vn < 0.0f) v -= n[k] * vn;
    moved = true;
  }
  if (!moved) return 0u;
  Vec3 q = make_vec3(float(p.x), float(p.y), float(p.z));
  for (uint32_t k = 0; k < count; ++k)
    if (ddot(dvec(q) - r, dvec(n[k])) < -kBoundPlaneRounding) {
      q = s.x[i];
      v = make_vec3(0, 0, 0);
      break;
    }
  s.x_next[i] = q;
  s.v_next[i] = v;
  return 1u;
}

// Clamp: the vertex stays on its planes' allowed sides and inside its ball. Along its own move from
// x (onto its planes) it goes as far as the ball allows; its velocity shrinks in proportion.
// Returns 1 when it changed the move.
RC_HD uint32_t stage_clamp(const StepView& s, uint32_t i) {
  if (!is_free(s, i)) return 0u;
  // The planes first, then the ball along the move from x: x and the position the planes left are
  // both on every plane's allowed side, so every point between them is.
  const uint32_t planed = keep_to_planes(s, i);
  const float allowed = allowance_of(s, i);
  if (!(length(s.x_next[i] - s.x_ref[i]) > allowed)) {
    if (planed) s.flags[i] |= kFlagClamped;
    return planed;
  }
  // Largest k in [0, 1] with |x + k m - x_ref| <= allowed, in double.
  const DVec3 p = dvec(s.x[i]) - dvec(s.x_ref[i]), m = dvec(s.x_next[i]) - dvec(s.x[i]);
  const double mm = ddot(m, m), pm = ddot(p, m), a = double(allowed);
  const double disc = pm * pm - mm * (ddot(p, p) - a * a);
  double k = mm > 0.0 && disc > 0.0 ? (-pm + sqrt(disc)) / mm : 0.0;
  k = k < 0.0 ? 0.0 : (k > 1.0 ? 1.0 : k);
  const Vec3 move = s.x_next[i] - s.x[i];
  s.x_next[i] = s.x[i] + move * float(k);
  s.v_next[i] *= float(k);
  s.flags[i] |= kFlagClamped;
  return 1u;
}

// ---- Further passes of the bound (sim/step.h, run_bound_passes) ----------------------------------
// The bound is absolute: a vertex moves at most kBoundFactor of its distance to the nearest feature
// per refresh, even where a body pushes two layers (or the two sides of a fold) together and their
// distance does not change. Where a vertex an obstacle or the contact solve pushed was held back by
// its ball (`held`), the step goes on from where the clamp left every vertex: the balls are
// recomputed there (a full refresh at x_mid) and every vertex goes on along its move toward its goal
// (its position before the first clamp) as far as its new ball allows. Each pass keeps the
// invariant, so the guarantee stands; layers moving together gain kBoundFactor of their gap per pass.
inline constexpr uint32_t kBoundPasses = 4;

// 1 when vertex i was pushed (by an obstacle or by the contact solve) and is clamped; with an
// integrator of long steps (`every_clamp`), when it is clamped at all. In a step where no body moves
// (a skinned body standing before its walk), a push of the contact solve is cloth settling against
// cloth, as in a static scene, where the paper's step goes on without further passes: there only an
// obstacle's push holds. (GarmentCode's jumpsuit sewn on the standing man, its layers kept apart by
// the solve and pulled together by its stitches, otherwise ran a pass in every step that moved
// nothing: GarmentOnMan.ClothSettlingOnTheStandingManRunsNoFurtherBoundPasses.)
RC_HD uint32_t stage_held(const StepView& s, uint32_t i, bool every_clamp) {
  if (!(s.flags[i] & kFlagClamped)) return 0u;
  if (every_clamp || (s.flags[i] & kFlagPushed)) return 1u;
  return (s.flags[i] & kFlagContact) && s.counters->obstacle_move != 0u ? 1u : 0u;
}

// Before the first clamp: every vertex's goal (position and velocity).
RC_HD void stage_save_goal(const StepView& s, uint32_t i) {
  s.x_goal[i] = s.x_next[i];
  s.v_goal[i] = s.v_next[i];
}

// One thread: another pass runs only if the last one held a pushed vertex back, and (after the
// first) moved a vertex: a pass that moved none leaves every vertex where it started, so the next
// would refresh at the same positions and clamp the same moves, changing nothing.
RC_HD void stage_bound_pass_begin(const StepView& s) {
  StepCounters* c = s.counters;
  c->pass_active = c->held > 0u && (c->bound_passes == 0u || c->pass_moved != 0u) ? 1u : 0u;
  c->held = 0u;
  c->pass_moved = 0u;
  c->escalate = 0u;
  if (!c->pass_active) {
    c->refresh = kRefreshNone;  // the pass's stages (which run on the GPU all the same) do nothing
    return;
  }
  // Where no body moves, the pass measures only around the vertices short of their goals: the
  // others' balls shrink to radius 0 where they stay (kRefreshPass). Where a body moves, the next
  // step's contact solve reads every ball to skip its pair searches (sim/contact.h, contact_far),
  // and balls of radius 0 would let it skip none: every ball is measured again (the walking dress
  // ran its contact solve 1.5 times as long with those balls as without).
  c->refresh = s.bodies_move ? kRefreshFull : kRefreshPass;
  *s.bound_age = 0u;
  ++c->bound_passes;
}

// Every vertex starts the pass where the last clamp left it, aiming at its goal again; one short of
// its goal is marked (kFlagPassMove), the others stay where they are.
RC_HD void stage_bound_pass_move(const StepView& s, uint32_t i) {
  if (!s.counters->pass_active) return;
  s.x_mid[i] = s.x_next[i];
  s.flags[i] &= ~kFlagPassMove;
  if (!is_free(s, i)) return;
  const Vec3 g = s.x_goal[i], m = s.x_mid[i];
  s.x_next[i] = g;
  if (g.x != m.x || g.y != m.y || g.z != m.z) s.flags[i] |= kFlagPassMove;
}

// The clamp of a further pass (m: the step's view with x = x_mid): along the rest of its move. The
// velocity is the goal's, shortened as much as the whole move from x was. Returns 1 when it held
// back a pushed vertex again (every_clamp: as stage_held).
RC_HD uint32_t stage_bound_pass_clamp(const StepView& s, const StepView& m, uint32_t i, bool every_clamp) {
  if (!s.counters->pass_active || !is_free(s, i)) return 0u;
  s.flags[i] &= ~kFlagClamped;
  const uint32_t clamped = stage_clamp(m, i);
  const double want = sqrt(ddot(dvec(s.x_goal[i]) - dvec(s.x[i]), dvec(s.x_goal[i]) - dvec(s.x[i])));
  const double got = sqrt(ddot(dvec(s.x_next[i]) - dvec(s.x[i]), dvec(s.x_next[i]) - dvec(s.x[i])));
  s.v_next[i] = s.v_goal[i] * float(want > 0.0 ? (got < want ? got / want : 1.0) : 1.0);
  if (clamped) s.flags[i] |= kFlagClamped;
  const Vec3 a = s.x_next[i], b = s.x_mid[i];
  if (a.x != b.x || a.y != b.y || a.z != b.z) atomic_store_one(&s.counters->pass_moved);
  return stage_held(s, i, every_clamp);
}

// A vertex an obstacle pushed out and the bound then held back: 1 when it shortened the push.
RC_HD uint32_t stage_push_clamped(const StepView& s, uint32_t i) {
  return (s.flags[i] & (kFlagPushed | kFlagClamped)) == (kFlagPushed | kFlagClamped) ? 1u : 0u;
}

// Whether p lies behind the obstacle face nearest to it (within reach): inside the obstacle at t + dt.
RC_HD bool inside_obstacle(const StepView& s, Vec3 p, float reach) {
  const ObstaclePoint q = nearest_obstacle_point(s, p, reach);
  if (!q.found) return false;
  const Vec3 face = triangle_normal(s.geom.obstacle_vertices, s.geom.obstacle_indices, q.prim);
  return ddot(dvec(p) - q.point, dvec(face)) < 0.0;
}

// Of those, a vertex the bound left inside the obstacle (behind the face nearest to it): cloth on
// both sides of it left no room (a pinch, or a push faster than the bound allows). Counted, and
// reported by the run as obstacle_conflicts.
RC_HD uint32_t stage_conflict(const StepView& s, uint32_t i) {
  if (!stage_push_clamped(s, i)) return 0u;
  const Vec3 xn = s.x_next[i];
  return inside_obstacle(s, xn, obstacle_query_reach(s, i, xn)) ? 1u : 0u;
}

// Whether vertex i ends the step inside an obstacle (behind the face nearest to it at t + dt) having
// not been inside one at its start (inside[i], what this stage found in the last step, kept for the
// next). Every vertex outside at t that is inside at t + dt lies within its own move and the
// obstacles' (obstacle_reach) of the surface, so the query reaches it; where the vertex's body
// clearance (stage_obstacles) shows no body within that reach, the query would find none and is
// skipped. Counted as entered_obstacles: where the implicit integrator's step is cut into substeps,
// a step with one is taken again in more (Simulator::advance).
RC_HD uint32_t stage_entered(const StepView& s, uint32_t i) {
  const Vec3 xn = s.x_next[i];
  uint32_t in = 0u;
  if (is_representative(s.model, i) && is_finite(xn)) {
    const float reach = obstacle_query_reach(s, i, xn);
    in = !body_clear_of(s, i, xn, reach) && inside_obstacle(s, xn, reach) ? 1u : 0u;
  }
  const uint32_t was = s.inside[i];
  s.inside[i] = in;
  return in & (was ^ 1u);
}

}  // namespace raycloth
