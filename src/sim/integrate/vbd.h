// The implicit integrator: implicit Euler by Vertex Block Descent, with contact inside the solve
// (the bodies: one plane per vertex; the cloth: a plane per nearby cloth triangle), the sweeps
// started where each vertex fell in the last step, and Chebyshev acceleration of the sweeps. It
// owns its scratch (VbdScratch) and its settings (sweeps, tolerance); sim/step.h calls integrate()
// and after_response().
#pragma once
#include <cstdint>
#include <vector>

#include "sim/integrate/common.h"
#include "sim/obstacle_query.h"
#include "sim/stage_time.h"

namespace raycloth {

// ---- The implicit integrator: implicit Euler by Vertex Block Descent ----------------------------
// (Chen, Macklin, Yuksel et al., "Vertex Block Descent", TOG 43(4), 2024.) Implicit Euler asks for
// the x' that makes
//   G_i(x') = m_i/dt^2 (x'_i - y_i) + m_i c_i/dt (x'_i - x_i) - F_i(x', v') = 0,   v' = (x' - x)/dt,
// with y = x + dt v + dt^2 g the inertial target, c the viscous damping and F the springs of eq. (2)
// (and their damping along the spring) plus an attachment's pull. Block descent sweeps the vertices
// one colour at a time (no two vertices of a colour share a spring) and takes, for each, one Newton
// step on its own 3x3 block with the others held: dx_i = -H_i^{-1} G_i, with
//   H_i = (m_i/dt^2 + m_i c_i/dt) I + sum_springs [k (d d^T + max(0, 1 - l/|x_j - x_i|)(I - d d^T))
//         + k_d/dt d d^T] (+ (k_a + k_ad/dt) I for an attachment, + sum w_r^2 I for hinges, + the membranes' blocks),
// the spring term's transverse part clamped at 0 so that H_i stays positive definite. Each such
// step lowers the incremental potential, so a sweep never diverges whatever dt is.
struct Sym3 {
  float xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
};

RC_HD void add_outer(Sym3& h, Vec3 d, float s) {
  h.xx += s * d.x * d.x, h.xy += s * d.x * d.y, h.xz += s * d.x * d.z;
  h.yy += s * d.y * d.y, h.yz += s * d.y * d.z, h.zz += s * d.z * d.z;
}

RC_HD void add_identity(Sym3& h, float s) { h.xx += s, h.yy += s, h.zz += s; }

// x with h x = b (h symmetric positive definite), by the adjugate; 0 when h is singular.
RC_HD Vec3 solve_sym3(const Sym3& h, Vec3 b) {
  const float c00 = h.yy * h.zz - h.yz * h.yz, c01 = h.xz * h.yz - h.xy * h.zz, c02 = h.xy * h.yz - h.xz * h.yy;
  const float det = h.xx * c00 + h.xy * c01 + h.xz * c02;
  if (!(fabsf(det) > 0.0f)) return make_vec3(0, 0, 0);
  const float c11 = h.xx * h.zz - h.xz * h.xz, c12 = h.xy * h.xz - h.xx * h.yz, c22 = h.xx * h.yy - h.xy * h.xy;
  const float inv = 1.0f / det;
  return make_vec3((c00 * b.x + c01 * b.y + c02 * b.z) * inv, (c01 * b.x + c11 * b.y + c12 * b.z) * inv,
                   (c02 * b.x + c12 * b.y + c22 * b.z) * inv);
}

// One block-descent step of vertex i (free): its new position, given the others' current guesses
// xn (its own included), its start x, v, the inertial target y_i, and an attachment's target point
// and velocity with stiffness ka and damping kad (ka = kad = 0 for none).
RC_HD Vec3 vbd_vertex(const ModelView& m, const Vec3* x, const Vec3* xn, uint32_t i, Vec3 y, float dt, float sew,
                      Vec3 attach_target, Vec3 attach_velocity, float ka, float kad, Sym3* h_out = nullptr) {
  const float mass = 1.0f / m.inv_mass[i];
  const float inertia = mass / (dt * dt), drag = mass * m.damping[i] / dt;
  const Vec3 xi = xn[i], vi = (xi - x[i]) / dt;
  Vec3 g = (xi - y) * inertia + (xi - x[i]) * drag;  // the gradient of the incremental potential
  Sym3 h;
  add_identity(h, inertia + drag);
  for (uint32_t e = m.adj_offset[i]; e < m.adj_offset[i + 1]; ++e) {
    const uint32_t j = m.adj_other[e];
    const Vec3 d = xn[j] - xi;
    const float len = length(d);
    if (!(len > 1e-12f)) continue;
    const Vec3 dir = d / len;
    float rest = m.adj_rest[e];
    if (m.adj_rest_start && sew < 1.0f) rest += (m.adj_rest_start[e] - rest) * (1.0f - sew);
    const float stretch = spring_stretch(len, rest, m.adj_rest[e]);
    const float k = m.adj_k[e], kd = m.adj_kd[e];
    // A stiffening spring (fabric/stiffening.h): its secant across, its tangent along.
    const float ks = m.adj_k_stiff ? fabric::stiffened(k, m.adj_k_stiff[e], stretch, rest) : k;
    float mag = ks * stretch;
    if (kd != 0.0f) mag += kd * dot((xn[j] - x[j]) / dt - vi, dir);
    g -= dir * mag;
    const float transverse = len > rest ? 1.0f - rest / len : 0.0f;
    add_identity(h, ks * transverse);
    const float along = m.adj_k_stiff ? fabric::stiffened_tangent(k, m.adj_k_stiff[e], stretch, rest) - ks * transverse
                                      : k * (1.0f - transverse);
    add_outer(h, dir, along + kd / dt);
  }
  // Hinge bending: linear in the positions, its block w_r^2 I.
  if (m.hinge_offset) {
    g -= hinge_force(m, xn, i);
    add_identity(h, hinge_stiffness(m, i));
  }
  // Membranes: their block with the coefficients held (sim/membrane.h).
  if (m.membrane_offset) {
    float b[6] = {0, 0, 0, 0, 0, 0};
    Vec3 fm = make_vec3(0, 0, 0);
    membrane_block(m, xn, i, b, &fm);
    g -= fm;
    h.xx += b[0], h.xy += b[1], h.xz += b[2], h.yy += b[3], h.yz += b[4], h.zz += b[5];
  }
  if (ka != 0.0f || kad != 0.0f) {
    g -= (attach_target - xi) * ka + (attach_velocity - vi) * kad;
    add_identity(h, ka + kad / dt);
  }
  if (h_out) *h_out = h;
  return xi - solve_sym3(h, g);
}

// Contact with a body inside the block step: the vertex's new position y (from vbd_vertex, whose
// block Hessian is h) is kept on the outer side of the plane n . p >= offset, the body's tangent
// plane lifted by the thickness. Where y lies behind it, the block's minimiser on the plane is
//   z = y + H^-1 n lambda,  lambda = (offset - n . y) / (n^T H^-1 n),
// lambda being the normal force the body gives; then Coulomb friction: the vertex's slide along the
// plane relative to the surface (start x, surface velocity w) is taken off as far as mu lambda can,
// the force to stop a slide u being inertia |u| (inertia: m/dt^2 + m c/dt, the block's own term:
// the cloth around slides with the vertex, so its springs do not resist the slide; counting them,
// a sheet on a slope slid as if there were no friction). A vertex in front of the plane is untouched.
RC_HD Vec3 plane_project(Vec3 y, Vec3 x, const Sym3& h, Vec3 n, float offset, Vec3 w, float dt, float mu, float inertia) {
  const float gap = offset - dot(n, y);
  if (!(gap > 0.0f)) return y;
  const Vec3 hn = solve_sym3(h, n);
  const float nhn = dot(n, hn);
  if (!(nhn > 0.0f)) return y;
  const float lambda = gap / nhn;
  Vec3 z = y + hn * lambda;
  Vec3 u = z - x - w * dt;
  u -= n * dot(n, u);
  const float slide = length(u);
  if (slide > 0.0f && inertia > 0.0f) z -= u * fminf(1.0f, mu * lambda / (inertia * slide));
  return z;
}

// The integrator's own view: its settings and its scratch arrays (VbdScratch).
struct VbdView {
  uint32_t iterations = 10;
  float tolerance = 1e-4f;
  Vec3* x_sweep = nullptr;         // the iterate before the last sweep
  Vec3* x_sweep_prev = nullptr;    // and the one before that (Chebyshev acceleration)
  Vec3* plane_normal = nullptr;    // the body plane each vertex is kept above (0 normal: none),
  Vec3* plane_velocity = nullptr;  // the surface's velocity there,
  float* plane_offset = nullptr;   // and the plane's offset (n . p >= offset)
  // The cloth each vertex is kept from inside the solve (stage_implicit_cloth): kSolveClothPairs
  // slots a vertex, each a cloth triangle (kNoSolvePair: none; kSolvePairFlip: the vertex lies on
  // the side its normal turns away from; kSolvePairFixed: the pair's direction is cloth_n's, not
  // the normal's), the barycentric weights of its point nearest the vertex, and that direction.
  uint32_t* cloth_tri = nullptr;
  Vec3* cloth_w = nullptr;
  Vec3* cloth_n = nullptr;
};

// The inertial target y = x + dt v + dt^2 g of vertex i.
RC_HD Vec3 inertial_target(const StepView& s, uint32_t i) {
  const float dt = s.ctx.dt;
  return s.x[i] + s.v[i] * dt + s.ctx.gravity * (dt * dt);
}

// The stages: the sweeps start where the vertex would go with the part of gravity it fell with in
// the last step (the adaptive start of the vertex block descent paper, section 3.7):
// x + dt v + dt^2 a g/|g|, a the last step's acceleration along gravity, (v - v_before) / dt . g/|g|,
// clamped to [0, |g|] (a pinned vertex stays at x). Starting at y instead (a = |g|), cloth that rests
// on a body or hangs from it starts every step dt^2 |g| (2.7 mm at 1/60 s) below where it balances
// and the stiff springs must lift it back within the sweeps: a sheet hanging from a pinned edge at
// 1/60 s and 10 sweeps was stretched 11 times as much as by the explicit step (mean strain 1.28 %
// against 0.116 %), and is as much with this start
// (Implicit.SweepsStartWhereTheClothFellSoHangingClothIsNotOverstretched). The first step
// (v_before = v = 0) starts at x.
RC_HD void stage_implicit_begin(const StepView& s, uint32_t i) {
  if (s.model.inv_mass[i] == 0.0f || !is_representative(s.model, i)) {
    s.x_next[i] = s.x[i];
    return;
  }
  const float dt = s.ctx.dt;
  const Vec3 g = s.ctx.gravity;
  const float gl = length(g);
  Vec3 fall = make_vec3(0, 0, 0);
  if (gl > 0.0f) {
    const Vec3 down = g / gl;
    const float a = fminf(fmaxf(dot(s.v[i] - s.v_before[i], down) / dt, 0.0f), gl);
    fall = down * (a * dt * dt);
  }
  s.v_before[i] = s.v[i];
  s.x_next[i] = s.x[i] + s.v[i] * dt + fall;
}

// The cloth inside the solve (the vertex-triangle contact of "Offset Geometric Contact", TOG 44(4),
// 2025, as one plane a pair). Before the sweeps (at a step's first substep, within reach of what the
// vertex can move in all of them) every free vertex takes its kSolveClothPairs nearest cloth
// triangles (not its own) within the thickness and tolerance plus twice its inertial move, each
// with the weights of the triangle's point nearest the vertex at x and a direction: the triangle's
// normal, turned to the vertex's side, where that point lies inside the triangle (recomputed at
// every block step from where the triangle is then); else the direction from the point to the
// vertex at x, kept for the step. Every block step then keeps the vertex the thickness on its side
// of each (plane_project, with friction against the point's motion), the triangle where the last
// sweep left it: a triangle's corners may be swept beside the vertex, in the same colour, so the
// one read is the sweep's start (x_sweep), the same whatever the threads' order. So a vertex that a
// fold or a pushed layer drives into other cloth stops against it within the solve and its springs
// feel that, instead of the bound holding it back after the solve while the vertices around it,
// solved as if it had moved, stretch its edges (on the peers' scene at 1/60 s: edges stretched to
// twice their length beside vertices the bound held back for good; docs/performance.md). The
// response, the contact solve and the bound follow unchanged: they make the guarantee.
inline constexpr uint32_t kSolveClothPairs = 2;
inline constexpr uint32_t kNoSolvePair = 0xFFFFFFFFu;
inline constexpr uint32_t kSolvePairFlip = 0x80000000u;
inline constexpr uint32_t kSolvePairFixed = 0x40000000u;

RC_HD void stage_implicit_cloth(const StepView& s, const VbdView& v, uint32_t i) {
  if (s.ctx.substep > 0u) return;
  uint32_t* slot = v.cloth_tri + size_t(i) * kSolveClothPairs;
  for (uint32_t k = 0; k < kSolveClothPairs; ++k) slot[k] = kNoSolvePair;
  if (!s.cloth_contact || s.model.inv_mass[i] == 0.0f || !is_representative(s.model, i) || s.cloth_bvh.num_prims == 0)
    return;
  const Vec3 x = s.x[i];
  const float parts = float(s.ctx.substeps);
  const float reach = s.coll.thickness + s.coll.tolerance + 2.0f * parts * length(inertial_target(s, i) - x);
  const DVec3 dx = dvec(x);
  struct Pair {
    uint32_t code;
    Vec3 w, dir;
  };
  uint32_t found = 0, keys[kSolveClothPairs] = {};
  double d2s[kSolveClothPairs] = {};
  Pair items[kSolveClothPairs] = {};
  Aabb query = aabb_grow(point_box(x), reach);
  const double limit2 = double(reach) * reach, eps = 1e-6;
  bvh_for_each_overlap(s.cloth_bvh, query, [&](uint32_t t) {
    const uint32_t* c = s.model.triangles + 3 * t;
    if (c[0] == i || c[1] == i || c[2] == i) return;
    const DVec3 a = dvec(s.x[c[0]]), b = dvec(s.x[c[1]]), d = dvec(s.x[c[2]]);
    const TrianglePoint q = closest_on_triangle(dx, a, b, d);
    if (!(q.dist2 < limit2)) return;
    const Vec3 n = triangle_normal(s.x, s.model.triangles, t);
    const DVec3 off = dx - (a * q.wa + b * q.wb + d * q.wc);
    const double side = ddot(off, dvec(n));
    const bool inside = q.wa > eps && q.wb > eps && q.wc > eps;
    if (inside && side == 0.0) return;
    const double len = sqrt(ddot(off, off));
    if (!inside && !(len > 1e-9)) return;
    Pair p;
    p.code = t | (inside ? (side < 0.0 ? kSolvePairFlip : 0u) : kSolvePairFixed);
    p.w = make_vec3(float(q.wa), float(q.wb), float(q.wc));
    p.dir = inside ? make_vec3(0, 0, 0) : make_vec3(float(off.x / len), float(off.y / len), float(off.z / len));
    keep_nearest(kSolveClothPairs, found, d2s, keys, items, q.dist2, t, p);
  });
  for (uint32_t k = 0; k < found; ++k) {
    slot[k] = items[k].code;
    v.cloth_w[size_t(i) * kSolveClothPairs + k] = items[k].w;
    v.cloth_n[size_t(i) * kSolveClothPairs + k] = items[k].dir;
  }
}

// Vertex i's block step `next` kept the thickness on its side of each of its cloth pairs (h: the
// block's Hessian; inertia: its own term, the friction's budget).
RC_HD Vec3 keep_off_cloth(const StepView& s, const VbdView& v, uint32_t i, Vec3 next, const Sym3& h, float inertia) {
  for (uint32_t k = 0; k < kSolveClothPairs; ++k) {
    const uint32_t code = v.cloth_tri[size_t(i) * kSolveClothPairs + k];
    if (code == kNoSolvePair) break;
    const uint32_t t = code & ~(kSolvePairFlip | kSolvePairFixed);
    const uint32_t* c = s.model.triangles + 3 * t;
    const Vec3 w = v.cloth_w[size_t(i) * kSolveClothPairs + k];
    const Vec3 a = v.x_sweep[c[0]], b = v.x_sweep[c[1]], d = v.x_sweep[c[2]];
    Vec3 n = v.cloth_n[size_t(i) * kSolveClothPairs + k];
    if (!(code & kSolvePairFixed)) n = triangle_normal(v.x_sweep, s.model.triangles, t);
    if (code & kSolvePairFlip) n = -n;
    if (n.x == 0.0f && n.y == 0.0f && n.z == 0.0f) continue;
    const Vec3 q = a * w.x + b * w.y + d * w.z;
    const Vec3 q0 = s.x[c[0]] * w.x + s.x[c[1]] * w.y + s.x[c[2]] * w.z;
    next = plane_project(next, s.x[i], h, n, dot(n, q) + s.coll.thickness, (q - q0) / s.ctx.dt, s.ctx.dt,
                         s.coll.friction, inertia);
  }
  return next;
}

// ...then the colours are swept `iterations` times, one block-descent step per free vertex. In the
// last sweep the largest step taken is kept (counters->residual): how far from converged it was.
RC_HD void stage_implicit_vertex(const StepView& s, const VbdView& v, uint32_t i, bool last) {
  if (s.model.inv_mass[i] == 0.0f) return;
  Vec3 target = make_vec3(0, 0, 0), target_v = make_vec3(0, 0, 0);
  float ka = 0.0f, kad = 0.0f;
  attachment_target(s, i, target, target_v, ka, kad);
  Sym3 h;
  Vec3 next = vbd_vertex(s.model, s.x, s.x_next, i, inertial_target(s, i), s.ctx.dt, s.ctx.sew, target, target_v, ka, kad, &h);
  const Vec3 n = v.plane_normal[i];
  const float inertia = (1.0f / s.model.inv_mass[i]) * (1.0f / s.ctx.dt + s.model.damping[i]) / s.ctx.dt;
  if (v.cloth_tri[size_t(i) * kSolveClothPairs] != kNoSolvePair) next = keep_off_cloth(s, v, i, next, h, inertia);
  if (n.x != 0.0f || n.y != 0.0f || n.z != 0.0f)
    next = plane_project(next, s.x[i], h, n, v.plane_offset[i], v.plane_velocity[i], s.ctx.dt, s.coll.friction, inertia);
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

RC_HD void stage_sweep_save(const StepView& s, const VbdView& v, uint32_t i) { v.x_sweep[i] = s.x_next[i]; }

// omega: chebyshev_omega(sweep), computed once per sweep by the caller (1 for the first). Where a
// body moves (the swept bound's steps, sim/swept_bound.h), a vertex kept off cloth inside the solve
// (keep_off_cloth) is not pushed on: its projection onto a triangle that its corners' own steps move
// is not a smooth iteration, and pushed on it grew without end (the peers' drape with the swept bound
// and no balls: a last sweep moving a vertex 2.6 m); the balls' clamp had hidden that.
RC_HD void stage_sweep_accelerate(const StepView& s, const VbdView& v, uint32_t i, float omega) {
  if (s.model.inv_mass[i] == 0.0f || !is_representative(s.model, i)) return;
  const bool kept_off_cloth = s.bodies_move && v.cloth_tri[size_t(i) * kSolveClothPairs] != kNoSolvePair;
  if (omega != 1.0f && !kept_off_cloth) s.x_next[i] = v.x_sweep_prev[i] + (s.x_next[i] - v.x_sweep_prev[i]) * omega;
  v.x_sweep_prev[i] = v.x_sweep[i];
}

// One thread, after the sweeps: whether the last one still moved a vertex more than the tolerance.
RC_HD void stage_implicit_converged(const StepView& s, const VbdView& v) {
  s.counters->unconverged = float_from_bits(s.counters->residual) > v.tolerance ? 1u : 0u;
}

// ...and the velocity is the move over dt.
RC_HD void stage_implicit_end(const StepView& s, uint32_t i) {
  if (s.model.inv_mass[i] == 0.0f) {
    s.x_next[i] = s.x[i];
    s.v_next[i] = make_vec3(0, 0, 0);
  } else {
    s.v_next[i] = (s.x_next[i] - s.x[i]) / s.ctx.dt;
  }
  finish_integrate(s, i);
}

// The implicit integrator's contact with the bodies inside the solve (after the offset contact of
// "Offset Geometric Contact", TOG 44(4), 2025, reduced to one plane per vertex): before the sweeps,
// every free vertex that a body at t + dt lies within reach of takes the plane tangent to the body
// at its nearest point, lifted by the thickness; every sweep keeps it on the plane's outer side, with
// friction (plane_project). So the springs feel the body while the solve runs (docs/performance.md
// has the strain without it). The response, the contact solve and the bound still follow,
// unchanged: they make the guarantee. A vertex inside a body at t + dt gets no plane (the contact
// solve pushes it out).
//
// Where the step is cut into substeps, the planes are taken at the first, within reach of what the
// vertex and the body can move in all of them, and each later substep moves a plane on with its body
// point (its offset by the point's speed along the normal): one nearest-point query a vertex a
// step instead of one a substep.
RC_HD void stage_implicit_plane(const StepView& s, const VbdView& v, uint32_t i) {
  if (s.ctx.substep > 0u) {
    const Vec3 n = v.plane_normal[i];
    if (n.x != 0.0f || n.y != 0.0f || n.z != 0.0f) v.plane_offset[i] += dot(n, v.plane_velocity[i]) * s.ctx.dt;
    return;
  }
  v.plane_normal[i] = make_vec3(0, 0, 0);
  if (s.model.inv_mass[i] == 0.0f || !is_representative(s.model, i) || s.obstacle_bvh.num_prims == 0) return;
  const Vec3 x = s.x[i];
  const float k = float(s.ctx.substeps);
  const float reach = s.coll.thickness + s.coll.tolerance + k * length(inertial_target(s, i) - x) + k * obstacle_reach(s);
  const ObstaclePoint q = nearest_obstacle_point(s, x, reach);
  if (!q.found) return;
  const Vec3 face = triangle_normal(s.geom.obstacle_vertices, s.geom.obstacle_indices, q.prim);
  const DVec3 d = dvec(x) - q.point;
  if (ddot(d, dvec(face)) < 0.0) return;
  const double dist = sqrt(q.dist2);
  const Vec3 n = dist > 1e-9 ? make_vec3(float(d.x / dist), float(d.y / dist), float(d.z / dist)) : face;
  v.plane_normal[i] = n;
  v.plane_offset[i] = float(ddot(dvec(n), q.point)) + s.coll.thickness;
  Vec3 w = make_vec3(0, 0, 0);
  if (s.geom.obstacle_velocities) {
    const uint32_t* t = s.geom.obstacle_indices + 3 * q.prim;
    const Vec3* ov = s.geom.obstacle_velocities;
    w = ov[t[0]] * float(q.wa) + ov[t[1]] * float(q.wb) + ov[t[2]] * float(q.wc);
  }
  v.plane_velocity[i] = w;
}

// Where the response acted, the position follows the velocity it left (friction included), as the
// explicit step's x' = x + dt v' does; otherwise the cloth would slide within a long step as if
// there were no friction.
RC_HD void stage_follow_response(const StepView& s, uint32_t i) {
  if (s.contacts[i].w >= 0.0f && s.model.inv_mass[i] != 0.0f) s.x_next[i] = s.x[i] + s.v_next[i] * s.ctx.dt;
}

// The sweeps of one step as phases (sim/stage_time.h): per sweep, the iterate saved, each colour in
// turn (colour c is color_vertices[color_first[c], color_first[c + 1])), then the acceleration
// (none after the last sweep). Phase 0 of a call is the start of sweep first_sweep.
inline constexpr uint32_t kMaxSweepColors = kMaxPhases - 2;

struct SweepPlan {
  uint32_t colors = 0;
  uint32_t first_sweep = 0;
  uint32_t color_first[kMaxSweepColors + 1] = {};
};

RC_HD void sweep_phase(const StepView& s, const VbdView& v, const SweepPlan& plan, uint32_t p, uint32_t k) {
  const uint32_t per = plan.colors + 2u, sweep = plan.first_sweep + p / per, r = p % per;
  if (r == 0u) {
    stage_sweep_save(s, v, k);
  } else if (r <= plan.colors) {
    stage_implicit_vertex(s, v, s.model.color_vertices[plan.color_first[r - 1u] + k], sweep + 1u == v.iterations);
  } else {
    stage_sweep_accelerate(s, v, k, chebyshev_omega(sweep));
  }
}

[[noreturn]] void throw_too_many_colors(uint32_t colors);

// The scratch arrays in the backend's memory (HostArray or DeviceBuffer), sized for n vertices.
template <template <class> class Array>
struct VbdScratch {
  Array<Vec3> x_sweep, x_sweep_prev, plane_normal, plane_velocity, cloth_w, cloth_n;
  Array<float> plane_offset;
  Array<uint32_t> cloth_tri;
  explicit VbdScratch(size_t n) {
    const std::vector<Vec3> zero(n, Vec3{});
    x_sweep = Array<Vec3>(zero);
    x_sweep_prev = Array<Vec3>(zero);
    plane_normal = Array<Vec3>(zero);
    plane_velocity = Array<Vec3>(zero);
    plane_offset = Array<float>(std::vector<float>(n, 0.0f));
    cloth_tri = Array<uint32_t>(std::vector<uint32_t>(n * kSolveClothPairs, kNoSolvePair));
    cloth_w = Array<Vec3>(std::vector<Vec3>(n * kSolveClothPairs, Vec3{}));
    cloth_n = Array<Vec3>(std::vector<Vec3>(n * kSolveClothPairs, Vec3{}));
  }
  VbdView view(uint32_t iterations, float tolerance) {
    return {iterations, tolerance, x_sweep.data(), x_sweep_prev.data(), plane_normal.data(), plane_velocity.data(),
            plane_offset.data(), cloth_tri.data(), cloth_w.data(), cloth_n.data()};
  }
};

// The integrator of sim/step.h.
template <template <class> class Array>
class VertexBlockDescent {
 public:
  // Its steps are long: a vertex falling freely may move farther in one than its ball allows, so
  // the bound's further passes always run and every clamped vertex is held back by it.
  static constexpr bool kLongSteps = true;

  VertexBlockDescent(size_t n, uint32_t iterations, float tolerance)
      : scratch_(n), iterations_(iterations), tolerance_(tolerance) {}

  // The sweeps of the steps that follow (a substep's share: StepClock).
  void set_iterations(uint32_t iterations) { iterations_ = iterations; }

  // Starts at the inertial target, takes the body planes, sweeps the colours `iterations` times
  // (each colour in parallel), and takes v' = (x' - x) / dt.
  template <class Exec>
  void integrate(Exec& ex, const StepView& s) {
    const VbdView v = scratch_.view(iterations_, tolerance_);
    const uint32_t n = s.model.num_vertices;
    ex.for_each(Stage::Integrate, n, [s] RC_LAMBDA(uint32_t i) { stage_implicit_begin(s, i); });
    ex.for_each(Stage::Integrate, n, [s, v] RC_LAMBDA(uint32_t i) { stage_implicit_plane(s, v, i); });
    ex.for_each(Stage::Integrate, n, [s, v] RC_LAMBDA(uint32_t i) { stage_implicit_cloth(s, v, i); });
    // The sweeps as phases (sim/stage_time.h), as many sweeps to a call as kMaxPhases holds.
    const uint32_t per = s.model.num_colors + 2u;
    if (s.model.num_colors > kMaxSweepColors) throw_too_many_colors(s.model.num_colors);
    SweepPlan plan;
    plan.colors = s.model.num_colors;
    for (uint32_t c = 0; c <= plan.colors; ++c) plan.color_first[c] = s.model.color_offset[c];
    for (uint32_t first = 0; first < v.iterations; first += kMaxPhases / per) {
      plan.first_sweep = first;
      PhaseSizes sizes;
      for (uint32_t sweep = first; sweep < v.iterations && sweep < first + kMaxPhases / per; ++sweep) {
        sizes.add(n);
        for (uint32_t c = 0; c < plan.colors; ++c) sizes.add(plan.color_first[c + 1] - plan.color_first[c]);
        sizes.add(sweep + 1 == v.iterations ? 0u : n);
      }
      ex.phases(Stage::Integrate, sizes, [s, v, plan] RC_LAMBDA(uint32_t p, uint32_t k) { sweep_phase(s, v, plan, p, k); });
    }
    ex.for_each(Stage::Integrate, 1, [s, v] RC_LAMBDA(uint32_t) { stage_implicit_converged(s, v); });
    ex.for_each(Stage::Integrate, n, [s] RC_LAMBDA(uint32_t i) { stage_implicit_end(s, i); });
  }

  template <class Exec>
  void after_response(Exec& ex, const StepView& s) {
    ex.for_each(Stage::Respond, s.model.num_vertices, [s] RC_LAMBDA(uint32_t i) { stage_follow_response(s, i); });
  }

 private:
  VbdScratch<Array> scratch_;
  uint32_t iterations_;
  float tolerance_;
};

}  // namespace raycloth
