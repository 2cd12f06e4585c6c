// The stages of one step as per-vertex functions over plain pointers, and the step's view of the
// state. The sequence that calls them is written once, in sim/step.h, and run by every backend:
// oneTBB loops on the CPU, kernels on the GPU.
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
//   contact          two-sided contact between cloth features, with the obstacles (sim/contact.h)
//   bound            the displacement bound: refresh, clamp, further passes (sim/bound.h)
//   weld             seam partners take their representative's state
//   check            blow-up test
#pragma once
#include <cstdint>

#include "collide/proximity.h"
#include "collide/rules.h"
#include "sim/physics.h"

namespace raycloth {

// A velocity component past this (m/s) right after integration is a blow-up: the bound would
// otherwise keep an unstable step's positions in range and hide it.
inline constexpr float kRunawaySpeed = 1e3f;

// The displacement bound's refresh in a step (sim/bound.h).
inline constexpr uint32_t kRefreshNone = 0u, kRefreshPartial = 1u, kRefreshFull = 2u;

// Counters of one step, in the backend's memory (device memory on the GPU). Float maxima are kept
// as bit patterns so that atomics and reductions give the same value in any thread order.
struct StepCounters {
  uint32_t hits = 0;           // vertices with an entry in the collision buffer
  uint32_t pushed = 0;         // vertices pushed out of (or off) an obstacle at t + dt
  uint32_t clamped = 0;        // vertices whose move the bound shortened
  uint32_t conflicts = 0;      // vertices the bound left inside an obstacle it had been pushed out of
  uint32_t push_clamped = 0;   // vertices whose push out of (or off) an obstacle the bound shortened
  uint32_t wants = 0;          // vertices whose proposed position left their ball
  uint32_t wants_now = 0;      // of those, vertices marked for a partial refresh (kFlagRefresh)
  uint32_t refresh = 0;        // kRefreshNone, kRefreshPartial or kRefreshFull (the pass running)
  uint32_t refresh_made = 0;   // the step's own refresh (before further passes of the bound)
  uint32_t starved = 0;        // > 0 when a partial refresh could not give a vertex room for its move
  uint32_t escalate = 0;       // 1 when a starved partial refresh was redone as a full one
  uint32_t pad_max = 0;        // float bits: the largest ball radius (or target radius) on a partial refresh
  uint32_t move_max = 0;       // float bits: the largest |x' - x| of a vertex before the contact solve
  uint32_t drift_max = 0;      // float bits: the largest |x' - x_ref| of a vertex before the contact solve
  uint32_t contact_pairs = 0;  // cloth vertex-triangle pairs within the thickness (sim/contact.h)
  uint32_t contact_active = 0; // pairs that acted in the last round of the contact solve
  uint32_t contact_rounds = 0; // rounds of the position solve that found a pair to act on
  uint32_t contact_done = 0;   // 1 once a round found nothing to do: later rounds are skipped
  uint32_t contact_moved = 0;  // vertices the contact solve moved
  uint32_t held = 0;           // pushed vertices the last clamp held back (run_bound_passes)
  uint32_t pass_active = 0;    // 1 while a further pass of the bound runs
  uint32_t bound_passes = 0;   // further passes of the bound this step
  uint32_t residual = 0;       // float bits: the implicit integrator's largest step in its last sweep (metres)
  uint32_t unconverged = 0;    // 1 when that step exceeds the tolerance
  uint32_t bad_vertex = 0xFFFFFFFFu;  // smallest vertex that blew up
};

// A pair of cloth features within the thickness (sim/contact.h): a vertex and a triangle (v[0] the
// vertex, weights 1 and minus the barycentric weights of the triangle's nearest point) or two edges
// (weights 1 - s, s and -(1 - t), -t of their closest points); n is the direction the first
// feature keeps its distance along. v[0] = kNoPair marks an empty slot.
inline constexpr uint32_t kNoPair = 0xFFFFFFFFu;
struct ContactPair {
  uint32_t v[4] = {kNoPair, 0, 0, 0};
  float w[4] = {0, 0, 0, 0};
  Vec3 n;
};

// What a batch of steps did, summed over its steps (run_steps in sim/step.h, from the counters).
struct StepResult {
  uint64_t hits = 0;           // collision-buffer entries in the last step
  uint64_t pushed = 0;         // vertex-steps an obstacle at t + dt pushed out
  uint64_t clamped = 0;        // vertex-steps whose move the displacement bound shortened
  uint64_t conflicts = 0;      // vertex-steps the bound left inside an obstacle it had been pushed out of
  uint64_t push_clamped = 0;   // vertex-steps whose push out of an obstacle the bound shortened
  uint64_t refreshes = 0;      // steps that recomputed the displacement bound of every vertex
  uint64_t partial_refreshes = 0;  // steps that recomputed it for the vertices that needed room
  uint64_t contact_pairs = 0;  // vertex-steps' cloth pairs within the contact gap (sim/contact.h)
  uint64_t contact_moved = 0;  // vertex-steps the two-sided contact solve pushed
  uint64_t contact_rounds = 0; // position rounds of the contact solve that acted, summed over steps
  uint64_t bound_passes = 0;   // further passes of the bound (run_bound_passes), summed over steps
  double max_residual = 0;     // implicit integrator: the largest last-sweep step of any step (metres)
  uint64_t unconverged = 0;    // implicit integrator: steps whose last sweep still moved a vertex more than the tolerance
  int64_t bad_vertex = -1;     // first vertex that blew up, or -1
  uint64_t bad_step = 0;       // step (counted from the start of the run) where it did
};

// Adds one step's counters to a batch's result.
inline void add_step(StepResult& r, const StepCounters& c) {
  r.hits = c.hits;
  r.pushed += c.pushed;
  r.clamped += c.clamped;
  r.conflicts += c.conflicts;
  r.push_clamped += c.push_clamped;
  r.refreshes += c.refresh_made == kRefreshFull || c.bound_passes > 0 ? 1u : 0u;  // a pass refreshes in full
  r.partial_refreshes += c.refresh_made == kRefreshPartial && c.bound_passes == 0 ? 1u : 0u;
  r.contact_pairs += c.contact_pairs;
  r.contact_moved += c.contact_moved;
  r.contact_rounds += c.contact_rounds;
  r.bound_passes += c.bound_passes;
  r.max_residual = r.max_residual > double(float_from_bits(c.residual)) ? r.max_residual : double(float_from_bits(c.residual));
  r.unconverged += c.unconverged;
}

struct StepView {
  ModelView model;
  CollisionParams coll;
  CollisionGeometry geom;      // obstacle vertices/velocities at t + dt, cloth at x
  Vec3 gravity;
  float blowup_limit = 1e4f;   // |x| past this (metres) is a blow-up
  float sew = 1.0f;            // how far seams have closed (0 -> 1 over the model's sew_time)
  bool implicit = false;       // the implicit integrator (TimeDef::integrator), with its sweeps and tolerance
  uint32_t iterations = 10;
  float tolerance = 1e-4f;
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
  float* contact_shift = nullptr;
  // Further passes of the bound: per vertex the goal of the step (before any clamp) and where the
  // last pass left it.
  Vec3* x_goal = nullptr;
  Vec3* v_goal = nullptr;
  Vec3* x_mid = nullptr;  // per vertex: how far the contact solve moved it in this step
  Vec3* x_sweep = nullptr;       // implicit integrator: the iterate before the last sweep
  Vec3* x_sweep_prev = nullptr;  // and the one before that (Chebyshev acceleration)
  Vec3* plane_normal = nullptr;    // implicit integrator: the body plane each vertex is kept above
  Vec3* plane_velocity = nullptr;  // (0 normal: none), the surface's velocity there, and the
  float* plane_offset = nullptr;   // plane's offset (n . p >= offset)
  float* clearance = nullptr;      // per vertex: how far it can move before an obstacle could be near (stage_obstacles)
  // Two-sided contact (sim/contact.h): pair slots (contact_slots: per vertex, then per edge), and
  // per vertex the fixed-point sum (and count) of the corrections its pairs give it in a round.
  ContactPair* pairs = nullptr;
  uint32_t* pair_list = nullptr;   // the slots holding a pair this step, counters->contact_pairs of them
  FixedVec3* push = nullptr;
  uint32_t* push_count = nullptr;
  bool cloth_contact = true;       // the scene's collision.cloth_cloth
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
inline constexpr uint32_t kFlagContact = 32u; // the two-sided contact solve pushed it this step
inline constexpr uint32_t kFlagNearCloth = 64u; // a cloth triangle not its own is near it (sim/contact.h)
inline constexpr uint32_t kFlagSqueezed = 128u; // held between a body and cloth a body backs (sim/contact.h)

// How far off a body a squeezed vertex is held (a share of the thickness): a vertex between a body
// and cloth that another body (or another side of the body) pushes from the far side cannot be at
// the thickness from both; it yields into its own thickness toward the body, never into the body.
inline constexpr float kSqueezeOffset = 0.25f;
// The smallest body gap, as a share of the offset, that a pushed vertex is put halfway across
// (stage_obstacles).
inline constexpr float kPinchMinGap = 0.1f;



RC_HD bool is_representative(const ModelView& m, uint32_t i) { return m.alias[i] == i; }

// An attachment's pull on vertex i: a spring of rest length 0 to its body point at t + dt (lifted
// along the body triangle's normal), damped along the velocity relative to that point. While seams
// close the point starts at the vertex's start position and eases onto the body.
// Vertex i's attachment at t + dt: the body point it is pulled to, that point's velocity, the
// stiffness and the damping. False when it has none.
RC_HD bool attachment_target(const StepView& s, uint32_t i, Vec3& target, Vec3& target_v, float& k, float& kd) {
  const ModelView& m = s.model;
  if (!m.attach_slot || m.attach_slot[i] == kNoAttachment) return false;
  const uint32_t a = m.attach_slot[i];
  const uint32_t* t = s.geom.obstacle_indices + 3 * m.attach_tri[a];
  const Vec3* ov = s.geom.obstacle_vertices;
  const Vec3 w = m.attach_bary[a];
  const Vec3 n = triangle_normal(ov, s.geom.obstacle_indices, m.attach_tri[a]);
  target = ov[t[0]] * w.x + ov[t[1]] * w.y + ov[t[2]] * w.z + n * m.attach_lift[a] + m.attach_offset[a] * (1.0f - s.sew);
  target_v = make_vec3(0, 0, 0);
  if (s.geom.obstacle_velocities) {
    const Vec3* vv = s.geom.obstacle_velocities;
    target_v = vv[t[0]] * w.x + vv[t[1]] * w.y + vv[t[2]] * w.z;
  }
  k = m.attach_k[a];
  kd = m.attach_kd[a];
  return true;
}

RC_HD Vec3 attachment_force(const StepView& s, uint32_t i) {
  Vec3 target, target_v;
  float k, kd;
  if (!attachment_target(s, i, target, target_v, k, kd)) return make_vec3(0, 0, 0);
  return (target - s.x[i]) * k + (target_v - s.v[i]) * kd;
}

// The proposed x', v' ready (either integrator): the collision buffer cleared, the paper's ray along
// the move, and a runaway flagged.
RC_HD void finish_integrate(const StepView& s, uint32_t i) {
  s.contacts[i] = Contact();
  s.rays[i] = s.model.inv_mass[i] == 0.0f ? Ray() : velocity_ray(s.x[i], s.x_next[i], i, s.coll);
  s.rays[i].vertex = sew_group_of(s.model, i);  // its alias, or its sew group (model.tri_alias)
  // Checked before any response or bound can hide it: an unstable time step shows here first.
  const Vec3 vn = s.v_next[i];
  const bool runaway = !is_finite(vn) || !is_finite(s.x_next[i]) || fabsf(vn.x) > kRunawaySpeed ||
                       fabsf(vn.y) > kRunawaySpeed || fabsf(vn.z) > kRunawaySpeed;
  s.flags[i] = runaway ? kFlagBlowup : 0u;
}

// The paper's explicit Euler, eq. (3).
RC_HD void stage_integrate(const StepView& s, uint32_t i) {
  integrate_vertex(s.model, s.x, s.v, i, s.gravity, s.coll.dt, s.v_next[i], s.x_next[i], s.sew,
                   attachment_force(s, i));
  finish_integrate(s, i);
}

// The implicit integrator (physics.h, vbd_vertex): every vertex starts at its inertial target
// y = x + dt v + dt^2 g (a pinned one at x)...
RC_HD Vec3 inertial_target(const StepView& s, uint32_t i) {
  const float dt = s.coll.dt;
  return s.x[i] + s.v[i] * dt + s.gravity * (dt * dt);
}

RC_HD void stage_implicit_begin(const StepView& s, uint32_t i) {
  s.x_next[i] = s.model.inv_mass[i] == 0.0f || !is_representative(s.model, i) ? s.x[i] : inertial_target(s, i);
}

// ...then the colours are swept `iterations` times, one block-descent step per free vertex. In the
// last sweep the largest step taken is kept (counters->residual): how far from converged it was.
RC_HD void stage_implicit_vertex(const StepView& s, uint32_t i, bool last) {
  if (s.model.inv_mass[i] == 0.0f) return;
  Vec3 target = make_vec3(0, 0, 0), target_v = make_vec3(0, 0, 0);
  float ka = 0.0f, kad = 0.0f;
  attachment_target(s, i, target, target_v, ka, kad);
  Sym3 h;
  Vec3 next = vbd_vertex(s.model, s.x, s.x_next, i, inertial_target(s, i), s.coll.dt, s.sew, target, target_v, ka, kad, &h);
  const Vec3 n = s.plane_normal[i];
  if (n.x != 0.0f || n.y != 0.0f || n.z != 0.0f)
    next = plane_project(next, s.x[i], h, n, s.plane_offset[i], s.plane_velocity[i], s.coll.dt, s.coll.friction,
                         (1.0f / s.model.inv_mass[i]) * (1.0f / s.coll.dt + s.model.damping[i]) / s.coll.dt);
  if (last) atomic_max_nonneg(&s.counters->residual, length(next - s.x_next[i]));
  s.x_next[i] = next;
}

// Chebyshev acceleration of the sweeps (Wang, "A Chebyshev semi-iterative approach for accelerating
// projective and position-based dynamics", TOG 34(6), 2015; the vertex block descent paper uses it
// too): after sweep k the iterate is pushed on to omega_k (x_hat - x_{k-1}) + x_{k-1}, with
// omega_1 = 1, omega_2 = 2 / (2 - rho^2), omega_{k+1} = 4 / (4 - rho^2 omega_k), rho the estimated
// spectral radius of one sweep. kChebyshevRho was chosen on the peers' scene (docs/performance.md).
inline constexpr float kChebyshevRho = 0.9f;

RC_HD float chebyshev_omega(uint32_t sweep) {
  float omega = 1.0f;
  for (uint32_t k = 1; k <= sweep; ++k)
    omega = k == 1 ? 2.0f / (2.0f - kChebyshevRho * kChebyshevRho) : 4.0f / (4.0f - kChebyshevRho * kChebyshevRho * omega);
  return omega;
}

RC_HD void stage_sweep_save(const StepView& s, uint32_t i) { s.x_sweep[i] = s.x_next[i]; }

// omega: chebyshev_omega(sweep), computed once per sweep by the caller (1 for the first).
RC_HD void stage_sweep_accelerate(const StepView& s, uint32_t i, float omega) {
  if (s.model.inv_mass[i] == 0.0f || !is_representative(s.model, i)) return;
  if (omega != 1.0f) s.x_next[i] = s.x_sweep_prev[i] + (s.x_next[i] - s.x_sweep_prev[i]) * omega;
  s.x_sweep_prev[i] = s.x_sweep[i];
}

// One thread, after the sweeps: whether the last one still moved a vertex more than the tolerance.
RC_HD void stage_implicit_converged(const StepView& s) {
  s.counters->unconverged = float_from_bits(s.counters->residual) > s.tolerance ? 1u : 0u;
}

// ...and the velocity is the move over dt.
RC_HD void stage_implicit_end(const StepView& s, uint32_t i) {
  if (s.model.inv_mass[i] == 0.0f) {
    s.x_next[i] = s.x[i];
    s.v_next[i] = make_vec3(0, 0, 0);
  } else {
    s.v_next[i] = (s.x_next[i] - s.x[i]) / s.coll.dt;
  }
  finish_integrate(s, i);
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
  // A long implicit step: where the response acted, the position follows the velocity it left
  // (friction included), as the explicit step's x' = x + dt v' does; otherwise the cloth would slide
  // within the step as if there were no friction.
  if (s.implicit && s.contacts[i].w >= 0.0f && s.model.inv_mass[i] != 0.0f) s.x_next[i] = s.x[i] + s.v_next[i] * s.coll.dt;
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

// The implicit integrator's contact with the bodies inside the solve (after the offset contact of
// "Offset Geometric Contact", TOG 44(4), 2025, reduced to one plane per vertex): before the sweeps,
// every free vertex that a body at t + dt lies within reach of takes the plane tangent to the body
// at its nearest point, lifted by the thickness; every sweep keeps it on the plane's outer side, with
// friction (physics.h, plane_project). So the springs feel the body while the solve runs: without
// it the solve moved the cloth as if there were no body, the response then stopped the vertices
// that met it, and their neighbours were left stretched (10 % mean strain where the cloth lay on the
// sphere of the peers' scene at 1/60 s). The response, the contact solve and the bound still follow,
// unchanged: they make the guarantee. A vertex inside a body at t + dt gets no plane (the contact
// solve pushes it out).
RC_HD void stage_implicit_plane(const StepView& s, uint32_t i) {
  s.plane_normal[i] = make_vec3(0, 0, 0);
  if (s.model.inv_mass[i] == 0.0f || !is_representative(s.model, i) || s.obstacle_bvh.num_prims == 0) return;
  const Vec3 x = s.x[i];
  const float reach = s.coll.thickness + s.coll.tolerance + length(inertial_target(s, i) - x) + s.obstacle_reach;
  const ObstaclePoint q = nearest_obstacle_point(s, x, reach);
  if (!q.found) return;
  const Vec3 face = triangle_normal(s.geom.obstacle_vertices, s.geom.obstacle_indices, q.prim);
  const DVec3 d = dvec(x) - q.point;
  if (ddot(d, dvec(face)) < 0.0) return;
  const double dist = sqrt(q.dist2);
  const Vec3 n = dist > 1e-9 ? make_vec3(float(d.x / dist), float(d.y / dist), float(d.z / dist)) : face;
  s.plane_normal[i] = n;
  s.plane_offset[i] = float(ddot(dvec(n), q.point)) + s.coll.thickness;
  Vec3 w = make_vec3(0, 0, 0);
  if (s.geom.obstacle_velocities) {
    const uint32_t* t = s.geom.obstacle_indices + 3 * q.prim;
    const Vec3* ov = s.geom.obstacle_velocities;
    w = ov[t[0]] * float(q.wa) + ov[t[1]] * float(q.wb) + ov[t[2]] * float(q.wc);
  }
  s.plane_velocity[i] = w;
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

// Obstacles at t + dt: a vertex inside, or nearer than the thickness, goes to the thickness outside
// the nearest surface point and loses its velocity into the surface relative to the surface's own
// velocity there (friction on the rest).
// Sets clearance[i]: how far the vertex can move from here before it could come within the thickness
// of an obstacle (0 where it was pushed, or lies under a face), so that the contact solve's rounds
// only look again where it matters.
RC_HD void stage_obstacles(const StepView& s, uint32_t i) {
  if (!is_representative(s.model, i)) return;
  Vec3& xn = s.x_next[i];
  s.clearance[i] = INFINITY;
  // The distance kept from the body: the thickness, or a share of it for a squeezed vertex.
  const float offset = (s.flags[i] & kFlagSqueezed) ? kSqueezeOffset * s.coll.thickness : s.coll.thickness;
  if (s.model.inv_mass[i] != 0.0f && s.obstacle_bvh.num_prims > 0 && is_finite(xn)) {
    // A vertex outside at t can be at most its own move plus the obstacle's move inside at t + dt.
    const float reach = s.coll.thickness + length(xn - s.x[i]) + s.obstacle_reach;
    ObstaclePoint q = nearest_obstacle_point(s, xn, reach);
    s.clearance[i] = q.found ? 0.0f : reach - s.coll.thickness;
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
      const bool near = inside || dist < double(offset);
      if (!near && q.num_under == 0) s.clearance[i] = float(dist) - offset;
      if (near || q.num_under > 0) {
        const Vec3 before = xn;
        bool pushed = near, under = false;
        if (near) {
          const Vec3 surface = make_vec3(float(q.point.x), float(q.point.y), float(q.point.z));
          xn = surface + out * offset;
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
            xn = make_vec3(float(fpoint.x), float(fpoint.y), float(fpoint.z)) + fn * offset;
            out = fn;
            q.prim = f, q.wa = fp.wa, q.wb = fp.wb, q.wc = fp.wc;
            t = s.geom.obstacle_indices + 3 * f;
            moved = pushed = under = true;
          }
          if (!moved) break;
        }
        if (!pushed) return;
        // A pinch: where the body brings another of its surfaces within the offset in front of the
        // point it pushes the vertex out from (an arm against the side), the offset would put the
        // vertex inside that one. It goes halfway across the body's gap instead, outside both. A
        // face met within kPinchMinGap of the offset is a neighbour grazed at a crease or a surface
        // touching this one: halfway is then on the surface, where an open body's inside is not
        // defined, so the vertex takes the whole offset as before.
        {
          const Vec3 from = xn - out * offset;
          const float gap = pinch_gap_along(s, from, out, offset, q.prim);
          if (gap < offset && gap >= kPinchMinGap * offset) xn = from + out * (0.5f * gap);
        }
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
