// Per-vertex cloth physics, host and device: eq. (2) spring forces gathered over the vertex's
// springs, hinge bending gathered over its hinges, gravity, viscous damping.
#pragma once
#include <cstdint>

#include "fabric/stiffening.h"
#include "raycloth/hd.h"
#include "raycloth/vec3.h"
#include "sim/membrane.h"
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

// Hinge bending (Hinge in sim/model.h): each of vertex i's hinges pulls it by -w_r (sum_j w_j x_j),
// the gradient of 1/2 |sum_j w_j x_j|^2 at its corner r. Zero where the model has no hinges.
RC_HD Vec3 hinge_force(const ModelView& m, const Vec3* x, uint32_t i) {
  Vec3 f = make_vec3(0, 0, 0);
  if (!m.hinge_offset) return f;
  for (uint32_t e = m.hinge_offset[i]; e < m.hinge_offset[i + 1]; ++e) {
    const uint32_t h = 4 * (m.hinge_entry[e] / 4), r = m.hinge_entry[e] % 4;
    // The weights sum to 0: the sum is taken from corner 0, translation-free (on a garment 1.2 m up,
    // the flat sheet's leftover force falls from 6e-5 to 4e-5 of a 1 mm fold's).
    const Vec3 x0 = x[m.hinge_vertex[h]];
    const Vec3 s = (x[m.hinge_vertex[h + 1]] - x0) * m.hinge_weight[h + 1] + (x[m.hinge_vertex[h + 2]] - x0) * m.hinge_weight[h + 2] +
                   (x[m.hinge_vertex[h + 3]] - x0) * m.hinge_weight[h + 3];
    f -= s * m.hinge_weight[h + r];
  }
  return f;
}

// The hinges' share of vertex i's block of the stiffness matrix: sum over its hinges of w_r^2 (times
// the identity).
RC_HD float hinge_stiffness(const ModelView& m, uint32_t i) {
  float k = 0.0f;
  if (!m.hinge_offset) return k;
  for (uint32_t e = m.hinge_offset[i]; e < m.hinge_offset[i + 1]; ++e) {
    const float w = m.hinge_weight[4 * (m.hinge_entry[e] / 4) + m.hinge_entry[e] % 4];
    k += w * w;
  }
  return k;
}

}  // namespace raycloth
