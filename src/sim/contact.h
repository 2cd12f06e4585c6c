// Two-sided contact, solved within the step (docs/collision.md, "Contact that pushes back").
//
// The paper's rays and the obstacle stage act on one vertex at a time: a vertex that meets cloth
// changes its own motion, and the cloth it met never learns of it. A body moving into cloth that
// lies in layers then pushes the first layer against the next, which stays where it is, and the
// displacement bound (which keeps the layers from crossing) holds the first layer back: the body
// ends up inside the cloth. Here every pair of a cloth vertex and a cloth triangle within the
// thickness is a constraint on both sides,
//
//   C = n . (y_i - sum_k w_k y_k) - h >= 0          (y: proposed positions, h: the thickness)
//
// with n the direction the vertex lies from the triangle (its side at the start of the step) and w
// the barycentric weights of the triangle's nearest point. A violated pair moves the vertex and the
// triangle's corners apart along n, equal and opposite and weighted by inverse mass (a pinned
// vertex has inverse mass 0 and moves nothing; momentum is conserved):
//
//   lambda = -C / (1/m_i + sum_k w_k^2 / m_k),   dy_i = lambda n / m_i,   dy_k = -w_k lambda n / m_k.
//
// Edge-edge pairs are the same with the closest points of two edges (weights 1 - s, s and
// -(1 - t), -t). Rounds of Jacobi iteration (each vertex moves by the mean of what its pairs give it) alternate
// with the obstacles at t + dt, which are kinematic (infinite mass: they always win), until a round
// finds nothing to do or kContactRounds have run: a push from a moving body goes through one more
// layer in every round. A last round does the same on velocities (the part of the relative
// velocity into each pair removed, inelastic), so a pushed layer moves on with what pushed it.
//
// Corrections are summed in fixed point (FixedVec3), so every thread order gives the same result on
// both backends. The vertices the solve moved refresh their displacement bound in this step
// (kFlagContact, stage_wants_refresh_now), so the bound that follows keeps them from crossing
// without undoing the push. The solve is what moves cloth; the bound stays the guarantee.
#pragma once
#include <cstdint>

#include "sim/bound.h"
#include "sim/stages.h"

namespace raycloth {

inline constexpr uint32_t kVertexPairs = 4;    // nearest cloth triangles kept per vertex
inline constexpr uint32_t kEdgePairs = 4;      // nearest cloth edges kept per edge
inline constexpr uint32_t kContactRounds = 32;  // position rounds at most in one step
// A pair acts on positions when its gap is below (1 - kContactSlack) of the thickness, and then
// restores the whole thickness: rounds end once every gap is within that slack, instead of chasing
// the last fractions of a Jacobi iteration's convergence.
inline constexpr float kContactSlack = 0.05f;
// A vertex moves by kContactRelax / count of the sum of what its `count` pairs give it in a round (at
// most the sum): 1 is plain averaging (docs/collision.md says why not more).
inline constexpr float kContactRelax = 1.0f;
// The gap a pair is held at: the thickness, or where a moving body pushes the cloth kGapPerMove
// times the push, that is the smaller of its vertices' largest move in the step and the obstacles'
// largest move (at most kGapMax thicknesses). The displacement bound lets a vertex move kBoundFactor
// of its distance to the nearest feature at the step's start, so layers a body pushes along must
// lie more than 1 / kBoundFactor of the push apart for the next step's push to fit in their balls:
// held at the thickness, a body faster than kBoundFactor thickness per step would outrun the bound
// and end inside the cloth. Where no body moves the gap is the thickness.
inline constexpr float kGapPerMove = 1.15f / kBoundFactor;
inline constexpr float kGapMax = 4.0f;
// Edges are searched for edge-edge pairs only where a vertex of theirs has a cloth triangle within
// kNearFactor times the pair distance (kFlagNearCloth): two layers whose edges come that close have
// vertices near each other's triangles.
inline constexpr float kNearFactor = 4.0f;
// A vertex the solve moved more than this share of the thickness in the step refreshes its bound in
// this step if it leaves its ball (kFlagContact): it is being pushed through the layers. Smaller
// corrections (layers resting on each other) wait for the bound's next refresh, at most
// kBoundMaxAge - 1 steps, falling short by less than that many times this share.
inline constexpr float kContactPushed = 0.02f;
// The most a pair moves one of its vertices, in shortfalls (contact_correction).
inline constexpr float kContactMoveCap = 3.0f;

// The gap pairs with vertices moving `move` in this step are held at.
RC_HD float contact_gap(float thickness, float move) {
  return fminf(kGapMax * thickness, fmaxf(thickness, kGapPerMove * move));
}

// The pair slots: kVertexPairs per vertex, then kEdgePairs per edge of the welded surface.
RC_HD uint32_t contact_slots(const ModelView& m) { return m.num_vertices * kVertexPairs + m.num_edges * kEdgePairs; }

// The pair search's cloth clearances. Where a body moves, every vertex looks in the cloth tree for
// triangles within kNearFactor pair distances in every step (every substep of the implicit
// integrator: 42 a 1/60 s step under the walking skirt), and on a garment nearly every search finds
// nothing: a single layer's nearest triangles not a vertex's own are an edge's height away. So a
// search also measures each vertex's clearance c: its distance to the nearest cloth triangle not its
// own, up to kClearReach pair distances (the search box grown for it), and where the vertex was then
// (z). Until they are measured again, with D the largest move of any vertex from its z since
// (clear_drift), every such triangle is at least c - |y - z| - D from the vertex at y: each point of a
// triangle moves no farther than its farthest corner. Where that exceeds kNearFactor pair distances
// the search would find no pair and no triangle near, and is skipped. The clearances are measured
// again once D reaches kClearSkin pair distances, or the pair distance grows. The pairs found, and
// so every result, are the same as searching every step.
inline constexpr float kClearSkin = 1.0f;
inline constexpr float kClearReach = kNearFactor + 2.0f * kClearSkin;

// Whether this step's search measures the clearances again (one thread, after stage_contact_reach).
// Never measured, their pair distance is 0, below any step's (the thickness at least).
RC_HD void stage_cloth_clear_decide(const StepView& s) {
  ClothClear& c = *s.cloth_clear_state;
  const float reach = contact_gap(s.coll.thickness, obstacle_reach(s));
  const float drift = float_from_bits(s.counters->clear_drift);
  c.remeasure = !(drift < kClearSkin * c.reach) || reach > c.reach ? 1u : 0u;
  if (c.remeasure) c.reach = reach;
}

// True when vertex i at y = x_next[i] has no cloth triangle (not its own) within `near` metres, by its
// clearance (above).
RC_HD bool cloth_clear_of(const StepView& s, uint32_t i, double near) {
  return still_clear(s.cloth_clear[i], s.cloth_clear_at[i], s.x_next[i], double(float_from_bits(s.counters->clear_drift)),
                     near);
}

// The largest move (from x) and drift (from the ball's centre x_ref) of any vertex: how far a
// triangle can be from where the cloth tree has it, and the filter of the pair searches; and the
// largest move since the clearances were measured.
RC_HD void stage_contact_reach(const StepView& s, uint32_t i) {
  s.contact_shift[i] = 0.0f;
  if (!is_finite(s.x_next[i])) return;
  const DVec3 z = dvec(s.x_next[i]) - dvec(s.cloth_clear_at[i]);
  atomic_max_nonneg(&s.counters->clear_drift, float(sqrt(ddot(z, z))));
  if (!is_representative(s.model, i)) return;
  atomic_max_nonneg(&s.counters->move_max, length(s.x_next[i] - s.x[i]));
  atomic_max_nonneg(&s.counters->drift_max, length(s.x_next[i] - s.x_ref[i]));
}

// True when vertex i's bound shows nothing of the cloth within kNearFactor pair distances of it: at x_ref nothing that
// shares no vertex with it was nearer than min(bound, radius), and since then it and every other
// vertex have drifted at most drift_max.
RC_HD bool contact_far(const StepView& s, uint32_t i) {
  if (s.plane_count[i] > 0u) return false;  // a pair too near for a ball gave it a plane
  const float nearest = fminf(float_from_bits(s.bound[i]), s.bound_radius[i]);
  return nearest - length(s.x_next[i] - s.x_ref[i]) - float_from_bits(s.counters->drift_max) >
         kNearFactor * contact_gap(s.coll.thickness, obstacle_reach(s));
}

// True when vertex i's bound shows a cloth feature sharing no vertex with it (a vertex, a triangle
// or an edge of another's against one of its own edges) that may now be within `reach` of it:
// nearer than that at x_ref, less what it and every other vertex have drifted since. Every pair
// within reach of one of i's edges is then searched from it (kFlagNearCloth).
RC_HD bool contact_near_by_bound(const StepView& s, uint32_t i, float reach) {
  if (s.plane_count[i] > 0u) return true;
  return float_from_bits(s.bound[i]) - length(s.x_next[i] - s.x_ref[i]) -
             float_from_bits(s.counters->drift_max) <=
         reach;
}

// Appends a found pair's slot to the step's list of pairs (counters->contact_pairs long). The order
// of the list depends on the threads; what the rounds compute from it does not (fixed-point sums).
RC_HD void list_pair(const StepView& s, uint32_t slot) {
  s.pair_list[atomic_fetch_add_one(&s.counters->contact_pairs)] = slot;
}

RC_HD Vec3 unit_or(DVec3 d, Vec3 fallback) {
  const double len = sqrt(ddot(d, d));
  if (!(len > 1e-9)) return fallback;
  return make_vec3(float(d.x / len), float(d.y / len), float(d.z / len));
}

// Vertex i's pairs: up to kVertexPairs cloth triangles (not its own) within the thickness of its
// proposed position, nearest first. A pair's direction: for a point inside the triangle its normal
// at y, turned to the side the vertex was on at x (so that a vertex whose proposed move crossed the
// plane is sent back); for a point on its boundary the direction from that point to the vertex.
// Returns the number of pairs.
RC_HD uint32_t stage_contact_find_vertex(const StepView& s, uint32_t i) {
  ContactPair* out = s.pairs + size_t(i) * kVertexPairs;
  for (uint32_t k = 0; k < kVertexPairs; ++k) out[k].v[0] = kNoPair;
  // A vertex that does not measure its clearance when the others do gets none (0: it searches).
  const bool measure = s.cloth_clear_state->remeasure != 0u;
  if (measure) {
    s.cloth_clear[i] = 0.0f;
    s.cloth_clear_at[i] = s.x_next[i];
  }
  if (!s.cloth_contact || !is_representative(s.model, i) || !is_finite(s.x_next[i]) || contact_far(s, i)) return 0u;
  const Vec3 y = s.x_next[i];
  const DVec3 dy = dvec(y);
  const double reach = contact_gap(s.coll.thickness, obstacle_reach(s));
  const double limit2 = reach * reach, near2 = kNearFactor * kNearFactor * limit2;
  if (!measure && cloth_clear_of(s, i, kNearFactor * reach)) {
    if (contact_near_by_bound(s, i, float(reach))) s.flags[i] |= kFlagNearCloth;
    return 0u;
  }
  uint32_t found = 0, keys[kVertexPairs];
  double d2s[kVertexPairs];
  ContactPair items[kVertexPairs];
  bool near = false;
  double clear2 = INFINITY;
  const float look = (measure ? kClearReach : kNearFactor) * float(reach);
  Aabb query = aabb_grow(point_box(y), look + float_from_bits(s.counters->move_max));
  bvh_for_each_overlap(s.cloth_bvh, query, [&](uint32_t t) {
    const uint32_t* c = s.model.triangles + 3 * t;
    // Its own triangles (corners are welded). The two vertices of an open stitch are cloth to each
    // other like any other: the stitch closes to within the contact's thickness and is welded there.
    if (c[0] == i || c[1] == i || c[2] == i) return;
    const DVec3 a = dvec(s.x_next[c[0]]), b = dvec(s.x_next[c[1]]), d = dvec(s.x_next[c[2]]);
    const TrianglePoint q = closest_on_triangle(dy, a, b, d);
    if (q.dist2 < clear2) clear2 = q.dist2;
    if (q.dist2 < near2) near = true;
    if (!(q.dist2 < limit2)) return;
    ContactPair p;
    p.v[0] = i, p.v[1] = c[0], p.v[2] = c[1], p.v[3] = c[2];
    p.w[0] = 1.0f, p.w[1] = -float(q.wa), p.w[2] = -float(q.wb), p.w[3] = -float(q.wc);
    const Vec3 ny = triangle_normal(s.x_next, s.model.triangles, t);
    const double eps = 1e-6;
    if (q.wa > eps && q.wb > eps && q.wc > eps) {
      const Vec3 nx = triangle_normal(s.x, s.model.triangles, t);
      const DVec3 px = dvec(s.x[c[0]]) * q.wa + dvec(s.x[c[1]]) * q.wb + dvec(s.x[c[2]]) * q.wc;
      double side = ddot(dvec(s.x[i]) - px, dvec(nx));
      if (side == 0.0) side = ddot(dy - (a * q.wa + b * q.wb + d * q.wc), dvec(ny));
      p.n = side < 0.0 ? -ny : ny;
    } else {
      p.n = unit_or(dy - (a * q.wa + b * q.wb + d * q.wc), ny);
    }
    keep_nearest(kVertexPairs, found, d2s, keys, items, q.dist2, t, p);
  });
  // Two edges can come within the gap of each other while every vertex of both is farther than
  // kNearFactor gaps from any triangle not its own: long edges crossing near their middles, as in
  // a tight fold. The bound's nearest feature is measured edge to edge too, so it catches those.
  if (!near && contact_near_by_bound(s, i, float(reach))) near = true;
  if (near) s.flags[i] |= kFlagNearCloth;
  // Every triangle within `look` of y was visited (the tree's boxes at x are within move_max of y's).
  if (measure) s.cloth_clear[i] = float(fmin(sqrt(clear2), double(look)));
  for (uint32_t k = 0; k < found; ++k) {
    out[k] = items[k];
    list_pair(s, uint32_t(out + k - s.pairs));
  }
  return found;
}

// Edge e's pairs: up to kEdgePairs cloth edges sharing no vertex with it within the thickness at
// y, each unordered pair once (from the edge whose vertex pair is smaller). The direction: the
// edges' common normal turned to the side edge e was on at x, or for near-parallel edges the
// direction between their closest points at y. Returns the number of pairs.
RC_HD uint32_t stage_contact_find_edge(const StepView& s, uint32_t e) {
  ContactPair* out = s.pairs + size_t(s.model.num_vertices) * kVertexPairs + size_t(e) * kEdgePairs;
  for (uint32_t k = 0; k < kEdgePairs; ++k) out[k].v[0] = kNoPair;
  const uint32_t a = s.model.edges[2 * e], b = s.model.edges[2 * e + 1];
  if (!s.cloth_contact || !((s.flags[a] | s.flags[b]) & kFlagNearCloth) || !is_finite(s.x_next[a]) ||
      !is_finite(s.x_next[b]))
    return 0u;
  const DVec3 ya = dvec(s.x_next[a]), yb = dvec(s.x_next[b]);
  const double reach = contact_gap(s.coll.thickness, obstacle_reach(s));
  const double limit2 = reach * reach;
  uint32_t found = 0, keys[kEdgePairs];
  double d2s[kEdgePairs];
  ContactPair items[kEdgePairs];
  Aabb query = aabb_grow(segment_box(s.x_next[a], s.x_next[b]), float(reach) + float_from_bits(s.counters->move_max));
  bvh_for_each_overlap(s.cloth_bvh, query, [&](uint32_t t2) {
    const uint32_t* w = s.model.triangles + 3 * t2;
    const uint32_t own = s.model.tri_edge_owner[t2];
    for (int l = 0; l < 3; ++l) {
      if (!(own & (1u << l))) continue;  // each edge once, from the triangle that owns it
      uint32_t c = w[l], d = w[(l + 1) % 3];
      if (c > d) { const uint32_t tmp = c; c = d; d = tmp; }
      if (c == a || c == b || d == a || d == b) continue;
      if (c < a || (c == a && d < b)) continue;  // the pair is found from the other edge
      const DVec3 yc = dvec(s.x_next[c]), yd = dvec(s.x_next[d]);
      double u, v;
      closest_segment_params(ya, yb, yc, yd, u, v);
      const DVec3 gap = (ya + (yb - ya) * u) - (yc + (yd - yc) * v);
      const double d2 = ddot(gap, gap);
      if (!(d2 < limit2)) continue;
      ContactPair p;
      p.v[0] = a, p.v[1] = b, p.v[2] = c, p.v[3] = d;
      p.w[0] = float(1.0 - u), p.w[1] = float(u), p.w[2] = -float(1.0 - v), p.w[3] = -float(v);
      const Vec3 ea = s.x_next[b] - s.x_next[a], ec = s.x_next[d] - s.x_next[c];
      const Vec3 m = cross(ea, ec);
      const float mm = length(m);
      if (mm > 1e-3f * length(ea) * length(ec)) {
        const DVec3 gx = (dvec(s.x[a]) + (dvec(s.x[b]) - dvec(s.x[a])) * u) - (dvec(s.x[c]) + (dvec(s.x[d]) - dvec(s.x[c])) * v);
        double side = ddot(gx, dvec(m));
        if (side == 0.0) side = ddot(gap, dvec(m));
        p.n = m * ((side < 0.0 ? -1.0f : 1.0f) / mm);
      } else {
        p.n = unit_or(gap, make_vec3(0, 0, 0));
        if (length_sq(p.n) == 0.0f) continue;
      }
      keep_nearest(kEdgePairs, found, d2s, keys, items, d2, c * 0x10001u + d, p);
    }
  });
  for (uint32_t k = 0; k < found; ++k) {
    out[k] = items[k];
    list_pair(s, uint32_t(out + k - s.pairs));
  }
  return found;
}

// What one pair gives its four vertices. The pair's constraint is n . sum_k w_k y_k >= target
// (positions: target the thickness; velocities: target 0, the relative velocity into the pair
// removed); inv are the vertices' inverse masses (0: pinned, moves nothing). A pair acts when it is
// short of the target by more than `slack`; then each vertex moves by
// d_k = inv_k w_k lambda n with lambda = (target - n . sum w y) / sum_k w_k^2 inv_k, so that
// sum_k m_k d_k = lambda n sum_k w_k = 0 (the weights of each side sum to 1 and -1): momentum is
// conserved. lambda is capped so that no vertex moves more than kContactMoveCap times the shortfall.
// Returns false when the pair does not act.
RC_HD bool contact_correction(const ContactPair& p, const float inv[4], const Vec3 y[4], float target, float slack,
                              Vec3 d[4]) {
  float denom = 0.0f;
  Vec3 sum = make_vec3(0, 0, 0);
  for (int k = 0; k < 4; ++k) {
    denom += p.w[k] * p.w[k] * inv[k];
    sum += y[k] * p.w[k];
  }
  if (!(denom > 0.0f)) return false;  // both sides pinned
  const float c = dot(p.n, sum) - target;
  if (!(c < -slack)) return false;
  // No vertex moves farther than kContactMoveCap times the shortfall: where the only free vertex of
  // a pair has a tiny weight (the rest pinned, or backed by a body), the full correction would throw
  // it by the shortfall over its weight, and the velocity round would make that a blow-up. A free
  // corner of weight 1/3 or more needs at most 3 times the shortfall, so real pairs are not capped.
  float most = 0.0f;
  for (int k = 0; k < 4; ++k) most = fmaxf(most, fabsf(p.w[k]) * inv[k]);
  const float lambda = fminf(-c / denom, kContactMoveCap * -c / most);
  for (int k = 0; k < 4; ++k) d[k] = p.n * (lambda * p.w[k] * inv[k]);
  return true;
}

// One round, per listed pair k: the pair adds what it gives each of its vertices to their sums (fixed
// point, any thread order). Returns 1 when the pair acted.
RC_HD uint32_t stage_contact_push(const StepView& s, uint32_t k, uint32_t mode) {
  if (s.counters->contact_done || k >= s.counters->contact_pairs) return 0u;
  const ContactPair& p = s.pairs[s.pair_list[k]];
  Vec3 y[4];
  float inv[4], free_inv[4], move = 0.0f, denom = 0.0f;
  bool backed = false;
  for (int k = 0; k < 4; ++k) {
    const uint32_t v = p.v[k];
    y[k] = mode == 0u ? s.x_next[v] : s.v_next[v];
    inv[k] = free_inv[k] = s.model.inv_mass[v];
    move = fmaxf(move, length(s.x_next[v] - s.x[v]));
    // A vertex an obstacle pushed this step has the body behind it: toward the body it cannot
    // yield, so there it counts as kinematic (the body's infinite mass) and the other side moves.
    // A squeezed vertex (below) yields into its thickness; the obstacles still hold it outside.
    if ((s.flags[v] & (kFlagPushed | kFlagSqueezed)) == kFlagPushed && dot(p.n, s.contact_normal[v]) * p.w[k] < 0.0f) {
      inv[k] = 0.0f;
      backed = backed || free_inv[k] > 0.0f;
    }
    denom += p.w[k] * p.w[k] * inv[k];
  }
  float gap = contact_gap(s.coll.thickness, fminf(move, obstacle_reach(s)));
  // A squeeze: every free vertex of the pair is backed by a body, on both sides (a hand pressing
  // two layers against a hip). The bodies win, so nothing of the pair could move, and the bound
  // would then let the layers close in on each other step after step until neither can move at all
  // (a ball of radius 0). Instead the pair's backed vertices give way into their own thickness
  // (kFlagSqueezed: the obstacles hold them kSqueezeOffset of it off the body from the next round on)
  // and the pair asks only for the thickness itself.
  const bool squeeze = mode == 0u && !(denom > 0.0f) && backed;
  if (squeeze) {
    for (int k = 0; k < 4; ++k) inv[k] = free_inv[k];
    gap = fminf(gap, s.coll.thickness);
  }
  if (mode == 1u) {
    // Velocities only where the positions are in contact (at the thickness, or within 5 % of it).
    Vec3 sum = make_vec3(0, 0, 0);
    for (int k = 0; k < 4; ++k) sum += s.x_next[p.v[k]] * p.w[k];
    if (dot(p.n, sum) > 1.05f * gap) return 0u;
  }
  Vec3 d[4];
  const float target = mode == 0u ? gap : 0.0f;
  const float slack = mode == 0u ? kContactSlack * gap : 0.0f;
  if (!contact_correction(p, inv, y, target, slack, d)) return 0u;
  // The count's upper half marks a squeezed vertex (read in stage_contact_apply; flags are not
  // written here, so every pair of the round reads the same flags).
  const uint32_t one = squeeze ? 1u + (1u << 16) : 1u;
  for (int k = 0; k < 4; ++k) {
    if (!(inv[k] > 0.0f)) continue;
    atomic_add_fixed(&s.push[p.v[k]], d[k]);
    atomic_fetch_add_u32(&s.push_count[p.v[k]], one);
  }
  return 1u;
}

// One round, per vertex: it moves by the mean of what its pairs gave it (Jacobi with averaging:
// a vertex between two layers is not pushed twice). A vertex that has moved farther than its
// clearance is then held outside the obstacles again (they are kinematic: the body wins). Returns
// 1 when the vertex moved.
RC_HD uint32_t stage_contact_apply(const StepView& s, uint32_t i, uint32_t mode) {
  const uint32_t raw = s.push_count[i], count = raw & 0xFFFFu;
  if (count == 0u) return 0u;
  const Vec3 d = from_fixed(s.push[i]) * fminf(1.0f, kContactRelax / float(count));
  s.push[i] = FixedVec3();
  s.push_count[i] = 0u;
  if (raw >> 16) s.flags[i] |= kFlagSqueezed;
  if (mode == 1u) {
    s.v_next[i] += d;
    return 0u;
  }
  s.x_next[i] += d;
  s.contact_shift[i] += length(d);
  if (s.contact_shift[i] > kContactPushed * s.coll.thickness) s.flags[i] |= kFlagContact;
  s.clearance[i] -= length(d);
  if (!(s.clearance[i] > 0.0f)) stage_obstacles(s, i);
  return 1u;
}

// After a round (one thread): a round that found nothing to act on ends the solve.
RC_HD void stage_contact_round_end(const StepView& s) {
  StepCounters* c = s.counters;
  if (c->contact_done) return;
  if (c->contact_active == 0u) {
    c->contact_done = 1u;
  } else {
    ++c->contact_rounds;
    c->contact_active = 0u;
  }
}

// Before the velocity round (one thread): it runs whether or not the position rounds converged.
RC_HD void stage_contact_velocity_begin(const StepView& s) { s.counters->contact_done = 0u; }

}  // namespace raycloth
