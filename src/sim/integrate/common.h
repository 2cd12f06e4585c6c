// What both integrators share (sim/integrate/): an attachment's pull, and the proposed x', v' made
// ready for the response (the collision buffer cleared, the paper's ray along the move, a runaway
// flagged).
#pragma once
#include <cstdint>

#include "sim/physics.h"
#include "sim/step_view.h"

namespace raycloth {

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
  target = ov[t[0]] * w.x + ov[t[1]] * w.y + ov[t[2]] * w.z + n * m.attach_lift[a] + m.attach_offset[a] * (1.0f - s.ctx.sew);
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
  s.rays[i].vertex = i;  // the ray skips the collision triangles that have it as a corner (model.tri_alias)
  // Checked before any response or bound can hide it: an unstable time step shows here first.
  const Vec3 vn = s.v_next[i];
  const bool runaway = !is_finite(vn) || !is_finite(s.x_next[i]) || fabsf(vn.x) > kRunawaySpeed ||
                       fabsf(vn.y) > kRunawaySpeed || fabsf(vn.z) > kRunawaySpeed;
  s.flags[i] = runaway ? kFlagBlowup : 0u;
}

}  // namespace raycloth
