// Per-vertex cloth physics, host and device: eq. (2) spring forces gathered over the vertex's
// springs, gravity, viscous damping, and the explicit Euler step of eq. (3).
#pragma once
#include <cstdint>

#include "fabric/stiffening.h"
#include "raycloth/hd.h"
#include "raycloth/vec3.h"
#include "sim/model.h"

namespace raycloth {

// A stitch (a spring whose rest length ends at 0: a seam sewn from apart) pulls as if stretched at
// most this far (metres): where the body stands in a stitch's way the pull stays bounded (200 N/m:
// 2 N) instead of growing with the gap until the vertices run away.
inline constexpr float kStitchMaxStretch = 0.01f;
RC_HD float spring_stretch(float len, float rest, float final_rest) {
  const float s = len - rest;
  return final_rest == 0.0f && s > kStitchMaxStretch ? kStitchMaxStretch : s;
}

// Eq. (2): each spring pulls with k (|d| - l0) along d = p_other - p_self; optional damping along
// the spring. A zero-length seam spring at zero length pulls with no force. While seams close
// (m.adj_rest_start set), l0 goes from the start length to the rest length as `sew` goes 0 -> 1.
RC_HD Vec3 spring_force(const ModelView& m, const Vec3* x, const Vec3* v, uint32_t i, float sew = 1.0f) {
  Vec3 f = make_vec3(0, 0, 0);
  const Vec3 xi = x[i], vi = v[i];
  for (uint32_t e = m.adj_offset[i]; e < m.adj_offset[i + 1]; ++e) {
    const uint32_t j = m.adj_other[e];
    const Vec3 d = x[j] - xi;
    const float len = length(d);
    if (len > 1e-12f) {
      const Vec3 dir = d / len;
      float rest = m.adj_rest[e];
      if (m.adj_rest_start && sew < 1.0f) rest += (m.adj_rest_start[e] - rest) * (1.0f - sew);
      const float stretch = spring_stretch(len, rest, m.adj_rest[e]);
      const float k = m.adj_k_stiff ? fabric::stiffened(m.adj_k[e], m.adj_k_stiff[e], stretch, rest) : m.adj_k[e];
      float mag = k * stretch;
      if (m.adj_kd[e] != 0.0f) mag += m.adj_kd[e] * dot(v[j] - vi, dir);
      f += dir * mag;
    }
  }
  return f;
}

// Eq. (3): a = f / m, v' = v + dt a, x' = x + dt v'. Pinned vertices (inv_mass 0) stay put.
// `external` is any other force on the vertex (an attachment's pull).
RC_HD void integrate_vertex(const ModelView& m, const Vec3* x, const Vec3* v, uint32_t i, Vec3 gravity, float dt,
                            Vec3& v_next, Vec3& x_next, float sew = 1.0f, Vec3 external = Vec3{0, 0, 0}) {
  const float inv_mass = m.inv_mass[i];
  if (inv_mass == 0.0f) {
    v_next = make_vec3(0, 0, 0);
    x_next = x[i];
    return;
  }
  const Vec3 a = (spring_force(m, x, v, i, sew) + external) * inv_mass + gravity - v[i] * m.damping[i];
  v_next = v[i] + a * dt;
  x_next = x[i] + v_next * dt;
}

// ---- The implicit integrator: implicit Euler by Vertex Block Descent ----------------------------
// (Chen, Macklin, Yuksel et al., "Vertex Block Descent", TOG 43(4), 2024.) Implicit Euler asks for
// the x' that makes
//   G_i(x') = m_i/dt^2 (x'_i - y_i) + m_i c_i/dt (x'_i - x_i) - F_i(x', v') = 0,   v' = (x' - x)/dt,
// with y = x + dt v + dt^2 g the inertial target, c the viscous damping and F the springs of eq. (2)
// (and their damping along the spring) plus an attachment's pull. Block descent sweeps the vertices
// one colour at a time (no two vertices of a colour share a spring) and takes, for each, one Newton
// step on its own 3x3 block with the others held: dx_i = -H_i^{-1} G_i, with
//   H_i = (m_i/dt^2 + m_i c_i/dt) I + sum_springs [k (d d^T + max(0, 1 - l/|x_j - x_i|)(I - d d^T))
//         + k_d/dt d d^T] (+ (k_a + k_ad/dt) I for an attachment),
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

}  // namespace raycloth
