// Per-vertex cloth physics, host and device: eq. (2) spring forces gathered over the vertex's
// springs, gravity, viscous damping, and the explicit Euler step of eq. (3).
#pragma once
#include <cstdint>

#include "raycloth/hd.h"
#include "raycloth/vec3.h"
#include "sim/model.h"

namespace raycloth {

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
      float mag = m.adj_k[e] * (len - rest);
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

}  // namespace raycloth
