// The swept bound: what keeps cloth from crossing cloth in a long step (an integrator with
// kLongSteps, the implicit one) where a body moves, after the balls of sim/bound.h. The balls are
// absolute: a vertex moves at most kBoundFactor of its distance to the nearest feature per refresh,
// so cloth that a body carries farther than that in one step (two layers pushed together, their gap
// unchanged) took further passes, each a full refresh, and a vertex held back by its ball dragged
// on its neighbours. What keeps two features apart is how they move relative to each other. With
// every vertex on its straight line from x to x_next over the step, a point of a triangle moves by
// the same weights of its corners' moves, so the distance between two features changes at most by
// the largest relative move of their vertices (rel) times the share of the step gone. From x, where
// no two features meet, conservative advancement along the step then shows a pair never comes
// nearer than a floor: from a share u where they are D apart, they cannot reach the floor before
// u + (D - floor) / rel.
//
// So, once the balls are refreshed as the step decided (sim/bound.h), instead of the clamp: a pair of
// features (a vertex and a triangle, two edges, sharing no vertex) whose vertices all stay in their
// balls over the step keeps apart by the balls' invariant; every pair with a vertex out of its ball
// (kFlagSweptOut) whose boxes over the step come within the largest floor of each other is measured
// (the cloth's tree at x, queried with each triangle's box over the step grown by the largest move);
// one whose vertices' relative move could close it to its floor is advanced; one that would pass its
// floor before the step ends stops its vertices where it keeps twice its floor (each vertex along its
// own move, the smallest share of any of its pairs: that prefix of every pair's motion keeps the
// pair off its floor). A vertex stopped short changes its pairs' motion, so rounds check again the
// pairs of the triangles whose corners moved less, until a round stops no vertex; from round
// kSweptStopFrom a failing pair's vertices stay at x, and if kSweptRounds rounds have not settled it,
// every vertex stays at x (counted: swept_bound_stops). Every step ends with no pair nearer than its
// floor, less the rounding of float positions, which the floor exceeds. The sequence is in
// sim/step.h (run_swept_bound).
#pragma once
#include <cstdint>

#include "sim/bound.h"

namespace raycloth {

// The floor a pair at distance d0 (at x) may not come nearer than over a step: kSweptFloorOfGap of
// its distance (what the balls' invariant keeps: two balls of kBoundFactor of it), at most
// kSweptFloorShare of the thickness; a pair nearer than kSweptTiny may not come nearer at all (float
// rounding of the positions is about 0.1 um at 1 m).
inline constexpr double kSweptFloorOfGap = 0.5;
inline constexpr float kSweptFloorShare = 0.1f;
inline constexpr double kSweptTiny = 1e-6;
// A pair that would pass its floor is stopped where it keeps kSweptStopMargin of the floor more (and
// at least kSweptStopRounding more): the rounds that check it again then find it clear of the floor,
// the rounding of the stopped positions to float included.
inline constexpr double kSweptStopMargin = 0.25;
inline constexpr double kSweptStopRounding = 4e-7;
inline constexpr uint32_t kSweptAdvances = 12;
inline constexpr uint32_t kSweptRounds = 10;
inline constexpr uint32_t kSweptStopFrom = 5;

RC_HD double swept_floor(const StepView& s, double d0) {
  if (d0 < kSweptTiny) return d0;
  return fmin(kSweptFloorOfGap * d0, double(kSweptFloorShare) * double(s.coll.thickness));
}

// The largest floor of any pair: features whose boxes over the step stay farther apart than this
// keep their floors.
RC_HD float swept_reach(const StepView& s) { return kSweptFloorShare * s.coll.thickness; }

RC_HD Aabb swept_box(const StepView& s, const uint32_t* v, int n) {
  Aabb b = point_box(s.x[v[0]]);
  for (int k = 0; k < n; ++k) b = aabb_union(aabb_union(b, point_box(s.x[v[k]])), point_box(s.x_next[v[k]]));
  return b;
}

// The distance between features a (na vertices: 1 a vertex, 2 an edge) and b (3 a triangle, 2 an
// edge), every vertex at x + u (x_next - x).
RC_HD double swept_distance(const StepView& s, const uint32_t* w, int na, double u) {
  DVec3 q[4];
  for (int j = 0; j < 4; ++j) q[j] = dvec(s.x[w[j]]) + (dvec(s.x_next[w[j]]) - dvec(s.x[w[j]])) * u;
  if (na == 1) return sqrt(closest_on_triangle(q[0], q[1], q[2], q[3]).dist2);
  return sqrt(segment_segment_dist2(q[0], q[1], q[2], q[3]));
}

// Whether the pair only parts along the direction between its closest points at x (n, from the
// second feature to the first): each of its vertices moves along n no less than every vertex of the
// other. Convex features that far apart along n then stay at least d0 apart over the whole step,
// however near they are (a pair micrometres apart may always part).
RC_HD bool swept_parting(const StepView& s, const uint32_t* w, int na) {
  DVec3 q[4];
  for (int j = 0; j < 4; ++j) q[j] = dvec(s.x[w[j]]);
  DVec3 a, b;
  if (na == 1) {
    const TrianglePoint c = closest_on_triangle(q[0], q[1], q[2], q[3]);
    a = q[0], b = q[1] * c.wa + q[2] * c.wb + q[3] * c.wc;
  } else {
    double u, v;
    closest_segment_params(q[0], q[1], q[2], q[3], u, v);
    a = q[0] + (q[1] - q[0]) * u, b = q[2] + (q[3] - q[2]) * v;
  }
  const DVec3 n = a - b;
  if (!(ddot(n, n) > 0.0)) return false;
  double lo = INFINITY, hi = -INFINITY;
  for (int j = 0; j < 4; ++j) {
    const double along = ddot(dvec(s.x_next[w[j]]) - q[j], n);
    if (j < na) lo = fmin(lo, along);
    else hi = fmax(hi, along);
  }
  return lo >= hi;
}

// Conservative advancement from 0 toward 1 while the pair stays farther than `floor`: the share of
// the step it is sure to keep that floor for (1: all of it).
RC_HD double swept_advance(const StepView& s, const uint32_t* w, int na, double d0, double rel, double floor) {
  double u = 0.0, dist = d0;
  for (uint32_t k = 0; k < kSweptAdvances; ++k) {
    if (!(dist > floor)) return u;
    const double next = u + (dist - floor) / rel;
    if (next >= 1.0) return 1.0;
    u = next;
    dist = swept_distance(s, w, na, u);
  }
  return u;
}

// A pair of features (w[0..na) against w[na..4)): 1 when it keeps its floor over the whole step,
// else the share of the step its vertices may go and keep kSweptStopMargin floors (0: none).
RC_HD double swept_pair_share(const StepView& s, const uint32_t* w, int na) {
  DVec3 m[4];
  for (int j = 0; j < 4; ++j) m[j] = dvec(s.x_next[w[j]]) - dvec(s.x[w[j]]);
  double rel2 = 0.0;
  for (int a = 0; a < na; ++a)
    for (int b = na; b < 4; ++b) rel2 = fmax(rel2, ddot(m[a] - m[b], m[a] - m[b]));
  if (rel2 == 0.0) return 1.0;  // moving together: the distance stays as it is
  const double rel = sqrt(rel2), d0 = swept_distance(s, w, na, 0.0), floor = swept_floor(s, d0);
  if (rel < d0 - floor) return 1.0;
  if (swept_parting(s, w, na)) return 1.0;
  if (swept_advance(s, w, na, d0, rel, floor) >= 1.0) return 1.0;
  const double stop = fmin(d0, floor + fmax(kSweptStopMargin * floor, kSweptStopRounding));
  return stop >= d0 ? 0.0 : swept_advance(s, w, na, d0, rel, stop);
}

// Per vertex, after the balls' refresh: whether its ball holds it over the step (x and x_next inside
// it, no planes). A pair of features whose vertices all stay in their balls keeps apart by the balls'
// invariant (sim/bound.h); every other pair is the swept bound's.
RC_HD void stage_swept_out(const StepView& s, uint32_t i) {
  s.flags[i] &= ~kFlagSweptOut;
  if (!is_free(s, i)) return;
  const float allowed = allowance_of(s, i);
  if (s.plane_count[i] > 0u || length(s.x[i] - s.x_ref[i]) > allowed || length(s.x_next[i] - s.x_ref[i]) > allowed)
    s.flags[i] |= kFlagSweptOut;
}

RC_HD bool swept_out(const StepView& s, const uint32_t* v, int n) {
  for (int k = 0; k < n; ++k)
    if (s.flags[v[k]] & kFlagSweptOut) return true;
  return false;
}

// Whether triangle t has a corner that moved less in the last round (its pairs are checked again).
RC_HD bool swept_changed(const StepView& s, uint32_t t) {
  const uint32_t* c = s.model.triangles + 3 * t;
  return ((s.flags[c[0]] | s.flags[c[1]] | s.flags[c[2]]) & kFlagSweptLess) != 0u;
}

// A pair that would pass its floor: each of its vertices may go at most `share` of its move.
RC_HD void swept_limit(const StepView& s, const uint32_t* w, double share) {
  atomic_store_one(&s.counters->swept_failing);
  for (int j = 0; j < 4; ++j) atomic_min_nonneg(&s.swept_share[w[j]], float(share));
}

// Per vertex, before the rounds: nothing limits it yet; the largest move of any vertex.
RC_HD void stage_swept_begin(const StepView& s, uint32_t i) {
  s.swept_share[i] = bits_from_float(1.0f);
  s.flags[i] &= ~kFlagSweptLess;
  if (!is_representative(s.model, i) || !is_finite(s.x_next[i])) return;
  atomic_max_nonneg(&s.counters->swept_move, length(s.x_next[i] - s.x[i]));
}

// Per triangle t, in round `round`: its pairs with every triangle whose box may meet its box over
// the step, each unordered pair of triangles once (round 0: all; later, those with a triangle whose
// corner moved less in the last round). Each pair of features is measured from the triangle that
// owns them (RAYCLOTH_MODEL_ARRAYS: tri_edge_owner), as stage_bound does.
RC_HD void stage_swept_check(const StepView& s, uint32_t t, uint32_t round) {
  const uint32_t* tri = s.model.triangles;
  const uint32_t v[3] = {tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]};
  // Round 0: the triangles with a corner out of its ball, each against every triangle near it (two
  // such: from the lower index); later rounds: the triangles with a corner that moved less.
  auto mine_of = [&](uint32_t u, const uint32_t* c) { return round == 0u ? swept_out(s, c, 3) : swept_changed(s, u); };
  if (!mine_of(t, v)) return;
  for (int k = 0; k < 3; ++k)
    if (!is_finite(s.x_next[v[k]])) return;
  const float reach = swept_reach(s);
  const Aabb box = swept_box(s, v, 3);
  const Aabb grown = aabb_grow(box, reach);
  Aabb query = aabb_grow(box, reach + float_from_bits(s.counters->swept_move));
  const uint32_t own = s.model.tri_edge_owner[t];
  bvh_for_each_overlap(s.cloth_bvh, query, [&](uint32_t t2) {
    if (t2 == t) return;
    const uint32_t w[3] = {tri[3 * t2], tri[3 * t2 + 1], tri[3 * t2 + 2]};
    if (t2 < t && mine_of(t2, w)) return;  // from t2's side
    for (int k = 0; k < 3; ++k)
      if (!is_finite(s.x_next[w[k]])) return;
    const Aabb box2 = swept_box(s, w, 3);
    if (!aabb_overlap(grown, box2)) return;
    const Aabb grown2 = aabb_grow(box2, reach);
    const uint32_t own2 = s.model.tri_edge_owner[t2];
    auto in_t = [&](uint32_t q) { return q == v[0] || q == v[1] || q == v[2]; };
    auto in_t2 = [&](uint32_t q) { return q == w[0] || q == w[1] || q == w[2]; };
    for (int k = 0; k < 3; ++k) {
      if ((own & (8u << k)) && !in_t2(v[k]) && aabb_overlap(grown2, swept_box(s, &v[k], 1))) {
        const uint32_t f[4] = {v[k], w[0], w[1], w[2]};
        if (swept_out(s, f, 4)) {
          const double share = swept_pair_share(s, f, 1);
          if (share < 1.0) swept_limit(s, f, share);
        }
      }
      if ((own2 & (8u << k)) && !in_t(w[k]) && aabb_overlap(grown, swept_box(s, &w[k], 1))) {
        const uint32_t f[4] = {w[k], v[0], v[1], v[2]};
        if (swept_out(s, f, 4)) {
          const double share = swept_pair_share(s, f, 1);
          if (share < 1.0) swept_limit(s, f, share);
        }
      }
    }
    for (int k = 0; k < 3; ++k) {
      if (!(own & (1u << k))) continue;
      const uint32_t e1[2] = {v[k], v[(k + 1) % 3]};
      const Aabb ea = aabb_grow(swept_box(s, e1, 2), reach);
      for (int l = 0; l < 3; ++l) {
        if (!(own2 & (1u << l))) continue;
        const uint32_t e2[2] = {w[l], w[(l + 1) % 3]};
        if (e2[0] == e1[0] || e2[0] == e1[1] || e2[1] == e1[0] || e2[1] == e1[1]) continue;
        if (!aabb_overlap(ea, swept_box(s, e2, 2))) continue;
        const uint32_t f[4] = {e1[0], e1[1], e2[0], e2[1]};
        if (!swept_out(s, f, 4)) continue;
        const double share = swept_pair_share(s, f, 2);
        if (share < 1.0) swept_limit(s, f, share);
      }
    }
  });
}

// One thread, before a round's check: no pair has failed yet. A round after one that found a
// failing pair is counted (swept_bound_rounds).
RC_HD void stage_swept_round_begin(const StepView& s, uint32_t round) {
  if (round > 0u && s.counters->swept_failing) ++s.counters->swept_rounds;
  s.counters->swept_failing = 0u;
}

// Per vertex, after a round's check that found a failing pair: a vertex a pair limited goes that
// share of its move (none from round kSweptStopFrom on); its velocity shrinks in proportion.
// Returns 1 when it moved less.
RC_HD uint32_t stage_swept_apply(const StepView& s, uint32_t i, uint32_t round) {
  s.flags[i] &= ~kFlagSweptLess;
  const float share = float_from_bits(s.swept_share[i]);
  s.swept_share[i] = bits_from_float(1.0f);
  if (!(share < 1.0f) || !is_free(s, i)) return 0u;
  const float k = round >= kSweptStopFrom ? 0.0f : share;
  const Vec3 before = s.x_next[i];
  s.x_next[i] = k == 0.0f ? s.x[i] : s.x[i] + (s.x_next[i] - s.x[i]) * k;
  s.v_next[i] *= k;
  const Vec3 after = s.x_next[i];
  if (after.x == before.x && after.y == before.y && after.z == before.z) return 0u;
  s.flags[i] |= kFlagSweptLess | kFlagClamped;
  return 1u;
}

// Per vertex, when kSweptRounds rounds left a pair failing: every vertex stays at x (no pair then
// moves at all), and the step says so.
RC_HD void stage_swept_stop(const StepView& s, uint32_t i) {
  if (!s.counters->swept_failing) return;
  if (i == 0u) s.counters->swept_stops = 1u;
  if (!is_free(s, i)) return;
  s.x_next[i] = s.x[i];
  s.v_next[i] = make_vec3(0, 0, 0);
  s.flags[i] |= kFlagClamped;
}

RC_HD uint32_t stage_swept_clamped(const StepView& s, uint32_t i) { return (s.flags[i] & kFlagClamped) ? 1u : 0u; }

}  // namespace raycloth
