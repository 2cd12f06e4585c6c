// The stages of one step as per-vertex (or per-edge) functions over plain pointers. The sequence
// that calls them is written once, in sim/step.h, and run by every backend: oneTBB loops on the
// CPU, kernels on the GPU.
//
//   integrate        eq. (2)+(3): proposed v', x'; the paper's ray per vertex along the move
//   (cast)           backend: rays against the obstacles (posed at t + dt) and the cloth (at x)
//   respond 1        the collision buffer from the hit; respond; second ray along the last contact
//                    normal (resting and sliding contact) or along the corrected move
//   (cast)           backend: second rays
//   respond 2        respond to second-ray hits
//   obstacles        the obstacles at t + dt: a vertex inside one, or nearer than the thickness,
//                    goes to the thickness outside its nearest point and takes the surface's
//                    velocity there (minus friction): a body moving into cloth at rest pushes it
//   refresh?         a vertex whose proposed position leaves its allowance ball (centre x_ref,
//                    radius kBoundFactor x its bound) asks for a new bound; one ask refreshes all
//   bound            only on a refresh: x_ref <- x and, per vertex, the distance at x to the
//                    nearest cloth feature it shares no vertex with (vertex-triangle both ways,
//                    edge-edge), looked for within a per-vertex look-ahead radius
//   clamp            each vertex stays inside its ball: two features that were apart at x_ref
//                    each stay within less than half their gap of where they were, so they cannot
//                    have met at any time since, and a run that starts with no edge through cloth
//                    never has one
//   weld             seam partners take their representative's state
//   check            blow-up test
#pragma once
#include <cstdint>

#include "collide/proximity.h"
#include "collide/rules.h"
#include "sim/physics.h"

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
inline constexpr float kBoundNear = 0.25f;

// A velocity component past this (m/s) right after integration is a blow-up: the bound would
// otherwise keep an unstable step's positions in range and hide it.
inline constexpr float kRunawaySpeed = 1e3f;

// Counters of one step, in the backend's memory (device memory on the GPU). Float maxima are kept
// as bit patterns so that atomics and reductions give the same value in any thread order.
struct StepCounters {
  uint32_t hits = 0;           // vertices with an entry in the collision buffer
  uint32_t pushed = 0;         // vertices pushed out of (or off) an obstacle at t + dt
  uint32_t clamped = 0;        // vertices whose move the bound shortened
  uint32_t conflicts = 0;      // vertices the bound kept from leaving an obstacle completely
  uint32_t wants = 0;          // vertices whose proposed position left their ball
  uint32_t wants_now = 0;      // of those, vertices marked for a partial refresh (kFlagRefresh)
  uint32_t refresh = 0;        // kRefreshNone, kRefreshPartial or kRefreshFull
  uint32_t starved = 0;        // > 0 when a partial refresh could not give a vertex room for its move
  uint32_t escalate = 0;       // 1 when a starved partial refresh was redone as a full one
  uint32_t pad_max = 0;        // float bits: the largest ball radius (or target radius) on a partial refresh
  uint32_t bad_vertex = 0xFFFFFFFFu;  // smallest vertex that blew up
};

struct StepView {
  ModelView model;
  CollisionParams coll;
  CollisionGeometry geom;      // obstacle vertices/velocities at t + dt, cloth at x
  Vec3 gravity;
  float blowup_limit = 1e4f;   // |x| past this (metres) is a blow-up
  float sew = 1.0f;            // how far seams have closed (0 -> 1 over the model's sew_time)
  const Vec3* x = nullptr;     // state at t
  const Vec3* v = nullptr;
  Vec3* x_next = nullptr;      // state at t + dt
  Vec3* v_next = nullptr;
  Ray* rays = nullptr;
  RawHit* hits = nullptr;
  Contact* contacts = nullptr;     // the collision buffer, one entry per vertex
  Vec3* contact_normal = nullptr;  // last step's acting contact normal (0 = none), updated in place
  // The displacement bound, kept across steps and refreshed when a vertex needs more room:
  uint32_t* bound = nullptr;       // per vertex: float bits of the nearest non-adjacent distance at x_ref
  float* bound_radius = nullptr;   // per vertex: how far that distance was looked for
  Vec3* x_ref = nullptr;           // per vertex: position at the last refresh
  uint32_t* bound_age = nullptr;   // steps since the last refresh (one value)
  float mean_edge = 0;             // the cloth's mean edge length: the look-ahead scale
  uint32_t* flags = nullptr;       // per vertex: kFlagPushed when an obstacle pushed it this step
  BvhView obstacle_bvh;            // over geom.obstacle_indices at t + dt
  BvhView cloth_bvh;               // over model.triangles at x
  float obstacle_reach = 0;        // how far an obstacle surface moves in this step, at most
  StepCounters* counters = nullptr;
};

inline constexpr uint32_t kFlagPushed = 1u;   // an obstacle pushed the vertex this step
inline constexpr uint32_t kFlagClamped = 2u;  // the bound shortened its move
inline constexpr uint32_t kFlagBlowup = 4u;   // integration gave a non-finite or runaway velocity
inline constexpr uint32_t kFlagInside = 8u;   // inside an obstacle at t + dt, or pushed hard by one
inline constexpr uint32_t kFlagRefresh = 16u; // its ball is recomputed by this step's partial refresh

inline constexpr uint32_t kRefreshNone = 0u, kRefreshPartial = 1u, kRefreshFull = 2u;


RC_HD bool is_representative(const ModelView& m, uint32_t i) { return m.alias[i] == i; }

// An attachment's pull on vertex i: a spring of rest length 0 to its body point at t + dt (lifted
// along the body triangle's normal), damped along the velocity relative to that point. While seams
// close the point starts at the vertex's start position and eases onto the body.
RC_HD Vec3 attachment_force(const StepView& s, uint32_t i) {
  const ModelView& m = s.model;
  if (!m.attach_slot || m.attach_slot[i] == kNoAttachment) return make_vec3(0, 0, 0);
  const uint32_t k = m.attach_slot[i];
  const uint32_t* t = s.geom.obstacle_indices + 3 * m.attach_tri[k];
  const Vec3* ov = s.geom.obstacle_vertices;
  const Vec3 w = m.attach_bary[k];
  const Vec3 n = triangle_normal(ov, s.geom.obstacle_indices, m.attach_tri[k]);
  const Vec3 target = ov[t[0]] * w.x + ov[t[1]] * w.y + ov[t[2]] * w.z + n * m.attach_lift[k] +
                      m.attach_offset[k] * (1.0f - s.sew);
  Vec3 target_v = make_vec3(0, 0, 0);
  if (s.geom.obstacle_velocities) {
    const Vec3* vv = s.geom.obstacle_velocities;
    target_v = vv[t[0]] * w.x + vv[t[1]] * w.y + vv[t[2]] * w.z;
  }
  return (target - s.x[i]) * m.attach_k[k] + (target_v - s.v[i]) * m.attach_kd[k];
}

RC_HD void stage_integrate(const StepView& s, uint32_t i) {
  integrate_vertex(s.model, s.x, s.v, i, s.gravity, s.coll.dt, s.v_next[i], s.x_next[i], s.sew,
                   attachment_force(s, i));
  s.contacts[i] = Contact();
  s.rays[i] = s.model.inv_mass[i] == 0.0f ? Ray() : velocity_ray(s.x[i], s.x_next[i], i, s.coll);
  s.rays[i].vertex = i;
  // Checked before any response or bound can hide it: an unstable time step shows here first.
  const Vec3 vn = s.v_next[i];
  const bool runaway = !is_finite(vn) || !is_finite(s.x_next[i]) || fabsf(vn.x) > kRunawaySpeed ||
                       fabsf(vn.y) > kRunawaySpeed || fabsf(vn.z) > kRunawaySpeed;
  s.flags[i] = runaway ? kFlagBlowup : 0u;
}

// Responds to the velocity ray's hit and prepares each vertex's second ray.
RC_HD void stage_respond_velocity(const StepView& s, uint32_t i) {
  const Ray r = s.rays[i];
  const Contact c = make_contact(r, s.hits[i], s.geom);
  s.contacts[i] = c;
  const Vec3 last = s.contact_normal[i];
  s.contact_normal[i] = make_vec3(0, 0, 0);
  Ray next;
  next.vertex = r.vertex;
  if (r.tmax > 0.0f && respond(r, c, s.coll, s.v_next[i], s.x_next[i])) {
    s.contact_normal[i] = c.normal;
    // The response moved the vertex: that move is cast again, so that it sees a second surface.
    next = velocity_ray(s.x[i], s.x_next[i], r.vertex, s.coll);
  } else if (s.model.inv_mass[i] != 0.0f) {
    next = contact_ray(s.x[i], last, r.vertex, s.coll);
  }
  s.rays[i] = next;
}

// Responds to the second ray's hit. Returns 1 when the vertex has an entry in the collision buffer.
RC_HD uint32_t stage_respond_contact(const StepView& s, uint32_t i) {
  const Ray r = s.rays[i];
  if (r.tmax > 0.0f && s.hits[i].kind != kHitNone) {
    const Contact c = make_contact(r, s.hits[i], s.geom);
    if (s.contacts[i].w < 0.0f) s.contacts[i] = c;
    if (respond(r, c, s.coll, s.v_next[i], s.x_next[i])) s.contact_normal[i] = c.normal;
  }
  return s.contacts[i].w >= 0.0f ? 1u : 0u;
}

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

// Obstacles at t + dt: a vertex inside, or nearer than the thickness, goes to the thickness outside
// the nearest surface point and loses its velocity into the surface relative to the surface's own
// velocity there (friction on the rest).
RC_HD void stage_obstacles(const StepView& s, uint32_t i) {
  if (!is_representative(s.model, i)) return;
  Vec3& xn = s.x_next[i];
  if (s.model.inv_mass[i] != 0.0f && s.obstacle_bvh.num_prims > 0 && is_finite(xn)) {
    // A vertex outside at t can be at most its own move plus the obstacle's move inside at t + dt.
    const float reach = s.coll.thickness + length(xn - s.x[i]) + s.obstacle_reach;
    ObstaclePoint q = nearest_obstacle_point(s, xn, reach);
    if (q.found) {
      const uint32_t* t = s.geom.obstacle_indices + 3 * q.prim;  // the face that set the push
      const Vec3 face = triangle_normal(s.geom.obstacle_vertices, s.geom.obstacle_indices, q.prim);
      const DVec3 d = dvec(xn) - q.point;
      const double dist = sqrt(q.dist2);
      const bool inside = ddot(d, dvec(face)) < 0.0;
      Vec3 out = face;  // outward direction from the surface point
      if (dist > 1e-9) {
        const double k = (inside ? -1.0 : 1.0) / dist;
        out = make_vec3(float(d.x * k), float(d.y * k), float(d.z * k));
      }
      const bool near = inside || dist < double(s.coll.thickness);
      if (near || q.num_under > 0) {
        const Vec3 before = xn;
        bool pushed = near, under = false;
        if (near) {
          const Vec3 surface = make_vec3(float(q.point.x), float(q.point.y), float(q.point.z));
          xn = surface + out * s.coll.thickness;
        }
        // Pushed out of the nearest surface, the vertex may still be straight under another face it
        // was under (an outer layer): then out in front of that one too, and so on.
        for (uint32_t pass = 0; pass < q.num_under; ++pass) {
          bool moved = false;
          for (uint32_t k = 0; k < q.num_under && !moved; ++k) {
            const uint32_t f = q.under[k];
            const uint32_t* ft = s.geom.obstacle_indices + 3 * f;
            const Vec3* ov = s.geom.obstacle_vertices;
            const DVec3 a = dvec(ov[ft[0]]), b = dvec(ov[ft[1]]), c = dvec(ov[ft[2]]);
            const TrianglePoint fp = closest_on_triangle(dvec(xn), a, b, c);
            const Vec3 fn = triangle_normal(ov, s.geom.obstacle_indices, f);
            const DVec3 fpoint = a * fp.wa + b * fp.wb + c * fp.wc, fd = dvec(xn) - fpoint;
            const double depth = -ddot(fd, dvec(fn));
            if (!(depth > 0.0) || depth * depth < 0.999999 * ddot(fd, fd)) continue;  // in front, or not under it
            xn = make_vec3(float(fpoint.x), float(fpoint.y), float(fpoint.z)) + fn * s.coll.thickness;
            out = fn;
            q.prim = f, q.wa = fp.wa, q.wb = fp.wb, q.wc = fp.wc;
            t = s.geom.obstacle_indices + 3 * f;
            moved = pushed = under = true;
          }
          if (!moved) break;
        }
        if (!pushed) return;
        Vec3 u = make_vec3(0, 0, 0);
        if (s.geom.obstacle_velocities) {
          const Vec3* ovel = s.geom.obstacle_velocities;
          u = ovel[t[0]] * float(q.wa) + ovel[t[1]] * float(q.wb) + ovel[t[2]] * float(q.wc);
        }
        s.v_next[i] = contact_velocity(s.v_next[i], out, u, s.coll.friction);
        s.contact_normal[i] = out;
        // Inside, or pushed more than a tenth of the thickness by a surface moving into the cloth
        // (not cloth falling onto or resting on a body): the bound is refreshed at once if it holds it.
        const bool hard = inside || under || (dot(u, out) > 0.0f && length(xn - before) > 0.1f * s.coll.thickness);
        s.flags[i] |= hard ? (kFlagPushed | kFlagInside) : kFlagPushed;
        if (s.contacts[i].w < 0.0f) {
          s.contacts[i].normal = out;
          s.contacts[i].w = float(dist);
          s.contacts[i].surface_velocity = u;
        }
      }
    }
  }
}

// The radius of vertex i's ball: kBoundFactor of the nearest non-adjacent distance at x_ref (or of
// the radius it was looked for within, when nothing was nearer), less the slack.
RC_HD float allowance_of(const StepView& s, uint32_t i) {
  return fmaxf(0.0f, kBoundFactor * fminf(float_from_bits(s.bound[i]), s.bound_radius[i]) - kBoundSlack);
}

RC_HD bool is_free(const StepView& s, uint32_t i) {
  return is_representative(s.model, i) && s.model.inv_mass[i] != 0.0f;
}

// 1 when vertex i's proposed position leaves its ball.
RC_HD uint32_t stage_wants_refresh(const StepView& s, uint32_t i) {
  if (!is_free(s, i)) return 0u;
  const Vec3 x = s.x_next[i];
  return is_finite(x) && length(x - s.x_ref[i]) > allowance_of(s, i) ? 1u : 0u;
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
  const bool was_inside = (s.flags[i] & kFlagInside) != 0u;
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
  if (c->wants * kBoundCrowd > s.model.num_vertices || (c->wants > 0u && age >= kBoundMaxAge))
    c->refresh = kRefreshFull;
  else if (c->wants_now > 0u)
    c->refresh = kRefreshPartial;
  else
    c->refresh = kRefreshNone;
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

// On a refresh: the ball's centre moves to x and the look-ahead radius follows the vertex's move.
// A full refresh does this for every vertex, a partial one for the marked vertices; a partial
// refresh also finds the largest pad over the vertices of the welded surface.
RC_HD void stage_bound_reset(const StepView& s, uint32_t i, uint32_t pass) {
  const uint32_t mode = refresh_in_pass(s, pass);
  if (mode == kRefreshNone) return;
  const bool partial = mode == kRefreshPartial;
  if (!partial || refreshing(s, i)) {
    s.x_ref[i] = s.x[i];
    s.bound[i] = bits_from_float(INFINITY);
    const float move = length(s.x_next[i] - s.x[i]);
    const float lo = kBoundMinRadius * s.mean_edge, hi = kBoundMaxRadius * s.mean_edge;
    const float want = is_finite(s.x_next[i]) ? kBoundLookahead * move / kBoundFactor : lo;
    s.bound_radius[i] = fminf(hi, fmaxf(lo, want));
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

RC_HD void stage_bound(const StepView& s, uint32_t t, uint32_t pass) {
  const uint32_t mode = refresh_in_pass(s, pass);
  if (mode == kRefreshNone) return;
  const bool partial = mode == kRefreshPartial;
  if (partial && !triangle_refreshing(s, t)) return;
  const uint32_t* tri = s.model.triangles;
  const Vec3* x = s.x_ref;  // the balls' centres (x itself for every vertex on a full refresh)
  const uint32_t v[3] = {tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]};
  const float radius = triangle_radius(s, t);
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
  auto bound = [&](uint32_t i, double d2) {
    const float d = float(sqrt(d2));
    if (d < radius) atomic_min_nonneg(&s.bound[i], d);
  };
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
        const double d2 = closest_on_triangle(p[k], q[0], q[1], q[2]).dist2;
        if (partial) bound_partial_pair(s, &v[k], 1, w, 3, d2);
        else bound(v[k], d2), bound(w[0], d2), bound(w[1], d2), bound(w[2], d2);
      }
      if ((own2 & (8u << k)) && !in_t(w[k]) && aabb_overlap(query, point_box(x[w[k]]))) {
        const double d2 = closest_on_triangle(q[k], p[0], p[1], p[2]).dist2;
        if (partial) bound_partial_pair(s, &w[k], 1, v, 3, d2);
        else bound(w[k], d2), bound(v[0], d2), bound(v[1], d2), bound(v[2], d2);
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
        const double d2 = segment_segment_dist2(p[k], p[(k + 1) % 3], q[l], q[(l + 1) % 3]);
        if (partial) {
          const uint32_t e1[2] = {a, b}, e2[2] = {c, d};
          bound_partial_pair(s, e1, 2, e2, 2, d2);
        } else {
          bound(a, d2), bound(b, d2), bound(c, d2), bound(d, d2);
        }
      }
    }
  });
}

// Clamp: the vertex stays inside its ball. Along its own move from x it goes as far as the ball
// allows; its velocity shrinks in proportion. Returns 1 when it shortened the move.
RC_HD uint32_t stage_clamp(const StepView& s, uint32_t i) {
  if (!is_free(s, i)) return 0u;
  const float allowed = allowance_of(s, i);
  if (!(length(s.x_next[i] - s.x_ref[i]) > allowed)) return 0u;
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

// A vertex an obstacle pushed out and the bound then held back may still be inside the obstacle:
// cloth on both sides of it left no room. Counted, and reported by the run.
RC_HD uint32_t stage_conflict(const StepView& s, uint32_t i) {
  return (s.flags[i] & (kFlagPushed | kFlagClamped)) == (kFlagPushed | kFlagClamped) ? 1u : 0u;
}

// Seam partners are one vertex: every partner takes its representative's state. Returns false on a
// blow-up (a non-finite or runaway position or velocity).
RC_HD bool stage_finish(const StepView& s, uint32_t i) {
  const uint32_t r = s.model.alias[i];
  if (r != i) {
    s.x_next[i] = s.x_next[r];
    s.v_next[i] = s.v_next[r];
  }
  const Vec3 xn = s.x_next[i];
  return !(s.flags[r] & kFlagBlowup) && is_finite(xn) && is_finite(s.v_next[i]) && fabsf(xn.x) < s.blowup_limit && fabsf(xn.y) < s.blowup_limit &&
         fabsf(xn.z) < s.blowup_limit;
}

}  // namespace raycloth
