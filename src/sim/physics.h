// Per-vertex cloth physics, host and device: eq. (2) spring forces gathered over the vertex's
// springs, gravity, viscous damping, and the explicit Euler step of eq. (3).
#pragma once
#include <cstdint>

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
      float mag = m.adj_k[e] * spring_stretch(len, rest, m.adj_rest[e]);
      if (m.adj_kd[e] != 0.0f) mag += m.adj_kd[e] * dot(v[j] - vi, dir);
      f += dir * mag;
    }
  }
  return f;
}

}  // namespace raycloth
