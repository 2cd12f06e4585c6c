// The measured fabrics' in-plane model on triangle meshes, host and device: an orthotropic membrane
// on each triangle, fitted to the measured model of Wang, Ramamoorthi and O'Brien (TOG 30(4), 2011;
// src/fabric/measured.h), instead of stretch springs along its edges, which cannot follow warp and
// weft apart (three spring directions fix the ratio of the sheet's cos 2a and cos 4a terms;
// docs/materials.md).
//
// Per triangle, in the warp (s) and weft (t) frame of its rest shape: F = Ds Dm^-1 (3 x 2), the
// Green strain G = (F^T F - I) / 2 and the energy per rest area
//   psi = P0(G_ss) + P2(G_tt) + k1 G_ss G_tt + 2 P3(G_st),
// each P the integral of a stress k(g) g whose stiffness grows linearly from a at no strain to a + b
// at the pull's Green strain at 1/6 (G1 = 1/6 + 1/72; half of it for the shear, which a pull at 45
// degrees strains by half) and stays there; compressed, a alone. It is an energy: the forces are its
// gradient (ARCSim's own, whose coefficients follow the principal strain's direction, are not, and a
// knit held stretched on triangles gained energy until it pulled 2 to 3 times its model).
// fabric::membrane_law fits a and b: at no strain the measured model exactly in every direction
// (row 0); at 1/6 the measured tension along the warp, the weft and 45 degrees between exactly.
#pragma once
#include <cmath>
#include <cstdint>

#include "raycloth/hd.h"
#include "raycloth/vec3.h"
#include "sim/model.h"

namespace raycloth {

// One direction's law (a, b, reach): the stress k(g) g, its tangent and its energy.
RC_HD float membrane_stress(float a, float b, float reach, float g) {
  if (!(g > 0.0f)) return a * g;
  return g < reach ? (a + b * g / reach) * g : (a + b) * g;
}
RC_HD float membrane_tangent(float a, float b, float reach, float g) {
  if (!(g > 0.0f)) return a;
  return g < reach ? a + 2.0f * b * g / reach : a + b;
}
RC_HD float membrane_potential(float a, float b, float reach, float g) {
  if (!(g > 0.0f)) return 0.5f * a * g * g;
  if (g < reach) return 0.5f * a * g * g + b * g * g * g / (3.0f * reach);
  return 0.5f * a * reach * reach + b * reach * reach / 3.0f + 0.5f * (a + b) * (g * g - reach * reach);
}

// One membrane triangle at positions x: its deformation gradient's columns (fs, ft), Green strain,
// stress S (sss, stt, sst), tangents and the shape-function gradients of its corners (gs, gt).
struct MembraneState {
  Vec3 fs, ft;
  float gss = 0, gtt = 0, gst = 0;
  float sss = 0, stt = 0, sst = 0;
  float t0 = 0, t2 = 0, t3 = 0, k1 = 0;  // dS_ss/dG_ss, dS_tt/dG_tt, dS_st/dG_st, dS_ss/dG_tt
  float gs[3] = {0, 0, 0}, gt[3] = {0, 0, 0};
  float area = 0;
};

RC_HD MembraneState membrane_state(const ModelView& m, const Vec3* x, uint32_t t) {
  MembraneState st;
  const uint32_t* v = m.membrane_vertex + 3 * t;
  const float* di = m.membrane_shape + 4 * t;  // Dm^-1, row-major: [[a, b], [c, d]]
  const Vec3 e1 = x[v[1]] - x[v[0]], e2 = x[v[2]] - x[v[0]];
  // F = [e1 e2] Dm^-1: column s = e1 a + e2 c, column t = e1 b + e2 d.
  st.fs = e1 * di[0] + e2 * di[2];
  st.ft = e1 * di[1] + e2 * di[3];
  st.gs[1] = di[0], st.gt[1] = di[1], st.gs[2] = di[2], st.gt[2] = di[3];
  st.gs[0] = -di[0] - di[2], st.gt[0] = -di[1] - di[3];
  st.gss = 0.5f * (dot(st.fs, st.fs) - 1.0f), st.gtt = 0.5f * (dot(st.ft, st.ft) - 1.0f), st.gst = 0.5f * dot(st.fs, st.ft);
  const float* p = m.membrane_law + kMembraneLaw * m.membrane_fabric[t];  // a0 b0 a2 b2 k1 a3 b3 G1
  const float reach = p[7];
  st.k1 = p[4];
  st.sss = membrane_stress(p[0], p[1], reach, st.gss) + st.k1 * st.gtt;
  st.stt = membrane_stress(p[2], p[3], reach, st.gtt) + st.k1 * st.gss;
  st.sst = membrane_stress(p[5], p[6], 0.5f * reach, fabsf(st.gst)) * (st.gst < 0.0f ? -1.0f : 1.0f);
  st.t0 = membrane_tangent(p[0], p[1], reach, st.gss);
  st.t2 = membrane_tangent(p[2], p[3], reach, st.gtt);
  st.t3 = membrane_tangent(p[5], p[6], 0.5f * reach, fabsf(st.gst));
  st.area = m.membrane_area[t];
  return st;
}

// The energy of membrane triangle t (its rest area times psi).
RC_HD float membrane_energy(const ModelView& m, const Vec3* x, uint32_t t) {
  const MembraneState st = membrane_state(m, x, t);
  const float* p = m.membrane_law + kMembraneLaw * m.membrane_fabric[t];
  return st.area * (membrane_potential(p[0], p[1], p[7], st.gss) + membrane_potential(p[2], p[3], p[7], st.gtt) +
                    st.k1 * st.gss * st.gtt + 2.0f * membrane_potential(p[5], p[6], 0.5f * p[7], fabsf(st.gst)));
}

// The force of membrane triangle t on its corner c: -A F S g_c.
RC_HD Vec3 membrane_corner_force(const MembraneState& st, uint32_t c) {
  const float ps = st.sss * st.gs[c] + st.sst * st.gt[c], pt = st.sst * st.gs[c] + st.stt * st.gt[c];
  return (st.fs * ps + st.ft * pt) * (-st.area);
}

// Vertex i's membrane force, gathered over its triangles (zero where the model has none).
RC_HD Vec3 membrane_force(const ModelView& m, const Vec3* x, uint32_t i) {
  Vec3 f = make_vec3(0, 0, 0);
  if (!m.membrane_offset) return f;
  for (uint32_t e = m.membrane_offset[i]; e < m.membrane_offset[i + 1]; ++e)
    f += membrane_corner_force(membrane_state(m, x, m.membrane_entry[e] / 3), m.membrane_entry[e] % 3);
  return f;
}

// Vertex i's block of the membranes' stiffness, for the implicit step (symmetric, 6 floats: xx, xy, xz,
// yy, yz, zz): A [max(0, g^T S g) I + F Q F^T], Q the 2 x 2 of the material part (dS = C dG with
// dG = sym(F^T d g^T), C the tangents), positive semi-definite where they are. With `f`, also adds
// vertex i's membrane force to it from the same states (membrane_force, not computed twice).
RC_HD void membrane_block(const ModelView& m, const Vec3* x, uint32_t i, float h[6], Vec3* f = nullptr) {
  if (!m.membrane_offset) return;
  for (uint32_t e = m.membrane_offset[i]; e < m.membrane_offset[i + 1]; ++e) {
    const MembraneState st = membrane_state(m, x, m.membrane_entry[e] / 3);
    const uint32_t c = m.membrane_entry[e] % 3;
    if (f) *f += membrane_corner_force(st, c);
    const float gs = st.gs[c], gt = st.gt[c];
    const float geometric = fmaxf(0.0f, gs * (st.sss * gs + st.sst * gt) + gt * (st.sst * gs + st.stt * gt));
    // Q columns: for u = e_s, dG = [[gs, gt / 2], [gt / 2, 0]]; for u = e_t, dG = [[0, gs / 2], [gs / 2, gt]].
    // dS g for each: (dSss gs + dSst gt, dSst gs + dStt gt).
    const float k0 = st.t0, k1 = st.k1, k2 = st.t2, k3 = st.t3;
    const float q00 = (k0 * gs) * gs + (k3 * 0.5f * gt) * gt, q10 = (k3 * 0.5f * gt) * gs + (k1 * gs) * gt;
    const float q01 = (k1 * gt) * gs + (k3 * 0.5f * gs) * gt, q11 = (k3 * 0.5f * gs) * gs + (k2 * gt) * gt;
    const float qs = 0.5f * (q10 + q01);  // symmetric by construction; averaged against rounding
    const Vec3 a = st.fs, b = st.ft;
    // F Q F^T = q00 a a^T + qs (a b^T + b a^T) + q11 b b^T
    const float A = st.area;
    h[0] += A * (geometric + q00 * a.x * a.x + 2.0f * qs * a.x * b.x + q11 * b.x * b.x);
    h[1] += A * (q00 * a.x * a.y + qs * (a.x * b.y + b.x * a.y) + q11 * b.x * b.y);
    h[2] += A * (q00 * a.x * a.z + qs * (a.x * b.z + b.x * a.z) + q11 * b.x * b.z);
    h[3] += A * (geometric + q00 * a.y * a.y + 2.0f * qs * a.y * b.y + q11 * b.y * b.y);
    h[4] += A * (q00 * a.y * a.z + qs * (a.y * b.z + b.y * a.z) + q11 * b.y * b.z);
    h[5] += A * (geometric + q00 * a.z * a.z + 2.0f * qs * a.z * b.z + q11 * b.z * b.z);
  }
}

}  // namespace raycloth
